"""An explicit-state explorer that enumerates every input valuation, written apart from the z3 engine.

It shares nothing with `mlca_verify.logic` but the model classes: its own expression evaluator, its own step
semantics, its own searches. Tests compare its verdicts and shortest lengths with the engine's, and use it to
replay the engine's counterexamples.
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Iterator, Mapping

from mlca_verify.model import BinOp, Const, Expr, Liveness, Machine, Not, StateIn, Var

Inputs = Mapping[str, bool]


def ev(expr: Expr, inputs: Inputs, state: str | None = None) -> bool:
    match expr:
        case Const(value=value):
            return value
        case Var(name=name):
            return bool(inputs[name])
        case StateIn(states=states):
            return state in states
        case Not(arg=arg):
            return not ev(arg, inputs, state)
        case BinOp(op="and", left=a, right=b):
            return ev(a, inputs, state) and ev(b, inputs, state)
        case BinOp(op="or", left=a, right=b):
            return ev(a, inputs, state) or ev(b, inputs, state)
        case BinOp(op="->", left=a, right=b):
            return (not ev(a, inputs, state)) or ev(b, inputs, state)
        case BinOp(op="<->", left=a, right=b):
            return ev(a, inputs, state) == ev(b, inputs, state)
    raise TypeError(expr)


def valuations(names: tuple[str, ...]) -> list[dict[str, bool]]:
    return [dict(zip(names, bits, strict=True)) for bits in itertools.product([False, True], repeat=len(names))]


class Explicit:
    """The machine's step relation, computed by enumeration."""

    def __init__(self, machine: Machine) -> None:
        self.m = machine
        self.vals = valuations(machine.input_names)

    def fired(self, state: str, inputs: Inputs) -> list[tuple[str, str]]:
        """(transition id, next state) for every transition that may fire; [] is a gap."""
        enabled = [
            (t.id, t.target)
            for t in self.m.transitions
            if (t.sources is None or state in t.sources) and ev(t.guard, inputs)
        ]
        if self.m.semantics == "first-match":
            enabled = enabled[:1]
        if not enabled and self.m.otherwise == "stay":
            return [("otherwise", state)]
        return enabled

    def steps(self, state: str) -> Iterator[tuple[dict[str, bool], str, str]]:
        for inputs in self.vals:
            for tid, target in self.fired(state, inputs):
                yield inputs, tid, target

    def distances(self) -> dict[str, int]:
        dist = {self.m.initial: 0}
        queue = deque([self.m.initial])
        while queue:
            state = queue.popleft()
            for _, _, target in self.steps(state):
                if target not in dist:
                    dist[target] = dist[state] + 1
                    queue.append(target)
        return dist

    # --- shortest violation lengths (None: the property holds) ---------------------------------------

    def nondeterminism(self) -> int | None:
        dist = self.distances()
        hits = [d + 1 for s, d in dist.items() for i in self.vals if len({t for _, t in self.fired(s, i)}) > 1]
        return min(hits, default=None)

    def gap(self) -> int | None:
        dist = self.distances()
        return min((d + 1 for s, d in dist.items() for i in self.vals if not self.fired(s, i)), default=None)

    def fires(self, tid: str) -> bool:
        return any(t == tid for s in self.distances() for _, t, _ in self.steps(s))

    def invariant(self, expr: Expr) -> int | None:
        dist = self.distances()
        bad = [d + 1 for s, d in dist.items() for i, _, t in self.steps(s) if not ev(expr, i, t)]
        return min(bad, default=None)

    def restricted(self, live: Liveness) -> tuple[dict[str, set[str]], set[str]]:
        succ: dict[str, set[str]] = {s: set() for s in self.m.states}
        stuck: set[str] = set()
        for s in self.m.states:
            for i in self.vals:
                if not ev(live.assume, i):
                    continue
                outs = self.fired(s, i)
                if not outs and not ev(live.goal, i, s):  # stuck in s, which it keeps: the goal never comes
                    stuck.add(s)
                succ[s] |= {t for _, t in outs if not ev(live.goal, i, t)}
        return succ, stuck

    def liveness(self, live: Liveness) -> int | None:
        """Shortest violation: stem + restricted path + restricted cycle, or stem + restricted path + gap."""
        succ, stuck = self.restricted(live)
        dist = self.distances()
        best: int | None = None
        for u, du in dist.items():
            rd = _bfs(succ, u)
            for c, dc in rd.items():
                if c in stuck:
                    best = _min(best, du + dc + 1)
                cycle = _cycle_length(succ, c)
                if cycle is not None:
                    best = _min(best, du + dc + cycle)
        return best

    def bounded_violated(self, live: Liveness) -> bool:
        assert live.within is not None
        succ, stuck = self.restricted(live)

        def walk(state: str, left: int) -> bool:
            if left == 0 or state in stuck:
                return True
            return any(walk(t, left - 1) for t in succ[state])

        return any(walk(u, live.within) for u in self.distances())


def _min(a: int | None, b: int) -> int:
    return b if a is None else min(a, b)


def _bfs(succ: dict[str, set[str]], start: str) -> dict[str, int]:
    dist = {start: 0}
    queue = deque([start])
    while queue:
        s = queue.popleft()
        for t in sorted(succ[s]):
            if t not in dist:
                dist[t] = dist[s] + 1
                queue.append(t)
    return dist


def _cycle_length(succ: dict[str, set[str]], c: str) -> int | None:
    back = [d + 1 for s, d in _bfs(succ, c).items() if c in succ[s]]
    return min(back, default=None)


def differ_length(a: Machine, b: Machine) -> int | None:
    """Shortest input sequence (in steps) after which the possible next states of `a` and `b` differ."""
    names = a.input_names + tuple(n for n in b.input_names if n not in a.input_names)
    ea, eb = Explicit(a), Explicit(b)
    if a.initial != b.initial:
        return 0
    vals = valuations(names)
    dist = {a.initial: 0}
    queue = deque([a.initial])
    while queue:
        s = queue.popleft()
        for i in vals:
            pa = {t for _, t in ea.fired(s, i)} if s in a.states else set()
            pb = {t for _, t in eb.fired(s, i)} if s in b.states else set()
            if pa != pb:
                return dist[s] + 1
        for i in vals:
            pa = {t for _, t in ea.fired(s, i)} if s in a.states else set()
            pb = {t for _, t in eb.fired(s, i)} if s in b.states else set()
            for t in sorted(pa & pb):
                if t not in dist:
                    dist[t] = dist[s] + 1
                    queue.append(t)
    return None
