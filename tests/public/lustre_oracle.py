"""The public Lustre models of this folder, transcribed a second time, straight from their Lustre text into Python
step functions (not from our TOML translations), and searched breadth first: an oracle that shares no code and
no encoding with the engine or the spec language.

A model is `step(previous, inputs) -> (next, {property: holds})`, with `previous` None at Lustre's first instant
(where `a -> b` is `a`); a step that returns None breaks a Lustre `assert` and is not a run. Lengths count
instants from 1, as Kind 2 and JKind report them. Where a model saturates an unbounded integer, the translation's
header says why that is exact; the oracle saturates at the same bound.
"""

from __future__ import annotations

from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from itertools import product

State = Hashable
Step = Callable[[State | None, object], tuple[State, dict[str, bool]] | None]
B = (False, True)


@dataclass(frozen=True)
class Model:
    step: Step
    inputs: Sequence[object]
    props: tuple[str, ...]
    max_depth: int = 200
    stop_where: Callable[[State], bool] | None = None  # states whose successors cannot break a property


@dataclass
class Explored:
    shortest: dict[str, int | None]  # the instant at which each property first fails, or None
    complete: bool  # every reachable state was explored (None then means valid)
    states: int = field(default=0)


def explore(model: Model) -> Explored:
    shortest: dict[str, int | None] = dict.fromkeys(model.props)
    seen: set[State] = set()
    frontier: list[State | None] = [None]
    depth = 0
    while frontier and depth < model.max_depth:
        depth += 1
        following: list[State | None] = []
        for state in frontier:
            for value in model.inputs:
                moved = model.step(state, value)
                if moved is None:
                    continue
                after, holds = moved
                for prop, ok in holds.items():
                    if not ok and shortest[prop] is None:
                        shortest[prop] = depth
                if (model.stop_where is None or not model.stop_where(after)) and after not in seen:
                    seen.add(after)
                    following.append(after)
        frontier = following
    return Explored(shortest, not frontier, len(seen))


def two_counters(fires_at: int) -> Step:
    """A Gray-code counter (a, b) and a modulo-4 counter: OK when `a and b` coincides with `time = fires_at`."""

    def step(s: State | None, _: object) -> tuple[State, dict[str, bool]]:
        a, b, t = (False, False, 0) if s is None else (not s[1], s[0], 0 if s[2] == 3 else s[2] + 1)
        return (a, b, t), {"OK": (a and b) == (t == fires_at)}

    return step


def speed(prop: str) -> Step:
    """speed2 (= ex3): never late right after early; ex8: always late-free and early before (incorrect)."""

    def step(s: State | None, i: object) -> tuple[State, dict[str, bool]]:
        beacon, second = i
        incr = 1 if beacon and not second else 2 if second and not beacon else 0
        total = 0 if s is None else s[0]
        total = min(total + incr if beacon or second else total, 10)
        if s is None:
            early = late = False
        else:
            early = total > 0 if s[1] else total >= 10
            late = total < 0 if s[2] else total <= -10
        if s is None:
            ok = True
        elif prop == "speed2":
            ok = not s[1] or not late
        else:
            ok = not late and bool(s[1])
        return (total, early, late), {"OK": ok}

    return step


def traffic(s: State | None, delta: object) -> tuple[State, dict[str, bool]]:
    d = int(delta)
    small = -1 <= d <= 1
    before, so_far = (0, small) if s is None else (s[0], s[1] and small)
    moves = (d < 0 and before > 0) or (d > 0 and before < 10)
    total = before + d if moves else before
    return (total, so_far), {"OK": not so_far or 0 <= total <= 20}


def stopwatch(s: State | None, i: object) -> tuple[State, dict[str, bool]]:
    on_off, reset, freeze = i
    was_running, was_frozen, count, shown = (False, False, 0, 0) if s is None else s
    running = not on_off if was_running else on_off
    frozen = not (freeze or on_off) if was_frozen else freeze and running
    count = 0 if reset and not running else min(count + 1 if running else count, 3)
    shown = shown if frozen else count
    return (running, frozen, count, shown), {"time_is_less_than_three": shown < 3}


def reset_counters(opposite: bool) -> Step:
    """Kind 2's `restart ... every`: the Gray counter restarts on `reset` (on `not reset` when `opposite`)."""

    def step(s: State | None, reset: object) -> tuple[State, dict[str, bool]]:
        gray_restarts = s is None or (not reset if opposite else bool(reset))
        a, b = (False, False) if gray_restarts else (not s[1], s[0])
        t = 0 if s is None or reset else 0 if s[2] == 3 else s[2] + 1
        return (a, b, t), {"OK": (a and b) == (t == 2)}

    return step


COSTS = (1, 2, 5, 8)


def bridge(s: State | None, i: object) -> tuple[State, dict[str, bool]] | None:
    where = tuple(i)
    if s is None:
        if any(where):
            return None  # everyone starts on the near side
        torch, cost = True, 0
    else:
        was, was_torch, was_cost = s
        torch = not was_torch
        crossed = [a != b for a, b in zip(where, was, strict=True)]
        if any(c and side != torch for c, side in zip(crossed, was, strict=True)):
            return None  # only with the torch
        if not any(crossed) or sum(crossed) > 2:
            return None
        cost = min(was_cost + max(c for c, x in zip(COSTS, crossed, strict=True) if x), 16)
    done = all(where)
    return (where, torch, cost), {"prop1": not (done and cost < 15), "prop2": not (done and cost == 15)}


EMPTY, WOLF, GOAT, CABBAGE = range(4)


def farmer(s: State | None, choice: object) -> tuple[State, dict[str, bool]]:
    if s is None:
        wolf = goat = cabbage = farmer_side = 0
        history = True
    else:
        last, wolf, goat, cabbage, farmer_side, history = s
        wolf, goat, cabbage = (1 - x if last == k else x for k, x in ((WOLF, wolf), (GOAT, goat), (CABBAGE, cabbage)))
        farmer_side = 1 - farmer_side
    safe = (wolf != goat or farmer_side == goat) and (goat != cabbage or farmer_side == cabbage)
    sides = {WOLF: wolf, GOAT: goat, CABBAGE: cabbage}
    legal = choice == EMPTY or sides[choice] == farmer_side
    history = safe and legal and history
    solved = wolf == goat == cabbage == farmer_side == 1
    return (choice, wolf, goat, cabbage, farmer_side, history), {"prop": not (history and solved)}


def delays(s: State | None, x: object) -> tuple[State, dict[str, bool]]:
    """JKind's pre.lus: ok1 compares two chains of delays of x; cex1 reads a stream 1, 2, ..., 6, 6, ..."""
    if s is None:
        u, y, z2, z1 = 2, 1, 2, 1
        chain = (5, 4, 3, 2)
        w = 1
    else:
        was_x, was_u, was_z2, v1, v2, v3, v4 = s
        u, y, z2, z1 = was_x, was_u, was_x, was_z2
        chain = (6, v4, v3, v2)
        w = v1
    return (x, u, z2, chain[3], chain[2], chain[1], chain[0]), {"ok1": y == z1, "cex1": w < 6}


def six_counter(s: State | None, _: object) -> tuple[State, dict[str, bool]]:
    if s is None:
        a = b = c = False
    else:
        pa, pb, pc = s
        a = not pa
        b = (not pc and not pb and pa) or (pb and not pa)
        c = (pc and not pa) or (pb and pa)
    return (a, b, c), {"OK": not (c and a)}


def inv_gen(s: State | None, _: object) -> tuple[State, dict[str, bool]]:
    if s is None:
        return (1, False), {"ok": True}
    count, x = s
    count = count + 1 if count < 5 else 5
    now = not count >= 5 and x
    return (count, now), {"ok": not x or now}


def subnode(s: State | None, _: object) -> tuple[State, dict[str, bool]]:
    x = -1 if s is None else min(s + 1, 10)
    return x, {"prop": x < 10 or x >= 10, "counter.lemma": x >= -1, "counter2.lemma": x >= -1}


# Each translation in this folder (its file stem) and the oracle's model of the same Lustre file.
MODELS: dict[str, Model] = {
    "two_counters": Model(two_counters(2), [None], ("OK",)),
    "cex_test": Model(two_counters(3), [None], ("OK",)),
    "speed2": Model(speed("speed2"), list(product(B, B)), ("OK",)),
    "ex8": Model(speed("ex8"), list(product(B, B)), ("OK",)),
    "traffic": Model(traffic, list(range(-3, 4)), ("OK",), stop_where=lambda s: not s[1]),
    "stopwatch": Model(stopwatch, list(product(B, B, B)), ("time_is_less_than_three",)),
    "reset_counters_success": Model(reset_counters(False), list(B), ("OK",)),
    "reset_counters_falsifiable": Model(reset_counters(True), list(B), ("OK",)),
    "bridge_and_torch": Model(bridge, list(product(B, B, B, B)), ("prop1", "prop2")),
    "farmer": Model(farmer, list(range(4)), ("prop",)),
    "jkind_pre": Model(delays, [0, 1, 2], ("ok1", "cex1"), max_depth=12),
    "six_counter": Model(six_counter, [None], ("OK",)),
    "inv_gen": Model(inv_gen, [None], ("ok",)),
    "subnode_properties": Model(subnode, [None], ("prop", "counter.lemma", "counter2.lemma")),
}
