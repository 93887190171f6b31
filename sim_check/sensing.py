"""Sensing for the boolean machines (MLCA, MLCA-R): N, W, L and R for one AV from its need and libsumo, with the
thresholds the docs state.

- N: the AV has a need (sim_check.need: SUMO's own model's wish, or the paper's middle-lane goal); W: it is not
  urgent.
- L, R: the need points to that side, and the gap there is safe: the leader in that lane is at least `TIME_GAP_S`
  ahead in time gap (and `MIN_GAP_M`), the follower at least `TIME_GAP_S` behind at its own speed, and the follower
  would not need to brake harder than `FOLLOWER_DECEL` to keep from closing the gap (a vehicle beside the AV is
  reported as a leader or follower with a negative gap, so it fails the check). This time-gap rule is the paper's
  reading, kept for the boolean machines; it is not safe by RSS (docs/findings.md F10): MLCA-T's rule is in its
  spec.
- Nothing here knows what the other AVs intend: Alg. 1 has no messages. The V2V machines (spec/v2v/) claim a gap
  and hear the others' claims through the radio (sim_check.radio), by their generated code alone.
"""

from __future__ import annotations

import math
from typing import Any

from sim_check.need import Need
from sim_check.reads import Reads

TIME_GAP_S = 1.0
MIN_GAP_M = 3.0
FOLLOWER_DECEL = 4.0


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
        self._next: dict[str, frozenset[str]] = {}

    def lane_length(self, edge: str) -> float:
        """The length of `edge` (of its first lane)."""
        return self.length(f"{edge}_0")

    def length(self, lane_id: str) -> float:
        length = self._lengths.get(lane_id)
        if length is None:
            length = self._lengths[lane_id] = self._sumo.lane.getLength(lane_id)
        return length

    def following(self, lane_id: str) -> frozenset[str]:
        """The lanes a vehicle on `lane_id` drives on next without changing lane: the junction's internal lane and
        the lane after it."""
        found = self._next.get(lane_id)
        if found is None:
            links = self._sumo.lane.getLinks(lane_id)
            found = self._next[lane_id] = frozenset(name for link in links for name in link[:5:4] if name)
        return found

    def change(self, old: str, new: str) -> int:
        """The lane change that took a vehicle from lane `old` to lane `new` in one step: 0 where `new` follows
        `old` (no change), else its side (+1 left, -1 right), measured against the lane that follows `old` on
        `new`'s edge where there is one (a change in the step an edge is entered)."""
        if new in self.following(old):
            return 0
        old_edge, old_index = _split(old)
        new_edge, new_index = _split(new)
        if old_edge != new_edge:
            for lane in self.following(old):
                edge, index = _split(lane)
                if edge == new_edge:
                    old_index = index
                    break
            else:
                for lane in self.following(old):  # through the junction's internal lane
                    for after in self.following(lane):
                        edge, index = _split(after)
                        if edge == new_edge:
                            old_index = index
        return (new_index > old_index) - (new_index < old_index)

    def lane_end(self, edge: str, lane: int, pos: float) -> float:
        """Metres to the end of the AV's lane: the acceleration lane (lane 0 of `acc`) ends, every other
        continues."""
        if edge != "acc" or lane != 0:
            return math.inf
        return self.length(f"{edge}_{lane}") - pos


def _split(lane_id: str) -> tuple[str, int]:
    """A lane id's edge and index (SUMO names a lane `<edge>_<index>`)."""
    edge, _, index = lane_id.rpartition("_")
    return edge, int(index)


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


def sense(
    read: Reads,
    network: Network,
    av: str,
    where: tuple[str, int, float],
    need: Need,
    *,
    speed: float,
) -> dict[str, bool]:
    """The inputs of one step. `where` is the AV's edge, lane index and position on the lane, `speed` its speed,
    already read this step; `network` is the run's `Network`. What the other AVs intend is not sensed: the boolean
    machines have no messages (the V2V machines of spec/v2v/ read theirs from the radio, sim_check.radio)."""
    edge, lane, _ = where
    side = need.side
    left = side > 0 and lane + 1 < network.lanes[edge]
    right = side < 0 and lane > 0
    return {
        "N": side != 0,
        "W": not need.urgent,
        "L": left and _gap_ok(read, av, +1, speed),
        "R": right and _gap_ok(read, av, -1, speed),
    }
