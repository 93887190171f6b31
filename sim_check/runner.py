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
import math
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from mlca_verify.targets import HOLDS, STATE_BITS
from sim_check import mobil
from sim_check.controllers import Controller, Setup, load_controller, setup_of
from sim_check.reads import Leader, Reads
from sim_check.results import AvMetrics, RunResult, Violation
from sim_check.scenario import Scenario, build, sumo_command
from sim_check.sensing import LaneClaim, Network, decides_on, sense

EMERGENCY_DECEL = 4.5  # m/s²: braking harder than this is counted as emergency braking
DWELL_S = 3.0  # a commanded lane change is not repeated within this time (SUMO's change is instantaneous)
TRACE_STEPS = 20  # steps of history stored with a monitor violation
SIM_LIMIT_S = 3600.0
SAMPLE_STEPS = 10  # the background traffic's speed is sampled every this many steps
SIDES = {"MOVING_LEFT": +1, "MOVING_RIGHT": -1}  # the states that move the AV, and the side they move it to


@dataclass
class Need:
    """The N episode an AV is in: whether the AV has changed lane in it, or passed up a safe gap."""

    moved: bool = False
    deferred: bool = False


History = deque[tuple[float, int, dict[str, bool], int]]


@dataclass(slots=True, eq=False)
class Driving:
    """What the loop keeps of one AV from its departure to its arrival."""

    id: str
    m: AvMetrics
    state: int  # the generated machine's state (fsm controllers)
    state_s: list[float]  # seconds spent in each state of the machine, by state
    history: History  # (time, state, inputs, next state) of the last steps, the trace stored with a violation
    edge: str = ""  # where the AV was the step before
    lane: int = -1
    braking: bool = False  # whether it braked harder than EMERGENCY_DECEL the step before
    close: set[str] = field(default_factory=set)  # vehicles within its minGap the step before
    need: Need | None = None  # the N episode it is in
    last_change: float = -math.inf  # when it was last commanded to change lane


class ClosedLoop:
    """The state of one run between steps.

    Its step runs between two SUMO steps, every step of every run, and SUMO's step leaves the caches cold for it:
    each Python call and each object it touches costs there several times what it costs in a warm loop. So a
    step keeps each AV's state in one object (`Driving`), reads through the bound `Reads`, and keeps to a few
    calls per AV: observing it (`drive`), sensing, the machine and its monitor, the mechanism's accounting; the
    rare events (a departure, an arrival, a collision, a min-gap contact, a command) have their own methods."""

    def __init__(self, sumo: Any, setup: Setup, scenario: Scenario, av_ids: tuple[str, ...]) -> None:
        self.sumo = sumo
        self.read = Reads(sumo)
        self.network = Network(sumo)
        self.setup = setup
        self.ctrl: Controller | None = load_controller(setup.name) if setup.kind == "fsm" else None
        # the side each state of the machine moves to: +1 left, -1 right, 0 none
        self.sides = tuple(SIDES.get(s, 0) for s in self.ctrl.states) if self.ctrl else ()
        self.decide = {"fsm": self.decide_sensed, "without": self.decide_sensed, "mobil": self.decide_mobil}.get(
            setup.kind
        )
        self.scenario = scenario
        self.target = scenario.target_lane
        self.metrics = {av: AvMetrics(av, sensed=setup.kind in ("fsm", "without")) for av in av_ids}
        self.avs: dict[str, Driving] = {}  # every AV that has departed
        self.driving: list[Driving] = []  # those not yet arrived, in the order of their ids
        self.violations: list[Violation] = []
        self.pairs: set[tuple[str, str]] = set()
        # (AV, edge, lane, position) of every AV every step: hashed once at the end (trajectory_sha256), in one
        # tight pass rather than a formatting and a hash call between two SUMO steps
        self.trail: list[tuple[str, str, int, float]] = []
        self.dt = scenario.traffic.step_s
        self.steps = 0
        self.bg_speed = [0.0, 0]  # sum of sampled speeds, number of samples
        self.edges: list[str] = []
        self.remaining = len(av_ids)  # the AVs that have not arrived

    def step(self, t: float) -> None:
        read = self.read
        departed = read.departed()
        if departed:
            self.depart(departed, t)
        arrived = read.arrived()
        if arrived:
            self.arrive(arrived, t)
        collisions = read.collisions()
        if collisions:
            self.collide(collisions)
        speeds = 0.0
        if self.driving:
            claims: list[LaneClaim] = []
            for av in self.driving:
                speeds += self.drive(av, t, claims)
        self.steps += 1
        if self.steps % SAMPLE_STEPS == 0:
            self.sample(speeds, len(self.driving))

    def enter(self, vid: str, t: float) -> Driving:
        """Start keeping AV `vid`, departed at `t`."""
        ctrl = self.ctrl
        m = self.metrics[vid]
        m.depart_s = t
        av = self.avs[vid] = Driving(
            vid, m, ctrl.initial if ctrl else 0, [0.0] * len(self.sides), deque(maxlen=TRACE_STEPS)
        )
        self.driving.append(av)
        self.driving.sort(key=lambda d: d.id)
        return av

    def depart(self, departed: Any, t: float) -> None:
        for vid in departed:
            if vid in self.metrics:
                if self.setup.kind != "sumo":
                    self.sumo.vehicle.setLaneChangeMode(vid, 0)
                self.enter(vid, t)

    def arrive(self, arrived: Any, t: float) -> None:
        for vid in arrived:
            av = self.avs.get(vid)
            if av is not None:
                av.m.arrive_s = t
                self.remaining -= 1
                self.driving.remove(av)
                if av.need is not None:
                    av.m.needs_open += 1
                    av.need = None

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

    def drive(self, av: Driving, t: float, claims: list[LaneClaim]) -> float:
        """One step of one AV: observe it (its metrics), and let its controller decide. Returns its speed."""
        read, m, vid = self.read, av.m, av.id
        edge, lane, pos = read.road(vid), read.lane(vid), read.position(vid)
        m.distance_m = read.distance(vid)
        if lane != av.lane and edge == av.edge and edge[:1] != ":":
            m.lane_changes.append(m.distance_m)
            need = av.need
            if need is not None and not need.moved:
                need.moved = True
                m.needs_moved += 1
        av.edge, av.lane = edge, lane
        braking = read.acceleration(vid) < -EMERGENCY_DECEL
        if braking and not av.braking:
            m.emergency_brakes += 1
        av.braking = braking
        speed: float = read.speed(vid)
        found = read.leader(vid, 250.0)
        leader: Leader = found if found and found[0] else None
        if leader is not None and speed > 1.0:
            gap = max(leader[1], 0.0) / speed
            if m.min_time_gap_s is None or gap < m.min_time_gap_s:
                m.min_time_gap_s = gap
        # SUMO's default collision criterion, counted beside the physical one: libsumo's gaps already subtract the
        # follower's minGap, so a negative gap to the leader or from the follower ("" where none) is a contact
        ahead = leader[0] if leader is not None and leader[1] < 0.0 else ""
        follower = read.follower(vid, 50.0)
        behind = follower[0] if follower[1] < 0.0 else ""
        if ahead or behind or av.close:
            self.contacts(av, ahead, behind)
        self.trail.append((vid, edge, lane, pos))
        if self.decide is not None:
            self.decide(av, t, claims, (edge, lane, pos), leader=leader, speed=speed)
        return speed

    def contacts(self, av: Driving, ahead: str, behind: str) -> None:
        """Count the min-gap contacts that begin this step: the vehicles within the AV's minGap ahead or behind
        (each "" where none) that were not the step before."""
        now = {vid for vid in (ahead, behind) if vid}
        av.m.mingap_contacts += len(now - av.close)
        av.close = now

    def trajectory_sha256(self) -> str:
        """The hash of every AV's edge, lane and position (to the millimetre), step by step."""
        lines = "".join(f"{av}|{edge}|{lane}|{pos:.3f}\n" for av, edge, lane, pos in self.trail)
        return hashlib.sha256(lines.encode()).hexdigest()

    def decide_sensed(
        self,
        av: Driving,
        t: float,
        claims: list[LaneClaim],
        where: tuple[str, int, float],
        *,
        leader: Leader,
        speed: float,
    ) -> None:
        """The sensed inputs decide: through the generated machine (fsm), whose lane is then claimed for the other
        AVs, or, "without algorithm", wherever N points (the direction is 0 exactly when N does not hold)."""
        sensed = sense(
            self.read, self.network, av.id, where, target=self.target, claims=claims, leader=leader, speed=speed
        )
        if sensed is None:
            return
        inputs, direction = sensed
        side = self.machine(av, t, inputs) if self.ctrl is not None else direction
        if side and self.command(av, t, where[1] + side) and self.ctrl is not None:
            claims.append(LaneClaim(av.id, where[0], where[1] + side, where[2]))
        if inputs["N"] or av.need is not None:
            self.account(av, inputs, side)

    def decide_mobil(
        self,
        av: Driving,
        t: float,
        claims: list[LaneClaim],
        where: tuple[str, int, float],
        *,
        leader: Leader,
        speed: float,
    ) -> None:
        """MOBIL (sim_check.mobil) decides, where the AV makes lane decisions; the end of the acceleration lane is
        a standing obstacle to it."""
        edge, lane, pos = where
        if not decides_on(edge):
            return
        end = self.network.lane_end(edge, lane, pos)
        lowest = 1 if edge == "acc" and lane > 0 else 0
        lanes = self.network.lanes[edge]
        side = mobil.decide(self.read, av.id, lane, lanes, leader=leader, lane_end=end, lowest=lowest)
        if side:
            self.command(av, t, lane + side)

    def machine(self, av: Driving, t: float, inputs: dict[str, bool]) -> int:
        """One step of the generated machine and its runtime monitor; the side it moves to (+1, -1 or 0)."""
        ctrl = self.ctrl
        assert ctrl is not None
        old = av.state
        answer = ctrl.packed(old, *ctrl.values(inputs))
        new = av.state = answer & STATE_BITS
        av.state_s[new] += self.dt
        av.history.append((t, old, inputs, new))
        if not answer & HOLDS:
            self.violation(av, t, ctrl.failing(new, inputs))
        return self.sides[new]

    def violation(self, av: Driving, t: float, failing: list[str]) -> None:
        """Store a runtime-monitor violation with the steps that led to it."""
        assert self.ctrl is not None
        names = self.ctrl.states
        trace = [
            {"t": round(when, 3), "state": names[old], "inputs": inputs, "next": names[new]}
            for when, old, inputs, new in av.history
        ]
        av.m.monitor_violations += 1
        self.violations.append(Violation(av.id, round(t, 3), failing, trace))

    def command(self, av: Driving, t: float, target: int) -> bool:
        """Ask SUMO for a lane change, at most once per DWELL_S (SUMO's change is instantaneous)."""
        if t - av.last_change < DWELL_S:
            return False
        self.sumo.vehicle.changeLane(av.id, target, 1.0)
        av.last_change = t
        return True

    def account(self, av: Driving, inputs: dict[str, bool], side: int) -> None:
        """The mechanism: N episodes, and safe gaps towards the wanted side that the controller did not take."""
        if not inputs["N"]:
            av.need = None
            return
        m, need = av.m, av.need
        if need is None:
            need = av.need = Need()
            m.needs += 1
        m.need_s += self.dt
        if (inputs["L"] or inputs["R"]) and not side:
            m.deferred_s += self.dt
            if not need.deferred:
                need.deferred = True
                m.needs_deferred += 1

    def finish(self) -> list[AvMetrics]:
        """Every AV's metrics at the end of the run, in the order the loop was given the AVs. The time in each
        state of the machine, kept by state number during the run, is put in by state name (the states an AV was
        never in are left out)."""
        if self.ctrl is not None:
            for av in self.avs.values():
                av.m.state_s = {self.ctrl.states[k]: s for k, s in enumerate(av.state_s) if s}
        return list(self.metrics.values())


def sumo_args(scenario: Scenario, net: Path, routes: Path, seed: int, options: tuple[str, ...] = ()) -> list[str]:
    return sumo_command(net, routes, "--seed", str(seed), "--step-length", str(scenario.traffic.step_s), *options)


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
    read, steps, vehicle_steps = loop.read, 0, 0
    try:
        while True:
            libsumo.simulationStep()
            t = read.time()
            steps += 1
            vehicle_steps += read.vehicle_count()
            loop.step(t)
            if not loop.remaining:
                break
            if t > limit_s:
                result.status, result.reason = "failed", f"AVs had not arrived after {limit_s:.0f} simulated s"
                break
    finally:
        libsumo.close()
    result.sim_steps, result.vehicle_steps = steps, vehicle_steps
    result.collisions = len(loop.pairs)
    result.bg_mean_speed_ms = loop.bg_speed[0] / loop.bg_speed[1] if loop.bg_speed[1] else None
    result.metrics = loop.finish()
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
    read, waiting, steps, vehicle_steps = Reads(libsumo), set(built.av_ids), 0, 0
    try:
        while waiting and read.time() <= limit_s:
            libsumo.simulationStep()
            steps += 1
            vehicle_steps += read.vehicle_count()
            waiting.difference_update(read.arrived())
    finally:
        libsumo.close()
    return time.perf_counter() - start, steps, vehicle_steps
