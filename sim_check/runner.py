"""One closed-loop run: SUMO through libsumo, sensing, the generated controller, the runtime monitor, metrics.

One libsumo simulation per process (libsumo keeps one global simulation); the sweep runs each run in a worker
process. For the generated machines, MOBIL and "without", SUMO's own lane changing is off for the AVs
(laneChangeMode 0): every lane change they make is one the controller commanded, executed by SUMO even where
unsafe, so the controller's own safety is what is measured. For SUMO's models the AV keeps SUMO's defaults.

Besides the paper's metrics, each AV records why it changed lane or did not (the mechanism): the episodes in
which N held, whether the AV changed lane in each or it was never resolved, whether a safe gap towards the
wanted side was seen and not taken (deferred), and the time spent in each state of the machine.
"""

from __future__ import annotations

import hashlib
import time
from collections import deque
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from sim_check import mobil
from sim_check.controllers import Controller, Setup, load_controller, setup_of
from sim_check.scenario import Scenario, build, sumo_bin
from sim_check.sensing import Claim, Leader, Network, Sensed, decides_on, sense

MARKS_KM = (5, 10, 15, 20)
EMERGENCY_DECEL = 4.5  # m/s²: braking harder than this is counted as emergency braking
DWELL_S = 3.0  # a commanded lane change is not repeated within this time (SUMO's change is instantaneous)
TRACE_STEPS = 20  # steps of history stored with a monitor violation
SIM_LIMIT_S = 3600.0
SAMPLE_STEPS = 10  # the background traffic's speed is sampled every this many steps
STATES = ("IDLE", "WAITING", "MOVING_LEFT", "MOVING_RIGHT")


MECHANISM = ("needs", "needs_moved", "needs_open", "needs_deferred", "need_s", "deferred_s")


@dataclass
class AvMetrics:
    av: str
    lane_changes: list[float] = field(default_factory=list)  # odometer (m) at each change
    collisions: int = 0
    emergency_brakes: int = 0
    min_time_gap_s: float | None = None
    depart_s: float | None = None
    arrive_s: float | None = None
    distance_m: float = 0.0
    monitor_violations: int = 0
    mingap_contacts: int = 0  # AV pairs closer than the follower's minGap: SUMO's default collision criterion
    needs: int = 0  # episodes in which N held
    needs_moved: int = 0  # of those, episodes in which the AV changed lane
    needs_open: int = 0  # of those, episodes still open when the AV arrived: the need was never resolved
    needs_deferred: int = 0  # of those, episodes in which a safe gap towards the wanted side was not taken
    need_s: float = 0.0
    deferred_s: float = 0.0
    state_s: dict[str, float] = field(default_factory=dict)
    sensed: bool = False  # whether N, W, L and R were computed (not for SUMO's own models nor MOBIL)

    def changes_by(self, km: int) -> int:
        return sum(1 for d in self.lane_changes if d <= km * 1000.0)

    def row(self) -> dict[str, Any]:
        travel = None if self.arrive_s is None or self.depart_s is None else self.arrive_s - self.depart_s
        return {
            "av": self.av,
            **{f"lc_{km}km": self.changes_by(km) for km in MARKS_KM},
            "collisions": self.collisions,
            "emergency_brakes": self.emergency_brakes,
            "min_time_gap_s": self.min_time_gap_s,
            "travel_time_s": travel,
            "mean_speed_ms": None if not travel else self.distance_m / travel,
            "arrived": self.arrive_s is not None,
            "monitor_violations": self.monitor_violations,
            "mingap_contacts": self.mingap_contacts,
            **{k: (getattr(self, k) if self.sensed else None) for k in MECHANISM},
            **{f"{state.lower()}_s": self.state_s.get(state) for state in STATES},
        }


@dataclass
class RunResult:
    controller: str
    avs: int
    seed: int
    status: str = "done"  # done, failed
    reason: str = ""
    sim_steps: int = 0
    wall_s: float = 0.0
    vehicle_steps: int = 0
    collisions: int = 0
    bg_mean_speed_ms: float | None = None  # the other traffic, sampled every SAMPLE_STEPS steps
    trajectory_sha256: str = ""
    metrics: list[AvMetrics] = field(default_factory=list)
    violations: list[dict[str, Any]] = field(default_factory=list)

    @property
    def monitor_violations(self) -> int:
        return len(self.violations)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["metrics"] = [m.row() for m in self.metrics]
        return data


@dataclass
class Need:
    """The N episode an AV is in: whether the AV has changed lane in it, or passed up a safe gap."""

    moved: bool = False
    deferred: bool = False


class Reads:
    """The SUMO getters the loop calls every step, bound once per run. Where `sumo` is libsumo, its compiled
    functions are bound directly: libsumo's Python methods only forward to them, and the extra Python call per
    read is a good part of what the loop costs beside SUMO's own step. The values are the same, but for getLeader's
    "no leader", ("", -1.0) here where libsumo's method returns None."""

    def __init__(self, sumo: Any) -> None:
        compiled = getattr(sumo, "_libsumo", None)

        def bind(domain: str, name: str) -> Any:
            if compiled is not None:
                return getattr(compiled, f"{domain}_{name}")
            return getattr(getattr(sumo, domain), name)

        self.departed = bind("simulation", "getDepartedIDList")
        self.arrived = bind("simulation", "getArrivedIDList")
        self.collisions = bind("simulation", "getCollisions")
        self.road = bind("vehicle", "getRoadID")
        self.lane = bind("vehicle", "getLaneIndex")
        self.position = bind("vehicle", "getLanePosition")
        self.distance = bind("vehicle", "getDistance")
        self.acceleration = bind("vehicle", "getAcceleration")
        self.speed = bind("vehicle", "getSpeed")
        self.leader = bind("vehicle", "getLeader")
        self.follower = bind("vehicle", "getFollower")
        self.edge_vehicles = bind("edge", "getLastStepVehicleNumber")
        self.edge_speed = bind("edge", "getLastStepMeanSpeed")


class ClosedLoop:
    """The state of one run between steps."""

    def __init__(self, sumo: Any, setup: Setup, scenario: Scenario, av_ids: tuple[str, ...]) -> None:
        self.sumo = sumo
        self.read = Reads(sumo)
        self.network = Network(sumo)
        self.setup = setup
        self.ctrl: Controller | None = load_controller(setup.name) if setup.kind == "fsm" else None
        self.scenario = scenario
        self.target = scenario.target_lane
        self.state: dict[str, int] = {}
        self.metrics = {av: AvMetrics(av, sensed=setup.kind in ("fsm", "without")) for av in av_ids}
        self.last_change: dict[str, float] = {}
        self.place: dict[str, tuple[str, int]] = {}
        self.braking: dict[str, bool] = {}
        self.need: dict[str, Need] = {}
        self.close: dict[str, set[str]] = {av: set() for av in av_ids}
        # (time, state, inputs, next state) of the last steps, turned into the stored trace on a violation
        self.history: dict[str, deque[tuple[float, int, dict[str, bool], int]]] = {
            av: deque(maxlen=TRACE_STEPS) for av in av_ids
        }
        self.violations: list[dict[str, Any]] = []
        self.pairs: set[tuple[str, str]] = set()
        # (AV, edge, lane, position) of every AV every step: hashed once at the end (trajectory_sha256), in one
        # tight pass rather than a formatting and a hash call between two SUMO steps
        self.trail: list[tuple[str, str, int, float]] = []
        self.dt = scenario.traffic.step_s
        self.steps = 0
        self.bg_speed = [0.0, 0]  # sum of sampled speeds, number of samples
        self.edges: list[str] = []
        self.arrived = 0

    def step(self, t: float) -> None:
        read = self.read
        for av in read.departed():
            if av in self.metrics:
                if self.setup.kind != "sumo":
                    self.sumo.vehicle.setLaneChangeMode(av, 0)
                self.state[av] = self.ctrl.initial if self.ctrl else 0
                self.metrics[av].depart_s = t
        for av in read.arrived():
            if av in self.metrics:
                self.metrics[av].arrive_s = t
                self.arrived += 1
                self.state.pop(av, None)
                if self.need.pop(av, None) is not None:
                    self.metrics[av].needs_open += 1
        collisions = read.collisions()
        if collisions:
            self.collide(collisions)
        claims: list[Claim] = []
        speeds = 0.0
        for av in sorted(self.state):
            where, leader, speed = self.observe(av)
            speeds += speed
            self.decide(av, t, claims, where, leader=leader, speed=speed)
        self.steps += 1
        if self.steps % SAMPLE_STEPS == 0:
            self.sample(speeds, len(self.state))

    def sample(self, av_speeds: float, avs: int) -> None:
        """Add the other traffic's speeds this step (every vehicle on a normal edge, less the AVs)."""
        if not self.edges:
            self.edges = [e for e in self.sumo.edge.getIDList() if not e.startswith(":")]
        total, count = -av_speeds, -avs
        for e in self.edges:
            n = self.read.edge_vehicles(e)
            if n:
                total += self.read.edge_speed(e) * n
                count += n
        if count > 0:
            self.bg_speed[0] += total
            self.bg_speed[1] += count

    def collide(self, collisions: Any) -> None:
        """Count the colliding pairs SUMO reports this step (a pair is counted once, however long it touches)."""
        for c in collisions:
            pair = tuple(sorted((c.collider, c.victim)))
            if pair in self.pairs:
                continue
            self.pairs.add(pair)
            for vid in pair:
                if vid in self.metrics:
                    self.metrics[vid].collisions += 1

    def observe(self, av: str) -> tuple[tuple[str, int, float], Leader, float]:
        read, m = self.read, self.metrics[av]
        edge, lane, pos = read.road(av), read.lane(av), read.position(av)
        m.distance_m = read.distance(av)
        before = self.place.get(av)
        if before is not None and before[0] == edge and before[1] != lane and not edge.startswith(":"):
            m.lane_changes.append(m.distance_m)
            need = self.need.get(av)
            if need is not None and not need.moved:
                need.moved = True
                m.needs_moved += 1
        self.place[av] = (edge, lane)
        braking = read.acceleration(av) < -EMERGENCY_DECEL
        if braking and not self.braking.get(av, False):
            m.emergency_brakes += 1
        self.braking[av] = braking
        speed = read.speed(av)
        found = read.leader(av, 250.0)
        leader: Leader = found if found and found[0] else None
        if leader is not None and speed > 1.0:
            gap = max(leader[1], 0.0) / speed
            m.min_time_gap_s = gap if m.min_time_gap_s is None else min(m.min_time_gap_s, gap)
        self.mingap(av, leader, read.follower(av, 50.0))
        self.trail.append((av, edge, lane, pos))
        return (edge, lane, pos), leader, speed

    def trajectory_sha256(self) -> str:
        """The hash of every AV's edge, lane and position (to the millimetre), step by step."""
        lines = "".join(f"{av}|{edge}|{lane}|{pos:.3f}\n" for av, edge, lane, pos in self.trail)
        return hashlib.sha256(lines.encode()).hexdigest()

    def mingap(self, av: str, leader: Leader, follower: tuple[str, float]) -> None:
        """SUMO's default collision criterion, counted beside the physical one: libsumo's gaps already subtract
        the follower's minGap, so a negative gap to the leader or from the follower is a min-gap contact.
        `follower` is ("", -1.0) when there is none."""
        now: set[str] = set()
        if leader is not None and leader[1] < 0.0:
            now.add(leader[0])
        if follower[0] and follower[1] < 0.0:
            now.add(follower[0])
        before = self.close[av]
        if now or before:  # most steps have no contact now nor in the step before
            self.metrics[av].mingap_contacts += len(now - before)
            self.close[av] = now

    def decide(
        self, av: str, t: float, claims: list[Claim], where: tuple[str, int, float], *, leader: Leader, speed: float
    ) -> None:
        kind = self.setup.kind
        if kind == "sumo":
            return
        if kind == "mobil":
            self.decide_mobil(av, t, where, leader)
            return
        sensed = sense(self.sumo, av, self.target, claims, where, network=self.network, leader=leader, speed=speed)
        if sensed is None:
            return
        # "without" goes wherever N points (the direction is 0 exactly when N does not hold)
        side = self.machine(av, t, sensed) if kind == "fsm" else sensed.direction
        if side and self.command(av, t, sensed.lane + side) and kind == "fsm":
            claims.append(Claim(av, sensed.edge, sensed.lane + side, where[2]))
        self.account(av, sensed, side)

    def machine(self, av: str, t: float, sensed: Sensed) -> int:
        """One step of the generated machine and its runtime monitor; the side it moves to (+1, -1 or 0)."""
        ctrl = self.ctrl
        assert ctrl is not None
        old, inputs = self.state[av], sensed.inputs
        new, holds = ctrl.advance(old, inputs)
        self.state[av] = new
        name = ctrl.states[new]
        state_s = self.metrics[av].state_s
        state_s[name] = state_s.get(name, 0.0) + self.dt
        self.history[av].append((t, old, inputs, new))
        if not holds:
            self.violation(av, t, ctrl.failing(new, inputs))
        return 1 if name == "MOVING_LEFT" else -1 if name == "MOVING_RIGHT" else 0

    def violation(self, av: str, t: float, failing: list[str]) -> None:
        """Store a runtime-monitor violation with the steps that led to it."""
        assert self.ctrl is not None
        names = self.ctrl.states
        trace = [
            {"t": round(when, 3), "state": names[old], "inputs": inputs, "next": names[new]}
            for when, old, inputs, new in self.history[av]
        ]
        self.metrics[av].monitor_violations += 1
        self.violations.append({"av": av, "time_s": round(t, 3), "invariants": failing, "trace": trace})

    def command(self, av: str, t: float, target: int) -> bool:
        """Ask SUMO for a lane change, at most once per DWELL_S (SUMO's change is instantaneous)."""
        if t - self.last_change.get(av, -1e9) < DWELL_S:
            return False
        self.sumo.vehicle.changeLane(av, target, 1.0)
        self.last_change[av] = t
        return True

    def account(self, av: str, sensed: Sensed, side: int) -> None:
        """The mechanism: N episodes, and safe gaps towards the wanted side that the controller did not take."""
        m, inputs = self.metrics[av], sensed.inputs
        if not inputs["N"]:
            self.need.pop(av, None)
            return
        need = self.need.get(av)
        if need is None:
            need = self.need[av] = Need()
            m.needs += 1
        m.need_s += self.dt
        if (inputs["L"] or inputs["R"]) and not side:
            m.deferred_s += self.dt
            if not need.deferred:
                need.deferred = True
                m.needs_deferred += 1

    def decide_mobil(self, av: str, t: float, where: tuple[str, int, float], leader: Leader) -> None:
        edge, lane, pos = where
        if not decides_on(edge):
            return
        lanes = self.network.lanes(edge)
        end = self.network.lane_end(edge, lane, pos)
        lowest = 1 if edge == "acc" and lane > 0 else 0
        side = mobil.decide(self.sumo, av, lane, lanes, leader=leader, lane_end=end, lowest=lowest)
        if side:
            self.command(av, t, lane + side)

    @property
    def done(self) -> bool:
        return self.arrived == len(self.metrics)


def sumo_args(scenario: Scenario, net: Path, routes: Path, seed: int, options: tuple[str, ...] = ()) -> list[str]:
    return [
        sumo_bin("sumo"), "-n", str(net), "-r", str(routes), "--seed", str(seed),
        "--step-length", str(scenario.traffic.step_s),
        "--collision.action", "warn", "--collision.check-junctions", "true", "--collision.mingap-factor", "0",
        "--no-step-log", "true", "--duration-log.disable", "true", "--no-warnings", "true", *options,
    ]  # fmt: skip


def run_once(
    scenario: Scenario,
    controller: str,
    seed: int,
    work: Path,
    *,
    setup: Setup | None = None,
    limit_s: float = SIM_LIMIT_S,
) -> RunResult:
    """One run, start to finish; raises on a simulator failure (the sweep records it). `setup` replaces the
    controller's registered setup (a benchmark varying SUMO options); a run whose AVs have not all arrived after
    `limit_s` simulated seconds fails."""
    import libsumo

    start = time.perf_counter()
    setup = setup or setup_of(controller)
    built = build(scenario, seed, work, setup.av_type)
    if setup.kind == "fsm":
        load_controller(controller)  # compiled before SUMO starts; cached for the loop
    libsumo.start(sumo_args(scenario, built.net, built.routes, seed, setup.options))
    loop = ClosedLoop(libsumo, setup, scenario, built.av_ids)
    result = RunResult(controller, scenario.traffic.avs, seed)
    try:
        while True:
            libsumo.simulationStep()
            t = libsumo.simulation.getTime()
            result.sim_steps += 1
            result.vehicle_steps += libsumo.vehicle.getIDCount()
            loop.step(t)
            if loop.done:
                break
            if t > limit_s:
                result.status, result.reason = "failed", f"AVs had not arrived after {limit_s:.0f} simulated s"
                break
    finally:
        libsumo.close()
    result.collisions = len(loop.pairs)
    result.bg_mean_speed_ms = loop.bg_speed[0] / loop.bg_speed[1] if loop.bg_speed[1] else None
    result.metrics = [loop.metrics[av] for av in built.av_ids]
    result.violations = loop.violations
    result.trajectory_sha256 = loop.trajectory_sha256()
    result.wall_s = time.perf_counter() - start
    return result


def run_plain(
    scenario: Scenario, seed: int, work: Path, *, setup: Setup | None = None, limit_s: float = SIM_LIMIT_S
) -> tuple[float, int, int]:
    """The same run with SUMO alone, the floor a closed-loop run is measured against (for the benchmarks): no
    sensing, controller, monitor or metrics; the AVs drive by SUMO's own models under the setup's vType and
    options (LC2013's by default); stepped from Python until every AV has arrived or `limit_s` has passed.
    Returns the wall seconds from SUMO's start, the steps and the vehicle-steps."""
    import libsumo

    setup = setup or setup_of("lc2013")
    built = build(scenario, seed, work, setup.av_type)
    start = time.perf_counter()
    libsumo.start(sumo_args(scenario, built.net, built.routes, seed, setup.options))
    waiting, steps, vehicle_steps = set(built.av_ids), 0, 0
    try:
        while waiting and libsumo.simulation.getTime() <= limit_s:
            libsumo.simulationStep()
            steps += 1
            vehicle_steps += libsumo.vehicle.getIDCount()
            waiting.difference_update(libsumo.simulation.getArrivedIDList())
    finally:
        libsumo.close()
    return time.perf_counter() - start, steps, vehicle_steps
