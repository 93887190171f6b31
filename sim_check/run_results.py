"""What a closed-loop run yields: its status, its per-AV metrics and its monitor violations (pure data: the results
database, the report and the evidence read these without SUMO)."""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any, Literal

from sim_check.radio import Traffic

MARKS_KM = (5, 10, 15, 20)
Job = tuple[str, int, int]  # a run's key: controller, AVs, seed
Status = Literal["done", "failed"]  # a run that finished, or one that failed (its reason says why)
STATES = ("IDLE", "WAITING", "MOVING_LEFT", "MOVING_RIGHT")
CLAIM_STATES = ("CLAIM_LEFT", "CLAIM_RIGHT")  # the repaired V2V protocol's (spec/v2v/mlca_t_claim.toml)
SIDES = {"MOVING_LEFT": +1, "MOVING_RIGHT": -1}  # the states that move the AV, and the side they move it to


MECHANISM = ("needs", "needs_moved", "needs_open", "needs_deferred", "need_s", "deferred_s")
# the shadow mode: what a sensed controller did with each wish episode of its need (sim_check.need)
WishOutcome = Literal["at_once", "deferred", "refused"]
OUTCOMES: tuple[WishOutcome, ...] = ("at_once", "deferred", "refused")
SHADOW = ("wishes", *(f"wishes_{o}" for o in OUTCOMES), "wish_delay_s", "commands", "repeats")
# safety beside collisions: each executed lane change's gaps and RSS check, and SUMO's SSM device
SAFETY = (
    "lc_min_gap_lead_m",
    "lc_min_gap_follow_m",
    "lc_rss_unsafe",
    "ssm_conflicts",
    "ssm_min_ttc_s",
    "ssm_max_drac",
    "ssm_min_pet_s",
)


@dataclass
class Episode:
    """One wish episode of an AV: a stretch of steps in which its need points to the same side for the same reason.
    `outcome`: `at_once` (the AV changed lane that way at the first step it could: the step after the episode
    began), `deferred` (it did later; `delay_s` after the episode began), or `refused` (the episode ended without
    that change; `state` is the machine's state at its last step, which says why: WAITING, the waiting was not
    over; IDLE, no safe gap; MOVING_*, the move was commanded and not executed)."""

    start_s: float
    side: int
    reason: str
    urgent: bool
    outcome: WishOutcome = "refused"
    delay_s: float = 0.0
    state: str = ""


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
    sensed: bool = False  # whether the need was computed (not for SUMO's own models nor MOBIL)
    commands: int = 0  # lane changes the controller commanded (MOBIL and the sensed controllers)
    repeats: int = 0  # of those, commands of a move still under way after one change was executed
    transitions: dict[str, int] = field(default_factory=dict)  # how often each transition of the machine fired
    episodes: list[Episode] = field(default_factory=list)
    lc_min_gap_lead_m: float | None = None  # the smallest physical gap to the new leader after a lane change
    lc_min_gap_follow_m: float | None = None  # ... and from the new follower
    lc_rss_unsafe: int = 0  # lane changes into a gap shorter than RSS's distance (sim_check.rss)
    ssm_conflicts: int = 0  # SUMO's SSM device (sim_check.ssm)
    ssm_min_ttc_s: float | None = None
    ssm_max_drac: float | None = None
    ssm_min_pet_s: float | None = None

    def changes_by(self, km: int) -> int:
        """Lane changes within `km` of the merge; the last mark counts every change to the end of the road."""
        if km == MARKS_KM[-1]:
            return len(self.lane_changes)
        return sum(1 for d in self.lane_changes if d <= km * 1000.0)

    def shadow(self) -> dict[str, Any]:
        """The shadow mode's summary: wish episodes by outcome, the summed delay of those followed late, and the
        commands (None for a controller that does not sense the need)."""
        if not self.sensed:
            return {**dict.fromkeys(SHADOW[:-2]), "commands": self.commands, "repeats": self.repeats}
        counts = {o: sum(e.outcome == o for e in self.episodes) for o in OUTCOMES}
        return {
            "wishes": len(self.episodes),
            **{f"wishes_{o}": n for o, n in counts.items()},
            "wish_delay_s": round(sum(e.delay_s for e in self.episodes), 3),
            "commands": self.commands,
            "repeats": self.repeats,
        }

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
            **{f"{state.lower()}_s": self.state_s.get(state) for state in (*STATES, *CLAIM_STATES)},
            **self.shadow(),
            **{k: getattr(self, k) for k in SAFETY},
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
    """One closed-loop run: its key (controller, AVs, seed), whether it finished, SUMO's counts, each AV's metrics,
    the monitor's violations, the radio's traffic and the hash of its trajectory (what `ResultsDB` stores)."""

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
    density_veh_km_lane: float | None = None  # all traffic on the road's normal edges, sampled likewise
    trajectory_sha256: str = ""
    metrics: list[AvMetrics] = field(default_factory=list)
    violations: list[Violation] = field(default_factory=list)
    v2v: Traffic = field(default_factory=Traffic)  # what the radio carried (controllers that talk to each other)

    @property
    def monitor_violations(self) -> int:
        """How many steps the monitor found an invariant failing in."""
        return len(self.violations)

    def to_json(self) -> dict[str, Any]:
        """The run as JSON values, each AV's metrics as its row of the results database."""
        data = asdict(self)
        data["metrics"] = [m.row() for m in self.metrics]
        return data
