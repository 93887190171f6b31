"""One closed-loop run: SUMO through libsumo, sensing, the generated controller, the runtime monitor, metrics.

One libsumo simulation per process (libsumo keeps one global simulation); the sweep runs each run in a worker
process. SUMO's own lane changing is off for the AVs (laneChangeMode 0): every lane change they make is one the
controller commanded, executed by SUMO even where unsafe, so the controller's own safety is what is measured.
"""

from __future__ import annotations

import hashlib
import time
from collections import deque
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from sim_check.controllers import Controller, load_controller
from sim_check.scenario import Scenario, build, sumo_bin
from sim_check.sensing import Claim, sense

MARKS_KM = (5, 10, 15, 20)
EMERGENCY_DECEL = 4.5  # m/s²: braking harder than this is counted as emergency braking
DWELL_S = 3.0  # a commanded lane change is not repeated within this time (SUMO's change is instantaneous)
TRACE_STEPS = 20  # steps of history stored with a monitor violation
SIM_LIMIT_S = 3600.0


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


class ClosedLoop:
    """The state of one run between steps."""

    def __init__(self, sumo: Any, controller: Controller, scenario: Scenario, av_ids: tuple[str, ...]) -> None:
        self.sumo = sumo
        self.ctrl = controller
        self.scenario = scenario
        self.av_ids = av_ids
        self.state: dict[str, int] = {}
        self.metrics = {av: AvMetrics(av) for av in av_ids}
        self.last_change: dict[str, float] = {}
        self.place: dict[str, tuple[str, int]] = {}
        self.braking: dict[str, bool] = {}
        self.history: dict[str, deque[dict[str, Any]]] = {av: deque(maxlen=TRACE_STEPS) for av in av_ids}
        self.violations: list[dict[str, Any]] = []
        self.pairs: set[tuple[str, str]] = set()
        self.digest = hashlib.sha256()

    def step(self, t: float) -> None:
        sumo = self.sumo
        for av in sumo.simulation.getDepartedIDList():
            if av in self.metrics:
                sumo.vehicle.setLaneChangeMode(av, 0)
                self.state[av] = self.ctrl.initial
                self.metrics[av].depart_s = t
        for av in sumo.simulation.getArrivedIDList():
            if av in self.metrics:
                self.metrics[av].arrive_s = t
                self.state.pop(av, None)
        self.collisions()
        claims: list[Claim] = []
        for av in sorted(self.state):
            where = self.observe(av)
            self.decide(av, t, claims, where)

    def collisions(self) -> None:
        for c in self.sumo.simulation.getCollisions():
            pair = tuple(sorted((c.collider, c.victim)))
            if pair in self.pairs:
                continue
            self.pairs.add(pair)
            for vid in pair:
                if vid in self.metrics:
                    self.metrics[vid].collisions += 1

    def observe(self, av: str) -> tuple[str, int, float]:
        sumo, m = self.sumo, self.metrics[av]
        edge, lane, pos = sumo.vehicle.getRoadID(av), sumo.vehicle.getLaneIndex(av), sumo.vehicle.getLanePosition(av)
        m.distance_m = sumo.vehicle.getDistance(av)
        before = self.place.get(av)
        if before is not None and before[0] == edge and before[1] != lane and not edge.startswith(":"):
            m.lane_changes.append(m.distance_m)
        self.place[av] = (edge, lane)
        braking = sumo.vehicle.getAcceleration(av) < -EMERGENCY_DECEL
        if braking and not self.braking.get(av, False):
            m.emergency_brakes += 1
        self.braking[av] = braking
        speed = sumo.vehicle.getSpeed(av)
        leader = sumo.vehicle.getLeader(av, 250.0)
        if leader is not None and leader[0] and speed > 1.0:
            gap = max(leader[1], 0.0) / speed
            m.min_time_gap_s = gap if m.min_time_gap_s is None else min(m.min_time_gap_s, gap)
        self.digest.update(f"{av}|{edge}|{lane}|{pos:.3f}\n".encode())
        return edge, lane, pos

    def decide(self, av: str, t: float, claims: list[Claim], where: tuple[str, int, float]) -> None:
        sensed = sense(self.sumo, av, self.scenario.target_lane, claims, where)
        if sensed is None:
            return
        old = self.state[av]
        new = self.ctrl.step(old, sensed.inputs)
        self.state[av] = new
        names = self.ctrl.states
        self.history[av].append({"t": round(t, 3), "state": names[old], "inputs": sensed.inputs, "next": names[new]})
        failing = self.ctrl.failing(new, sensed.inputs)
        if failing:
            self.metrics[av].monitor_violations += 1
            self.violations.append(
                {"av": av, "time_s": round(t, 3), "invariants": failing, "trace": list(self.history[av])}
            )
        side = {"MOVING_LEFT": 1, "MOVING_RIGHT": -1}.get(names[new], 0)
        if side and t - self.last_change.get(av, -1e9) >= DWELL_S:
            target = sensed.lane + side
            self.sumo.vehicle.changeLane(av, target, 1.0)
            self.last_change[av] = t
            claims.append(Claim(av, sensed.edge, target, where[2]))

    @property
    def done(self) -> bool:
        return all(m.arrive_s is not None for m in self.metrics.values())


def sumo_args(scenario: Scenario, net: Path, routes: Path, seed: int) -> list[str]:
    return [
        sumo_bin("sumo"), "-n", str(net), "-r", str(routes), "--seed", str(seed),
        "--step-length", str(scenario.traffic.step_s),
        "--collision.action", "warn", "--collision.check-junctions", "true", "--collision.mingap-factor", "0",
        "--no-step-log", "true", "--duration-log.disable", "true", "--no-warnings", "true",
    ]  # fmt: skip


def run_once(scenario: Scenario, controller: str, seed: int, work: Path) -> RunResult:
    """One run, start to finish; raises on a simulator failure (the sweep records it)."""
    import libsumo

    start = time.perf_counter()
    built = build(scenario, seed, work)
    ctrl = load_controller(controller)
    libsumo.start(sumo_args(scenario, built.net, built.routes, seed))
    loop = ClosedLoop(libsumo, ctrl, scenario, built.av_ids)
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
            if t > SIM_LIMIT_S:
                result.status, result.reason = "failed", f"AVs had not arrived after {SIM_LIMIT_S:.0f} simulated s"
                break
    finally:
        libsumo.close()
    result.wall_s = time.perf_counter() - start
    result.collisions = len(loop.pairs)
    result.metrics = [loop.metrics[av] for av in built.av_ids]
    result.violations = loop.violations
    result.trajectory_sha256 = loop.digest.hexdigest()
    return result
