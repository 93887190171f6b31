"""The need to change lane, one source for every controller that senses it (the generated machines and "without").

Two sources, chosen by the scenario (`[traffic] need`):
- `sumo` (the default): SUMO's own lane-change model says what it wants. LC2013 keeps computing its wish while
  TraCI holds the AV's lane (laneChangeMode 0); `vehicle.getLaneChangeState(av, side)` returns it before TraCI's
  overrides, with its reason: strategic (the route needs another lane, the merge included), cooperative, speed
  gain, keep right; and whether it is urgent. So the machines decide on exactly the needs SUMO's own model would
  act on, and a comparison with LC2013 compares decision logic, not goals.
- `middle`: the paper's goal (Sec. III: the AV "positions itself in the middle lane"): the AV wants the highway's
  target lane, and overtakes a slow leader within `LOOKAHEAD_M` (slower than `SLOWER` times its allowed speed).

U, the need is urgent: less than `URGENT_M` left of the AV's lane (the acceleration lane ends; the highway lanes
do not), for both sources; with `sumo`, also where SUMO's model marks its wish urgent.
"""

from __future__ import annotations

from dataclasses import dataclass

from sim_check.reads import Leader, Reads

URGENT_M = 100.0
LOOKAHEAD_M = 100.0
SLOWER = 0.9

# libsumo's LCA_* bits (libsumo.constants; SUMO's MSLink.h): the direction of a wish and its reasons
LCA_LEFT, LCA_RIGHT = 2, 4
LCA_STRATEGIC, LCA_COOPERATIVE, LCA_SPEEDGAIN, LCA_KEEPRIGHT, LCA_URGENT = 8, 16, 32, 64, 256
# the reasons, most pressing first: where SUMO's model wants both sides, the more pressing wish is the need
REASONS = (
    (LCA_STRATEGIC, "strategic"),
    (LCA_COOPERATIVE, "cooperative"),
    (LCA_SPEEDGAIN, "speedGain"),
    (LCA_KEEPRIGHT, "keepRight"),
)
NEED_SOURCES = ("sumo", "middle")


@dataclass(frozen=True, slots=True)
class Need:
    """What the AV needs this step: the side (+1 left, -1 right, 0 none), why, and whether it is urgent."""

    side: int
    reason: str
    urgent: bool


NO_NEED = Need(0, "", False)


def _reason(state: int, direction_bit: int) -> tuple[int, str]:
    """The rank and name of a wish's reason (rank len(REASONS) and "" where the state wants no change that way)."""
    if state & direction_bit:
        for rank, (bit, name) in enumerate(REASONS):
            if state & bit:
                return rank, name
    return len(REASONS), ""


def sumo_wish(read: Reads, av: str, urgent_end: bool) -> Need:
    """SUMO's own lane-change model's wish for `av` this step (its state before TraCI); `urgent_end` says that the
    AV's lane ends within URGENT_M."""
    left = read.lane_change_state(av, 1)[0]
    right = read.lane_change_state(av, -1)[0]
    rank_left, why_left = _reason(left, LCA_LEFT)
    rank_right, why_right = _reason(right, LCA_RIGHT)
    if not why_left and not why_right:
        return NO_NEED
    if why_left and rank_left <= rank_right:
        return Need(1, why_left, bool(left & LCA_URGENT) or urgent_end)
    return Need(-1, why_right, bool(right & LCA_URGENT) or urgent_end)


def middle_goal(
    read: Reads, av: str, where: tuple[str, int], *, lanes: int, target: int, leader: Leader, urgent_end: bool
) -> Need:
    """The paper's goal: the highway's target lane (on the acceleration lane, the lane that continues as it; on an
    imported OpenStreetMap road, the middle lane of the edge), and overtaking a slow leader in it."""
    edge, lane = where
    wanted = target + 1 if edge == "acc" else target if edge in ("hw", "hw_in") else lanes // 2
    side = (wanted > lane) - (wanted < lane)
    reason = "strategic"
    slow = SLOWER * read.allowed_speed(av)
    if side == 0:
        if leader is not None and leader[1] < LOOKAHEAD_M and read.speed(leader[0]) < slow:
            side, reason = (1 if lane + 1 < lanes else -1), "speedGain"
    elif edge != "acc" and any(  # back towards the wanted lane, unless still overtaking a slow leader there
        gap < LOOKAHEAD_M and read.speed(vid) < slow for vid, gap in read.neighbours(av, side, leaders=True)
    ):
        side = 0
    return Need(side, reason, urgent_end) if side else NO_NEED
