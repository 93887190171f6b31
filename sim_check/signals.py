"""The raw signals a machine with data decides on, read from libsumo: the AV's speed, and the gap and speed of the
leader and of the follower in each adjacent lane. sim_check holds no threshold of such a machine: its rule (MLCA-T's
L and R) is in the spec and in the code generated from it.

What the sensor reports, by the spec's conventions (spec/mlca_t.toml, [signals]):
- no vehicle sensed: a gap of 1000 m (the signals' range) and a speed of 0 for a leader (a standing vehicle
  1000 m ahead) or for a follower; a gap beyond 1000 m is reported as 1000 m (nearer: the safe side);
- a vehicle beside the AV: its gap as SUMO gives it, negative, so outside the range: the sample is invalid and the
  spec's L or R is false (fail-safe);
- no lane on that side, or a side the need does not point to: NaN, an invalid sample, so L or R is false. The
  spec's N has no direction: the side a move may take is the side of the need.
"""

from __future__ import annotations

import math

from sim_check.reads import Reads

NOTHING_M = 1000.0  # the gap reported where no vehicle is sensed (the top of the signals' range)
SIDE_SIGNALS = ("gap_lead", "gap_follow", "v_follow", "v_lead")
SENSED = ("v", *(f"{name}_{side}" for side in ("left", "right") for name in SIDE_SIGNALS))
NAN = math.nan
UNSENSED = (NAN, NAN, NAN, NAN)


def nearest(found: tuple[tuple[str, float], ...]) -> tuple[str, float] | None:
    """The nearest of getNeighbors' (id, gap) pairs, or None."""
    return min(found, key=lambda pair: pair[1]) if found else None


def side_signals(read: Reads, av: str, side: int) -> tuple[float, float, float, float]:
    """gap_lead, gap_follow, v_follow and v_lead on `side` (+1 left, -1 right) of `av`, where that lane exists."""
    lead = nearest(read.neighbours(av, side, leaders=True))
    follow = nearest(read.neighbours(av, side, leaders=False))
    gap_lead, v_lead = (min(lead[1], NOTHING_M), read.speed(lead[0])) if lead else (NOTHING_M, 0.0)
    gap_follow, v_follow = (min(follow[1], NOTHING_M), read.speed(follow[0])) if follow else (NOTHING_M, 0.0)
    return gap_lead, gap_follow, v_follow, v_lead


def signals(read: Reads, av: str, lane: int, *, lanes: int, speed: float, side: int) -> tuple[float, ...]:
    """Every signal of SENSED, in its order: the lane on the side of the need (`side`) is read; the other, or a lane
    that does not exist, is unsensed (NaN)."""
    left = side_signals(read, av, 1) if side > 0 and lane + 1 < lanes else UNSENSED
    right = side_signals(read, av, -1) if side < 0 and lane > 0 else UNSENSED
    return (speed, *left, *right)
