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
from typing import Any, NamedTuple

URGENT_M = 100.0
LOOKAHEAD_M = 100.0
SLOWER = 0.9
TIME_GAP_S = 1.0
MIN_GAP_M = 3.0
FOLLOWER_DECEL = 4.0
CLAIM_RADIUS_M = 30.0


Leader = tuple[str, float] | None  # libsumo's getLeader: (id, gap) or None


@dataclass(frozen=True, slots=True)
class Claim:
    """A V2V message: an AV intends to move into `lane` of `edge` around position `pos`."""

    av: str
    edge: str
    lane: int
    pos: float


class Sensed(NamedTuple):
    inputs: dict[str, bool]
    direction: int  # +1 towards the left, -1 towards the right, 0 none needed
    lane: int
    edge: str


def decides_on(edge: str) -> bool:
    """Whether an AV makes lane decisions on `edge`: not on the ramp (one lane), not inside a junction."""
    return edge != "ramp" and not edge.startswith(":")


class Network:
    """What the AVs read of the network itself, which does not change during a run: lane counts and lane lengths,
    read from SUMO once per edge or lane and kept (one per run: another run may load another network)."""

    def __init__(self, sumo: Any) -> None:
        self._sumo = sumo
        self._lanes: dict[str, int] = {}
        self._lengths: dict[str, float] = {}

    def lanes(self, edge: str) -> int:
        """The number of lanes of `edge`."""
        lanes = self._lanes.get(edge)
        if lanes is None:
            lanes = self._lanes[edge] = self._sumo.edge.getLaneNumber(edge)
        return lanes

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


def wanted_lane(edge: str, target: int, lanes: int) -> int:
    """The lane the AV wants on `edge` (one it decides on): the target lane on the built-in highway, the middle
    lane elsewhere (an imported OpenStreetMap road)."""
    if edge == "acc":
        return target + 1  # lane i+1 of the acceleration edge continues as lane i of the highway
    if edge in ("hw", "hw_in"):
        return target
    return lanes // 2


def neighbours(sumo: Any, av: str, side: int, leaders: bool) -> Any:
    """The nearest vehicles ahead (leaders) or behind in the lane on `side` (+1 left, -1 right): (id, gap) pairs.
    Named queries, not getNeighbors' bit modes (whose left/right bit is easily read backwards)."""
    v = sumo.vehicle
    if side > 0:
        return v.getLeftLeaders(av) if leaders else v.getLeftFollowers(av)
    return v.getRightLeaders(av) if leaders else v.getRightFollowers(av)


def _gap_ok(sumo: Any, av: str, side: int, v: float) -> bool:
    """Whether the gap on `side` is safe for the AV driving at `v` m/s."""
    for _vid, gap in neighbours(sumo, av, side, leaders=True):
        if gap < max(MIN_GAP_M, v * TIME_GAP_S):
            return False
    for vid, gap in neighbours(sumo, av, side, leaders=False):
        vf = sumo.vehicle.getSpeed(vid)
        if gap < max(MIN_GAP_M, vf * TIME_GAP_S):
            return False
        if vf > v and (vf - v) ** 2 / (2 * max(gap, 0.1)) > FOLLOWER_DECEL:
            return False
    return True


def _claimed(claims: list[Claim], av: str, edge: str, lane: int, pos: float) -> bool:
    return any(c.av != av and c.edge == edge and c.lane == lane and abs(c.pos - pos) < CLAIM_RADIUS_M for c in claims)


def _slow(sumo: Any, vid: str, gap: float, av: str) -> bool:
    """A slow vehicle `gap` metres ahead: within LOOKAHEAD_M and below SLOWER times the AV's allowed speed."""
    return gap < LOOKAHEAD_M and sumo.vehicle.getSpeed(vid) < SLOWER * sumo.vehicle.getAllowedSpeed(av)


def sense(
    sumo: Any,
    av: str,
    target: int,
    claims: list[Claim],
    where: tuple[str, int, float],
    *,
    network: Network,
    leader: Leader,
    speed: float,
) -> Sensed | None:
    """The inputs of one step, or None where the AV makes no decision (on the ramp, inside a junction).
    `where` is the AV's edge, lane index and position on the lane, `leader` its leader and `speed` its speed,
    already read this step; `network` is the run's `Network`."""
    edge, lane, pos = where
    if not decides_on(edge):
        return None
    lanes = network.lanes(edge)
    wanted = wanted_lane(edge, target, lanes)
    direction = (wanted > lane) - (wanted < lane)
    if direction == 0 and leader is not None and _slow(sumo, leader[0], leader[1], av):
        direction = 1 if lane + 1 < lanes else -1
    elif (  # back towards the wanted lane, unless still overtaking there
        direction != 0
        and edge != "acc"
        and any(_slow(sumo, vid, gap, av) for vid, gap in neighbours(sumo, av, direction, leaders=True))
    ):
        direction = 0
    left = direction > 0 and lane + 1 < lanes and not _claimed(claims, av, edge, lane + 1, pos)
    right = direction < 0 and lane > 0 and not _claimed(claims, av, edge, lane - 1, pos)
    inputs = {
        "N": direction != 0,
        "W": network.lane_end(edge, lane, pos) >= URGENT_M,
        "L": left and _gap_ok(sumo, av, +1, speed),
        "R": right and _gap_ok(sumo, av, -1, speed),
    }
    return Sensed(inputs, direction, lane, edge)
