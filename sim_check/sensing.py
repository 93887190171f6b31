"""Sensing: N, W, L and R for one AV from libsumo, with the thresholds the docs state.

- N, a lane change is wanted, for one of two reasons:
  - the AV is not in its wanted lane. On the acceleration lane (the merge) the wanted lane is the highway's target
    lane (the middle one, Sec. III); on the highway it is the target lane; on an imported OpenStreetMap road, the
    middle lane of the current edge. The direction is towards the wanted lane. While the leader in the next lane
    on that side is slow (below) and within `LOOKAHEAD_M`, the AV is still overtaking it and N does not hold.
  - in its wanted lane, the leader within `LOOKAHEAD_M` is slow: slower than `SLOWER` times the AV's allowed
    speed. The direction is left (overtaking), or right where there is no lane to the left.
  N drops as soon as neither holds (finding F8: nothing else ends a lane change).
- W, the AV can afford to wait: its current lane continues for more than `URGENT_M` metres (the acceleration
  lane ends; the highway lanes do not).
- L, R: the gap on that side is safe, and moving to that side brings the AV closer to its wanted lane. Safe:
  the leader in that lane is at least `TIME_GAP_S` ahead in time gap (and `MIN_GAP_M`), the follower at least
  `TIME_GAP_S` behind at its own speed, and the follower would not need to brake harder than `FOLLOWER_DECEL`
  to keep from closing the gap (a vehicle beside the AV is reported as a leader or follower with a negative gap,
  so it fails the check); and no other AV has claimed that lane near the same position this step (V2V).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from sim_check.reads import Leader, Reads

URGENT_M = 100.0
LOOKAHEAD_M = 100.0
SLOWER = 0.9
TIME_GAP_S = 1.0
MIN_GAP_M = 3.0
FOLLOWER_DECEL = 4.0
CLAIM_RADIUS_M = 30.0


@dataclass(frozen=True, slots=True)
class LaneClaim:
    """A V2V message: an AV intends to move into `lane` of `edge` around position `pos`."""

    av: str
    edge: str
    lane: int
    pos: float


def decides_on(edge: str) -> bool:
    """Whether an AV makes lane decisions on `edge`: not on the ramp (one lane), not inside a junction."""
    return edge != "ramp" and not edge.startswith(":")


class LaneCounts(dict[str, int]):
    """Lane counts by edge, each read from SUMO the first time it is asked for (a hit costs no Python call)."""

    def __init__(self, sumo: Any) -> None:
        super().__init__()
        self._sumo = sumo

    def __missing__(self, edge: str) -> int:
        lanes: int = self._sumo.edge.getLaneNumber(edge)
        self[edge] = lanes
        return lanes


class Network:
    """What the AVs read of the network itself, which does not change during a run: lane counts and lane lengths,
    read from SUMO once per edge or lane and kept (one per run: another run may load another network)."""

    def __init__(self, sumo: Any) -> None:
        self._sumo = sumo
        self.lanes = LaneCounts(sumo)  # network.lanes[edge]: the number of lanes of `edge`
        self._lengths: dict[str, float] = {}

    def lane_end(self, edge: str, lane: int, pos: float) -> float:
        """Metres to the end of the AV's lane: the acceleration lane (lane 0 of `acc`) ends, every other
        continues."""
        if edge != "acc" or lane != 0:
            return math.inf
        lane_id = f"{edge}_{lane}"
        length = self._lengths.get(lane_id)
        if length is None:
            length = self._lengths[lane_id] = self._sumo.lane.getLength(lane_id)
        return length - pos


def _gap_ok(read: Reads, av: str, side: int, v: float) -> bool:
    """Whether the gap on `side` is safe for the AV driving at `v` m/s."""
    for _vid, gap in read.neighbours(av, side, leaders=True):
        if gap < max(MIN_GAP_M, v * TIME_GAP_S):
            return False
    for vid, gap in read.neighbours(av, side, leaders=False):
        vf = read.speed(vid)
        if gap < max(MIN_GAP_M, vf * TIME_GAP_S):
            return False
        if vf > v and (vf - v) ** 2 / (2 * max(gap, 0.1)) > FOLLOWER_DECEL:
            return False
    return True


def _claimed(claims: list[LaneClaim], av: str, edge: str, lane: int, pos: float) -> bool:
    return any(c.av != av and c.edge == edge and c.lane == lane and abs(c.pos - pos) < CLAIM_RADIUS_M for c in claims)


def sense(
    read: Reads,
    network: Network,
    av: str,
    where: tuple[str, int, float],
    *,
    target: int,
    claims: list[LaneClaim],
    leader: Leader,
    speed: float,
) -> tuple[dict[str, bool], int] | None:
    """The inputs of one step and the direction of the wanted lane (+1 left, -1 right, 0 none wanted), or None
    where the AV makes no decision (on the ramp, inside a junction). `where` is the AV's edge, lane index and
    position on the lane, `leader` its leader and `speed` its speed, already read this step; `network` is the
    run's `Network`, `target` the highway's target lane and `claims` the lanes other AVs claimed this step.
    Called every step for every AV, between two SUMO steps: the common case (the AV in its wanted lane) makes no
    Python call but this one."""
    edge, lane, pos = where
    if edge == "ramp" or edge[:1] == ":":  # decides_on(edge), inline
        return None
    lanes = network.lanes[edge]
    if edge == "acc":  # the merge: lane i+1 of the acceleration edge continues as lane i of the highway
        wanted = target + 1
    elif edge in ("hw", "hw_in"):
        wanted = target
    else:  # an imported OpenStreetMap road: its middle lane
        wanted = lanes // 2
    direction = (wanted > lane) - (wanted < lane)
    if direction == 0:
        if (  # the leader is slow (below SLOWER times the AV's allowed speed) within LOOKAHEAD_M: overtake it
            leader is not None and leader[1] < LOOKAHEAD_M and read.speed(leader[0]) < SLOWER * read.allowed_speed(av)
        ):
            direction = 1 if lane + 1 < lanes else -1
    elif edge != "acc":  # back towards the wanted lane, unless still overtaking a slow leader there
        slow = SLOWER * read.allowed_speed(av)
        for vid, gap in read.neighbours(av, direction, leaders=True):
            if gap < LOOKAHEAD_M and read.speed(vid) < slow:
                direction = 0
                break
    left = direction > 0 and lane + 1 < lanes and not _claimed(claims, av, edge, lane + 1, pos)
    right = direction < 0 and lane > 0 and not _claimed(claims, av, edge, lane - 1, pos)
    inputs = {
        "N": direction != 0,
        "W": edge != "acc" or network.lane_end(edge, lane, pos) >= URGENT_M,
        "L": left and _gap_ok(read, av, +1, speed),
        "R": right and _gap_ok(read, av, -1, speed),
    }
    return inputs, direction
