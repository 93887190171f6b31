"""MOBIL (Kesting, Treiber and Helbing 2007, "General lane-changing model MOBIL for car-following models",
Transportation Research Record 1999): lane-change decisions from the accelerations a car-following model gives.

The core is pure: the Intelligent Driver Model (IDM) acceleration and the MOBIL safety and incentive criteria over
plain numbers, so that they are unit-tested on hand-computed cases. `decide` reads the neighbourhood from libsumo.

- Safety: the new follower would not have to brake harder than `b_safe`: ã_n >= -b_safe.
- Incentive: ã_c - a_c + p * ((ã_n - a_n) + (ã_o - a_o)) > a_thr + bias for a change to the left, and
  > a_thr - bias for a change to the right (the keep-right bias of European rules; bias = 0 is the symmetric
  model). c is the AV, n the follower in the target lane, o the AV's follower now; a tilde is the acceleration
  after the change.
- A lane that ends (the acceleration lane) is a standing obstacle at its end, which makes the merge mandatory
  without a separate rule.

Parameters, with their sources: p = 0.5 (politeness; "realistic" p is in ]0, 0.5], Treiber's MOBIL page), b_safe =
4 m/s² (MOBIL page and Kesting 2007), a_thr = 0.2 m/s² and bias = 0.2 m/s² (MOBIL page's typical values); IDM
(Treiber, Hennecke and Helbing 2000): T = 1.5 s, s0 = 2 m, a = 1.4 m/s², b = 2.0 m/s², delta = 4; the desired
speed v0 is the AV's allowed speed on its lane. SUMO's own car-following model still drives the AV
longitudinally; IDM only scores the options, as MOBIL is defined over any car-following model.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from sim_check.reads import Leader, Reads

FREE = math.inf  # no vehicle: an infinite gap


@dataclass(frozen=True)
class Idm:
    v0: float  # desired speed, m/s
    T: float = 1.5  # time gap, s
    s0: float = 2.0  # minimum gap, m
    a: float = 1.4  # maximum acceleration, m/s²
    b: float = 2.0  # comfortable deceleration, m/s²
    delta: float = 4.0

    def accel(self, v: float, gap: float = FREE, v_lead: float = 0.0) -> float:
        """IDM acceleration at speed v with `gap` metres to a leader at v_lead (FREE: no leader)."""
        free = 1.0 - math.pow(v / self.v0, self.delta)
        if gap == FREE:
            return self.a * free
        s_star = self.s0 + max(0.0, v * self.T + v * (v - v_lead) / (2.0 * math.sqrt(self.a * self.b)))
        return self.a * (free - math.pow(s_star / max(gap, 0.01), 2))


@dataclass(frozen=True)
class Mobil:
    p: float = 0.5
    b_safe: float = 4.0
    a_thr: float = 0.2
    bias: float = 0.2  # keep-right bias; 0 for symmetric rules


@dataclass(frozen=True)
class Car:
    """A neighbour: its gap (m, bumper to bumper, from the AV's point of view) and speed (m/s)."""

    gap: float = FREE
    v: float = 0.0


@dataclass(frozen=True)
class Scene:
    """What MOBIL needs for one candidate lane. Gaps of followers are measured from the follower's front to the
    AV's rear; `length` is the AV's length."""

    v: float  # the AV's speed
    length: float
    leader: Car  # the AV's leader now
    follower: Car  # the AV's follower now (o)
    new_leader: Car  # leader in the target lane
    new_follower: Car  # follower in the target lane (n)


@dataclass(frozen=True)
class MobilDecision:
    safe: bool
    incentive: float  # the left-hand side of the incentive criterion, m/s²
    change: bool


def evaluate(scene: Scene, side: int, idm: Idm, follower_idm: Idm, mobil: Mobil = Mobil()) -> MobilDecision:
    """MOBIL's criteria for a change to `side` (+1 left, -1 right)."""
    s = scene
    a_c = idm.accel(s.v, s.leader.gap, s.leader.v)
    a_c_new = idm.accel(s.v, s.new_leader.gap, s.new_leader.v)
    n, o = s.new_follower, s.follower
    if n.gap == FREE:
        a_n = a_n_new = 0.0
    else:  # before: n follows the new leader across the AV's place; after: n follows the AV
        gap_before = n.gap + s.length + s.new_leader.gap
        a_n = follower_idm.accel(n.v, gap_before, s.new_leader.v)
        a_n_new = follower_idm.accel(n.v, n.gap, s.v)
    if o.gap == FREE:
        a_o = a_o_new = 0.0
    else:  # before: o follows the AV; after: o follows the AV's old leader
        a_o = follower_idm.accel(o.v, o.gap, s.v)
        a_o_new = follower_idm.accel(o.v, o.gap + s.length + s.leader.gap, s.leader.v)
    safe = n.gap >= 0.0 and s.new_leader.gap >= 0.0 and a_n_new >= -mobil.b_safe
    incentive = a_c_new - a_c + mobil.p * ((a_n_new - a_n) + (a_o_new - a_o))
    threshold = mobil.a_thr + (mobil.bias if side > 0 else -mobil.bias)
    return MobilDecision(safe, incentive, safe and incentive > threshold)


def _nearest(pairs: Any, speed: Any) -> Car:
    if not pairs:
        return Car()
    vid, gap = min(pairs, key=lambda p: p[1])
    return Car(gap, speed(vid))


def decide(read: Reads, av: str, lane: int, lanes: int, *, leader: Leader, lane_end: float, lowest: int = 0) -> int:
    """+1, -1 or 0: the side MOBIL changes to this step, from libsumo's view of the AV in `lane` of an edge with
    `lanes` lanes. `leader` is the AV's leader as read this step; `lane_end` is the distance to the end of the
    AV's lane (infinite where it continues); lanes below `lowest` are not entered (a lane that ends). A vehicle
    beside the AV comes back as a neighbour with a negative gap: not safe."""
    speed = read.speed
    v = speed(av)
    v0 = read.allowed_speed(av)
    idm = Idm(v0=max(v0, 1.0))
    length = read.length(av)
    ahead = Car(leader[1], speed(leader[0])) if leader else Car()
    if lane_end < ahead.gap:  # the end of the lane is a standing obstacle
        ahead = Car(lane_end, 0.0)
    follow = read.follower(av, 250.0)
    follower = Car(follow[1], speed(follow[0])) if follow and follow[0] else Car()
    best, best_gain = 0, -math.inf
    for side in (+1, -1):
        if not lowest <= lane + side < lanes:
            continue
        scene = Scene(
            v,
            length,
            ahead,
            follower,
            _nearest(read.neighbours(av, side, leaders=True), speed),
            _nearest(read.neighbours(av, side, leaders=False), speed),
        )
        verdict = evaluate(scene, side, idm, idm)
        if verdict.change and verdict.incentive > best_gain:
            best, best_gain = side, verdict.incentive
    return best
