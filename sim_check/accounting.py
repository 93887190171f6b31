"""What a closed-loop run counts, apart from the stepping (`runner.ClosedLoop`): each AV's metrics (lane changes
and their gaps, min-gap contacts, collisions, the mechanism's N episodes and deferrals, the shadow mode's wish
episodes, the time in each state and the transitions fired), the monitor's violations with the steps that led
to them, the other traffic's speed and density, and the trail every AV leaves (hashed once at the end).

The loop calls it from the hot path between two SUMO steps, so its methods touch the AV's own record (`Driving`)
and read SUMO only where a rare event (a lane change) asks for it."""

from __future__ import annotations

import hashlib
import math
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from sim_check import rss
from sim_check.need import Need
from sim_check.reads import Reads
from sim_check.run_results import AvMetrics, Episode, Violation
from sim_check.sensing import Network

EMERGENCY_DECEL = 4.5  # m/s²: braking harder than this is counted as emergency braking

History = deque[tuple[float, int, dict[str, Any], int]]


@dataclass
class NeedEpisode:
    """The N episode an AV is in: whether the AV has changed lane in it, or passed up a safe gap."""

    moved: bool = False
    deferred: bool = False


@dataclass(slots=True, eq=False)
class Driving:
    """What the loop keeps of one AV from its departure to its arrival."""

    id: str
    m: AvMetrics
    state: int  # the generated machine's state (fsm controllers)
    state_s: list[float]  # seconds spent in each state of the machine, by state
    history: History  # (time, state, inputs, next state) of the last steps, the trace stored with a violation
    fired: list[int]  # how often each transition fired, by number (0: none fired)
    ctx: Any = None  # the generated machine's context
    edge: str = ""  # where the AV was the step before
    lane: int = -1
    lane_id: str = ""
    braking: bool = False  # whether it braked harder than EMERGENCY_DECEL the step before
    close: set[str] = field(default_factory=set)  # vehicles within its minGap the step before
    need: NeedEpisode | None = None  # the N episode it is in
    episode: Episode | None = None  # the wish episode it is in (shadow mode)
    last_change: float = -math.inf  # when it was last commanded to change lane
    moving: int = 0  # the side of the move under way (a generated machine in MOVING_*), 0 none
    last_fired: int = 0  # the transition that fired in the machine's last step, by number from 1 (0: none)
    merge_m: float = 0.0  # its odometer at the merge


class Ledger:
    """The counts of one run. `states` and `transitions` are the generated machine's (empty for the others);
    `dt` is the step length in seconds."""

    def __init__(
        self,
        read: Reads,
        network: Network,
        metrics: dict[str, AvMetrics],
        *,
        states: tuple[str, ...],
        transitions: tuple[str, ...],
        dt: float,
    ) -> None:
        self.read = read
        self.network = network
        self.metrics = metrics
        self.states = states
        self.transitions = transitions
        self.dt = dt
        self.violations: list[Violation] = []
        self.pairs: set[tuple[str, str]] = set()
        # (AV, edge, lane, position) of every AV every step: hashed once at the end (trajectory_sha256), in one
        # tight pass rather than a formatting and a hash call between two SUMO steps
        self.trail: list[tuple[str, str, int, float]] = []
        self.bg_speed = [0.0, 0]  # sum of sampled speeds, number of samples
        self.density = [0.0, 0]  # sum of sampled densities (vehicles per km per lane), number of samples
        self.edges: list[str] = []
        self.lane_km = 0.0  # the kilometres of lane of the normal edges
        self.rss = rss.spec_params()

    # --- the whole traffic ---------------------------------------------------------------------------------

    def sample(self, edge_ids: Callable[[], Sequence[str]], av_speeds: float, avs: int) -> None:
        """Add the other traffic's speeds this step (every vehicle on a normal edge, less the AVs), and the density
        of all traffic (vehicles per km of lane on the normal edges); `edge_ids` lists SUMO's edges, asked once."""
        if not self.edges:
            self.edges = [e for e in edge_ids() if not e.startswith(":")]
            self.lane_km = sum(self.network.lane_length(e) * self.network.lanes[e] for e in self.edges) / 1000.0
        total, count, vehicles = -av_speeds, -avs, 0
        for e in self.edges:
            n = self.read.edge_vehicles(e)
            if n:
                total += self.read.edge_speed(e) * n
                count += n
                vehicles += n
        if count > 0:
            self.bg_speed[0] += total
            self.bg_speed[1] += count
        if self.lane_km > 0:
            self.density[0] += vehicles / self.lane_km
            self.density[1] += 1

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

    def bg_mean_speed_ms(self) -> float | None:
        return self.bg_speed[0] / self.bg_speed[1] if self.bg_speed[1] else None

    def mean_density(self) -> float | None:
        return round(self.density[0] / self.density[1], 3) if self.density[1] else None

    def trajectory_sha256(self) -> str:
        """The hash of every AV's edge, lane and position (to the millimetre), step by step."""
        lines = "".join(f"{av}|{edge}|{lane}|{pos:.3f}\n" for av, edge, lane, pos in self.trail)
        return hashlib.sha256(lines.encode()).hexdigest()

    # --- one AV ------------------------------------------------------------------------------------------

    def contacts(self, av: Driving, ahead: str, behind: str) -> None:
        """Count the min-gap contacts that begin this step: the vehicles within the AV's minGap ahead or behind
        (each "" where none) that were not the step before."""
        now = {vid for vid in (ahead, behind) if vid}
        av.m.mingap_contacts += len(now - av.close)
        av.close = now

    def changed(self, av: Driving, t: float, side: int) -> None:
        """The AV changed lane towards `side` this step: count it, and credit the episodes it ends."""
        m = av.m
        m.lane_changes.append(m.distance_m - av.merge_m)
        self.check_change(av)
        need = av.need
        if need is not None and not need.moved:
            need.moved = True
            m.needs_moved += 1
        episode = av.episode
        if episode is not None and episode.side == side and episode.outcome == "refused":
            delay = max(0.0, t - episode.start_s - self.dt)
            episode.delay_s = round(delay, 3)
            episode.outcome = "at_once" if delay < self.dt / 2 else "deferred"

    def check_change(self, av: Driving) -> None:
        """The gaps to the new leader and from the new follower at the step the change is executed (physical: SUMO's
        gaps plus the rear vehicle's minGap), their minimum over the AV's changes, and RSS's check of both."""
        read, m, vid = self.read, av.m, av.id
        v = read.speed(vid)
        found = read.leader(vid, 1000.0)
        leader = (found[1] + read.min_gap(vid), read.speed(found[0])) if found and found[0] else None
        behind = read.follower(vid, 1000.0)
        follower = (behind[1] + read.min_gap(behind[0]), read.speed(behind[0])) if behind[0] else None
        if leader is not None and (m.lc_min_gap_lead_m is None or leader[0] < m.lc_min_gap_lead_m):
            m.lc_min_gap_lead_m = leader[0]
        if follower is not None and (m.lc_min_gap_follow_m is None or follower[0] < m.lc_min_gap_follow_m):
            m.lc_min_gap_follow_m = follower[0]
        if not rss.change_is_safe(v, leader, follower, self.rss):
            m.lc_rss_unsafe += 1

    def stepped(self, av: Driving, t: float, old: int, inputs: dict[str, Any], fired: int) -> None:
        """The machine took a step from `old` to `av.state` on `inputs`, `fired` firing (0: none)."""
        av.last_fired = fired
        av.fired[fired] += 1
        av.state_s[av.state] += self.dt
        av.history.append((t, old, inputs, av.state))

    def violation(self, av: Driving, t: float, failing: list[str]) -> None:
        """Store a runtime-monitor violation with the steps that led to it."""
        names = self.states
        trace = [
            {"t": round(when, 3), "state": names[old], "inputs": _plain(inputs), "next": names[new]}
            for when, old, inputs, new in av.history
        ]
        av.m.monitor_violations += 1
        self.violations.append(Violation(av.id, round(t, 3), failing, trace))

    def wish(self, av: Driving, t: float, need: Need) -> None:
        """The shadow mode's wish episodes, before the controller steps: the episode the AV was in ends where the
        need points elsewhere or for another reason (its state is the machine's at its last step); a new one
        begins; an episode that turns urgent is urgent."""
        episode = av.episode
        if episode is not None and (need.side, need.reason) != (episode.side, episode.reason):
            self.end_episode(av)
            episode = None
        if need.side and episode is None:
            av.episode = Episode(round(t, 3), need.side, need.reason, need.urgent)
        elif episode is not None and need.urgent:
            episode.urgent = True

    def track(self, av: Driving, need: Need, safe: bool, side: int) -> None:
        """The mechanism: N episodes, and safe gaps towards the wanted side that the controller did not take."""
        if not need.side:
            av.need = None
            return
        m, current = av.m, av.need
        if current is None:
            current = av.need = NeedEpisode()
            m.needs += 1
        m.need_s += self.dt
        if safe and not side:
            m.deferred_s += self.dt
            if not current.deferred:
                current.deferred = True
                m.needs_deferred += 1

    def arrived(self, av: Driving) -> None:
        """The AV has arrived: an N episode still open stays unresolved, a wish episode ends."""
        if av.need is not None:
            av.m.needs_open += 1
            av.need = None
        self.end_episode(av)

    def end_episode(self, av: Driving) -> None:
        episode = av.episode
        if episode is not None:
            episode.state = self.states[av.state] if self.states else ""
            av.m.episodes.append(episode)
            av.episode = None

    def finish(self, avs: list[Driving]) -> list[AvMetrics]:
        """Every AV's metrics at the end of the run, in the order the loop was given the AVs. The time in each
        state of the machine and the transitions fired, kept by number during the run, are put in by name (the
        states an AV was never in are left out; every transition is listed)."""
        for av in avs:
            self.end_episode(av)
            if self.states:
                av.m.state_s = {self.states[k]: s for k, s in enumerate(av.state_s) if s}
                av.m.transitions = {tid: av.fired[k + 1] for k, tid in enumerate(self.transitions)}
        return list(self.metrics.values())


def _plain(inputs: dict[str, Any]) -> dict[str, Any]:
    """A step's inputs as JSON stores them: a signal that is not a finite number as null."""
    signals_ = inputs.get("signals")
    if signals_ is None:
        return inputs
    return {**inputs, "signals": [v if math.isfinite(v) else None for v in signals_]}
