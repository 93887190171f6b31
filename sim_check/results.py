"""What a closed-loop run yields: its status, its per-AV metrics and its monitor violations (pure data: the results
database, the report and the evidence read these without SUMO)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Literal

MARKS_KM = (5, 10, 15, 20)
Job = tuple[str, int, int]  # a run's key: controller, AVs, seed
Status = Literal["done", "failed"]  # a run that finished, or one that failed (its reason says why)
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


@dataclass(frozen=True)
class Violation:
    """The runtime monitor fired: which AV, when, the failing invariants, and the steps that led there."""

    av: str
    time_s: float
    invariants: list[str]
    trace: list[Any]  # the last steps: (time, state, inputs, next state), as JSON stores them


@dataclass
class RunResult:
    controller: str
    avs: int
    seed: int
    status: Status = "done"
    reason: str = ""
    sim_steps: int = 0
    wall_s: float = 0.0
    vehicle_steps: int = 0
    collisions: int = 0
    bg_mean_speed_ms: float | None = None  # the other traffic, sampled every SAMPLE_STEPS steps
    trajectory_sha256: str = ""
    metrics: list[AvMetrics] = field(default_factory=list)
    violations: list[Violation] = field(default_factory=list)

    @property
    def monitor_violations(self) -> int:
        return len(self.violations)

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["metrics"] = [m.row() for m in self.metrics]
        return data
