"""An explicit-state explorer for machines with data over small integer domains, written apart from the z3 engine.

It shares nothing with `mlca_verify.logic`, only the model classes: its own exact evaluator over the model's AST
(ints and Fractions), its own step semantics, its own breadth-first searches. Every input valuation is enumerated:
each boolean input both ways, each signal over every integer of its range and one value just outside it on each
side (an invalid sample). Params are fixed to their defaults, or (for a parametric property) range over every
integer of their ranges. Variables are whatever the updates make them: the machines it is used on must keep them
in a small set (clamped updates), which the searches check with a limit on the number of nodes.

The semantics, as read from the spec language's documentation:

- a step reads fresh inputs; environment assumptions over the inputs and the frame before the step must hold
  (else the step cannot happen);
- the first transition (in file order) that applies to the mode and whose guard holds fires; none: the mode stays
  (`otherwise = "stay"`), or no step is possible (`otherwise = "undefined"`);
- each variable takes the firing transition's update, else its `every`, else keeps its value; guards, updates,
  assumptions and the definitions they read are evaluated over the inputs and the frame before the step;
- properties and outputs are evaluated over the step's inputs and the frame after it; `prev(e)` is `e` as it was
  evaluated after the previous step, and at the first step `e` over the initial frame with the current inputs;
- a boolean definition that reads a signal (directly or through numeric definitions: `Definition.signals`) takes
  `if_invalid` whenever one of those samples lies outside its range;
- a bounded response is violated at the step that completes `bound` consecutive steps at which `assume and not
  goal` hold (a counter that saturates at the bound).
"""

from __future__ import annotations

import itertools
from collections import deque
from collections.abc import Callable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

from mlca_verify.model import (
    Arith,
    BinOp,
    Call,
    Cmp,
    Const,
    Expr,
    Ite,
    Liveness,
    Machine,
    Neg,
    Not,
    Num,
    Output,
    Prev,
    StateIn,
    Var,
    Variable,
    nodes,
)

Value = bool | int | Fraction
NODE_LIMIT = 200_000  # nodes of one search: beyond it the machine's variables are not kept small


class TooLarge(Exception):
    """The search left the small domain it was written for."""


# --- exact evaluation ----------------------------------------------------------------------------------------


def _exact(value: Fraction | int) -> int | Fraction:
    if isinstance(value, Fraction) and value.denominator == 1:
        return int(value)
    return value


@dataclass
class Point:
    """Where an expression is evaluated: a mode and variables, a step's inputs (booleans and signals), the
    params, and what `prev()` reads (None where no prev may be read)."""

    machine: Machine
    mode: str
    variables: Mapping[str, Value]
    inputs: Mapping[str, Value]
    params: Mapping[str, Value]
    previous: Mapping[Prev, Value] | None = None
    cache: dict[str, Value] = field(default_factory=dict)

    def name(self, name: str) -> Value:
        if name in self.inputs:
            return self.inputs[name]
        if name in self.params:
            return self.params[name]
        if name in self.variables:
            return self.variables[name]
        if name not in self.cache:
            self.cache[name] = self.derived(name)
        value: Value = self.cache[name]
        return value

    def derived(self, name: str) -> Value:
        m = self.machine
        for d in m.definitions:
            if d.name == name:
                value = ev(d.expr, self)
                if d.type == "bool" and d.signals and not all(self.valid(s) for s in d.signals):
                    return d.if_invalid
                return value
        for o in m.outputs:
            if o.name == name:
                return ev(o.expr, self)
        raise KeyError(name)

    def valid(self, signal: str) -> bool:
        s = next(s for s in self.machine.signals if s.name == signal)
        low, high = s.range
        sample = _number(self.inputs[signal])
        return low <= sample <= high


def ev(expr: Expr, p: Point) -> Value:  # noqa: PLR0912
    """The exact value of `expr` at point `p`."""
    match expr:
        case Const(value=value):
            return value
        case Num(value=value):
            return _exact(value)
        case Var(name=name):
            return p.name(name)
        case StateIn(states=states):
            return p.mode in states
        case Not(arg=arg):
            return not ev(arg, p)
        case BinOp(op=op, left=left, right=right):
            a, b = bool(ev(left, p)), bool(ev(right, p))
            return {"and": a and b, "or": a or b, "->": (not a) or b, "<->": a == b}[op]
        case Prev():
            if p.previous is None:
                raise ValueError(f"prev() read where it has no value: {expr}")
            return p.previous[expr]
        case Neg(arg=arg):
            return -_number(ev(arg, p))
        case Arith(op=op, left=left, right=right):
            x, y = _number(ev(left, p)), _number(ev(right, p))
            if op == "+":
                return x + y
            if op == "-":
                return x - y
            if op == "*":
                return x * y
            if y == 0:
                raise ZeroDivisionError(f"division by zero in {expr}")
            return _exact(Fraction(x) / Fraction(y))
        case Cmp(op=op, left=left, right=right):
            lhs, rhs = ev(left, p), ev(right, p)
            if op == "==":
                return lhs == rhs
            if op == "!=":
                return lhs != rhs
            u, w = _number(lhs), _number(rhs)
            return {"<": u < w, "<=": u <= w, ">": u > w, ">=": u >= w}[op]
        case Ite(cond=cond, then=then, other=other):
            return ev(then, p) if ev(cond, p) else ev(other, p)
        case Call(fn="valid", args=(Var(name=name),)):
            return p.valid(name)
        case Call(fn="abs", args=(arg,)):
            number = _number(ev(arg, p))
            return -number if number < 0 else number
        case Call(fn="min", args=args):
            return min(_number(ev(e, p)) for e in args)
        case Call(fn="max", args=args):
            return max(_number(ev(e, p)) for e in args)
    raise TypeError(f"cannot evaluate {expr!r}")


def _number(value: Value) -> int | Fraction:
    if isinstance(value, bool):
        raise TypeError(f"a number was expected, got {value}")
    return value


def _truth(value: Value) -> bool:
    if not isinstance(value, bool):
        raise TypeError(f"a boolean was expected, got {value}")
    return value


# --- steps ---------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Move:
    """One step from a frame: the inputs it read, the transition that fired (None: none did), the next frame."""

    inputs: Mapping[str, Value]
    transition: str | None
    mode: str
    variables: tuple[Value, ...]


@dataclass(frozen=True)
class Node:
    """A node of a search: whether no step was taken yet, the frame, the prev() registers and the counter of a
    bounded response."""

    first: bool
    mode: str
    variables: tuple[Value, ...]
    registers: tuple[Value, ...] = ()
    counter: int | Fraction = 0


@dataclass(frozen=True)
class Check:
    """What a search looks for. `bad` sees the point before the step, the move, the point after it (whose
    `previous` answers prev()) and the bounded-response counter after the step."""

    prevs: tuple[Prev, ...]
    bad: Callable[[Point, Move, Point, int | Fraction], bool]
    total: bool = False  # `otherwise = "undefined"` read as "stay" (the completeness check)
    monitor: Liveness | None = None
    bound: Expr | None = None
    stuck_ends: bool = False  # with `total`: a step no transition takes is tested, and the run ends there


@dataclass(frozen=True)
class Found:
    """A search's answer: the shortest run (its inputs per step) whose last step is bad, and its params."""

    length: int
    params: dict[str, Value]
    inputs: tuple[Mapping[str, Value], ...]


@dataclass(frozen=True)
class Verdict:
    verdict: str  # "holds" or "violated"
    length: int | None = None  # a violated invariant, range or response: its shortest counterexample
    found: Found | None = None


@dataclass(frozen=True)
class Record:
    """One replayed step: the mode before it, the transition that fired, the frame after it, what the guards saw
    and the outputs after it, whether the assumptions held and whether the check's bad step happened."""

    state: str
    transition: str | None
    next: str
    variables: dict[str, Value]
    definitions: dict[str, Value]
    outputs: dict[str, Value]
    assumed: bool
    enabled: bool
    bad: bool


class DataExplorer:
    """The step relation of a machine with data, by enumeration, and breadth-first searches over it."""

    def __init__(self, machine: Machine, outside: int = 1, enumerate_inputs: bool = True) -> None:
        """`enumerate_inputs` False: only single steps on given inputs (`step`), for signals of any type."""
        self.m = machine
        self.names = tuple(v.name for v in machine.variables)
        self._moves: dict[tuple[object, ...], list[Move]] = {}
        self.valuations: list[dict[str, Value]] = []
        if not enumerate_inputs:
            return
        domains: list[list[Value]] = [[False, True] for _ in machine.inputs]
        for s in machine.signals:
            low, high = s.range
            if s.type != "int" or low.denominator != 1 or high.denominator != 1:
                raise ValueError(f"signal {s.name}: only int signals are enumerated")
            domains.append(list(range(int(low) - outside, int(high) + outside + 1)))
        keys = [i.name for i in machine.inputs] + [s.name for s in machine.signals]
        self.valuations = [dict(zip(keys, combo, strict=True)) for combo in itertools.product(*domains)]

    # --- params ---------------------------------------------------------------------------------------------

    def defaults(self) -> dict[str, Value]:
        return {p.name: _exact(p.default) for p in self.m.params}

    def param_valuations(self, parametric: bool) -> list[dict[str, Value]]:
        if not parametric:
            return [self.defaults()]
        ranges = []
        for p in self.m.params:
            if p.range is None or p.type != "int":
                raise ValueError(f"param {p.name}: a parametric search needs an int param with a range")
            ranges.append(range(int(p.range[0]), int(p.range[1]) + 1))
        names = [p.name for p in self.m.params]
        return [dict(zip(names, combo, strict=True)) for combo in itertools.product(*ranges)]

    # --- one step -------------------------------------------------------------------------------------------

    def point(
        self,
        mode: str,
        variables: tuple[Value, ...],
        inputs: Mapping[str, Value],
        params: Mapping[str, Value],
        previous: Mapping[Prev, Value] | None = None,
    ) -> Point:
        return Point(self.m, mode, dict(zip(self.names, variables, strict=True)), inputs, params, previous)

    def initial(self) -> tuple[str, tuple[Value, ...]]:
        return self.m.initial, tuple(_exact(v.initial) for v in self.m.variables)

    def step(
        self,
        params: Mapping[str, Value],
        mode: str,
        variables: tuple[Value, ...],
        inputs: Mapping[str, Value],
        total: bool = False,
        assume: bool = True,
    ) -> Move | None:
        """The step under `inputs`, or None when it cannot happen: an assumption fails (unless not `assume`), or no
        transition is enabled and `otherwise = "undefined"` (unless `total`)."""
        before = self.point(mode, variables, inputs, params)
        if assume and not all(_truth(ev(a.expr, before)) for a in self.m.assumptions):
            return None
        fired = None
        for t in self.m.transitions:
            if (t.sources is None or mode in t.sources) and _truth(ev(t.guard, before)):
                fired = t
                break
        if fired is None and self.m.otherwise == "undefined" and not total:
            return None
        updates = {u.variable: u.expr for u in fired.updates} if fired is not None else {}
        after: list[Value] = []
        for v, old in zip(self.m.variables, variables, strict=True):
            if v.name in updates:
                after.append(ev(updates[v.name], before))
            elif v.every is not None:
                after.append(ev(v.every, before))
            else:
                after.append(old)
        return Move(inputs, fired.id if fired else None, fired.target if fired else mode, tuple(after))

    def moves(
        self, params: Mapping[str, Value], mode: str, variables: tuple[Value, ...], total: bool = False
    ) -> list[Move]:
        key = (tuple(sorted(params.items())), mode, variables, total)
        if key not in self._moves:
            found = [self.step(params, mode, variables, i, total) for i in self.valuations]
            self._moves[key] = [mv for mv in found if mv is not None]
        return self._moves[key]

    # --- searches -------------------------------------------------------------------------------------------

    def after(self, check: Check, params: Mapping[str, Value], node: Node, mv: Move) -> tuple[Point, Node, bool]:
        """The point after move `mv` from search node `node` (its `previous` answers prev()), the node it leads
        to and whether the step is bad."""
        before = self.point(node.mode, node.variables, mv.inputs, params)
        if node.first:
            previous = {p: ev(p.arg, before) for p in check.prevs}
        else:
            previous = dict(zip(check.prevs, node.registers, strict=True))
        post = self.point(mv.mode, mv.variables, mv.inputs, params, previous)
        registers = tuple(ev(p.arg, post) for p in check.prevs)
        count: int | Fraction = 0
        if check.monitor is not None:
            assert check.bound is not None
            bound = _number(ev(check.bound, post))
            waiting = _truth(ev(check.monitor.assume, post)) and not _truth(ev(check.monitor.goal, post))
            count = min(node.counter + 1, bound) if waiting else 0
        nxt = Node(False, mv.mode, mv.variables, registers, count)
        return post, nxt, check.bad(before, mv, post, count)

    def search(self, check: Check, params: Mapping[str, Value]) -> Found | None:
        """The shortest run from the initial frame whose last step is bad (breadth first)."""
        start = Node(True, *self.initial())
        parent: dict[Node, tuple[Node, Mapping[str, Value]] | None] = {start: None}
        queue = deque([start])
        while queue:
            node = queue.popleft()
            for mv in self.moves(params, node.mode, node.variables, check.total):
                _, nxt, bad = self.after(check, params, node, mv)
                if bad:
                    inputs = [mv.inputs]
                    back = parent[node]
                    while back is not None:
                        inputs.append(back[1])
                        back = parent[back[0]]
                    return Found(len(inputs), dict(params), tuple(reversed(inputs)))
                if check.stuck_ends and mv.transition is None and self.m.otherwise == "undefined":
                    continue  # the machine is stuck: no run goes on from here
                if nxt not in parent:
                    parent[nxt] = (node, mv.inputs)
                    queue.append(nxt)
                    if len(parent) > NODE_LIMIT:
                        raise TooLarge(f"more than {NODE_LIMIT} nodes: the variables are not kept small")
        return None

    def shortest(self, check: Check, parametric: bool) -> Found | None:
        """The shortest bad run over the params (their defaults, or every valuation in range)."""
        best: Found | None = None
        for params in self.param_valuations(parametric):
            found = self.search(check, params)
            if found is not None and (best is None or found.length < best.length):
                best = found
        return best

    # --- the checks -----------------------------------------------------------------------------------------

    def reach_check(self, state: str) -> Check:
        return Check((), lambda pre, mv, post, n: mv.mode == state)

    def fires_check(self, tid: str) -> Check:
        return Check((), lambda pre, mv, post, n: mv.transition == tid)

    def range_check(self, name: str) -> Check:
        """A variable, or an output, outside its declared range after a step."""
        ranged: list[Variable | Output] = [*self.m.variables, *self.m.outputs]
        element = next(e for e in ranged if e.name == name)
        assert element.range is not None
        low, high = element.range
        return Check((), lambda pre, mv, post, n: not low <= _number(post.name(name)) <= high)

    def completeness_check(self) -> Check:
        return Check((), lambda pre, mv, post, n: mv.transition is None, total=True)

    def invariant_check(self, expr: Expr) -> Check:
        return Check(_prevs(expr), lambda pre, mv, post, n: not _truth(ev(expr, post)))

    def liveness_check(self, live: Liveness) -> Check:
        bound = live.bound
        if bound is None:
            if live.within is None:
                raise ValueError(f"{live.id}: only bounded responses are explored")
            bound = Num(Fraction(live.within), False)
        b = bound
        undefined = self.m.otherwise == "undefined"

        reads_prev = bool(_prevs(live.assume, live.goal))

        def bad(pre: Point, mv: Move, post: Point, n: int | Fraction) -> bool:
            if undefined and mv.transition is None:  # stuck, keeping its state: short of the goal, it never comes
                at = post if reads_prev else pre  # prev() is read after a step: the stay the step is read as
                return _truth(ev(live.assume, at)) and not _truth(ev(live.goal, at))
            return n >= _number(ev(b, post))

        return Check(_prevs(live.assume, live.goal, b), bad, total=undefined, monitor=live, bound=b, stuck_ends=True)

    def checks(self) -> Iterator[tuple[str, Check, bool, bool]]:
        """(property, check, parametric, reachability-like): for a reachability-like check (reach, fires) the
        property holds when the search finds a run; for the others it is violated."""
        m = self.m
        if m.otherwise == "undefined":
            yield "completeness", self.completeness_check(), False, False
        for s in m.states:
            yield f"reach:{s}", self.reach_check(s), False, True
        for t in m.transitions:
            yield f"fires:{t.id}", self.fires_check(t.id), False, True
        for e in [*m.variables, *m.outputs]:
            if e.range is not None:
                yield f"range:{e.name}", self.range_check(e.name), False, False
        for inv in m.invariants:
            yield inv.id, self.invariant_check(inv.expr), inv.parametric, False
        for live in m.liveness:
            yield live.id, self.liveness_check(live), live.parametric, False

    def check(self, name: str) -> Check:
        return next(c for prop, c, _, _ in self.checks() if prop == name)

    def verdicts(self) -> dict[str, Verdict]:
        """Every built-in check and declared property: holds or violated, with the shortest violation."""
        result = {"determinism": Verdict("holds")}
        if self.m.otherwise == "stay":
            result["completeness"] = Verdict("holds")
        for prop, check, parametric, reach_like in self.checks():
            found = self.shortest(check, parametric)
            if reach_like:
                result[prop] = Verdict("holds" if found else "violated", None, found)
            elif found is None:
                result[prop] = Verdict("holds")
            else:
                result[prop] = Verdict("violated", found.length, found)
        return result

    # --- replay ---------------------------------------------------------------------------------------------

    def replay(
        self, params: Mapping[str, Value], inputs: Sequence[Mapping[str, Value]], check: Check | None = None
    ) -> list[Record]:
        """Run the machine on the given inputs (boolean inputs and signals per step) and record every step. A step
        that cannot happen is still taken and recorded as such: one whose assumptions fail is taken as if they
        held (`assumed` false); one with no enabled transition keeps the mode (`enabled` false, whatever
        `otherwise` says)."""
        check = check or Check((), lambda pre, mv, post, n: False)
        mode, variables = self.initial()
        node = Node(True, mode, variables)
        records = []
        for i in inputs:
            before = self.point(mode, variables, i, params)
            assumed = all(_truth(ev(a.expr, before)) for a in self.m.assumptions)
            mv = self.step(params, mode, variables, i, total=True, assume=False)
            assert mv is not None
            post, node, bad = self.after(check, params, node, mv)
            records.append(
                Record(
                    state=mode,
                    transition=mv.transition,
                    next=mv.mode,
                    variables=dict(post.variables),
                    definitions={d.name: before.name(d.name) for d in self.m.definitions},
                    outputs={o.name: post.name(o.name) for o in self.m.outputs},
                    assumed=assumed,
                    enabled=mv.transition is not None,
                    bad=bad,
                )
            )
            mode, variables = mv.mode, mv.variables
        return records


def _prevs(*exprs: Expr) -> tuple[Prev, ...]:
    found: dict[Prev, None] = {}
    for e in exprs:
        for n in nodes(e):
            if isinstance(n, Prev):
                found[n] = None
    return tuple(found)
