"""The machine as a graph over its states whose edges carry z3 conditions on the inputs.

States are explicit (a machine has tens, not millions); inputs are symbolic. Every edge's existence, and every
property of a step, is decided by a z3 query over all input valuations at once, so a `holds` is a proof.
"""

from __future__ import annotations

from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass, field

import z3

from mlca_verify.logic.results import Outcome, Step
from mlca_verify.logic.solver import Solver, encode
from mlca_verify.logic.tables import none_before
from mlca_verify.model import OTHERWISE_ID, Machine, Transition


@dataclass(frozen=True)
class Move:
    """One way to leave `source`: a transition (or `otherwise: stay`) and the inputs under which it fires."""

    source: str
    target: str
    cond: z3.BoolRef
    transition: Transition | None

    @property
    def id(self) -> str:
        return OTHERWISE_ID if self.transition is None else self.transition.id

    def outcome(self, machine: Machine, label: str | None = None) -> Outcome:
        cite = machine.cite if self.transition is None else self.transition.cite
        return Outcome(self.id, cite, self.target, label)


class Encoding:
    """Moves and gaps of every state of one machine, over a shared solver."""

    def __init__(self, machine: Machine, solver: Solver) -> None:
        self.machine = machine
        self.solver = solver
        self.moves: dict[str, tuple[Move, ...]] = {}
        self.gaps: dict[str, z3.BoolRef] = {}
        self.guards: dict[str, tuple[z3.BoolRef, ...]] = {}
        outgoing: dict[str, list[Transition]] = {s: [] for s in machine.states}
        for t in machine.transitions:
            for state in machine.states if t.sources is None else t.sources:
                outgoing[state].append(t)
        for state in machine.states:
            self._encode_state(state, outgoing[state])

    def guard(self, t: Transition) -> z3.BoolRef:
        return encode(t.guard, self.solver.vars)

    def _encode_state(self, state: str, out: list[Transition]) -> None:
        guards = [self.guard(t) for t in out]
        before = none_before(self.machine, state, [t.guard for t in out], guards, self.solver.vars)
        first_match = self.machine.semantics == "first-match"
        moves = []
        for index, (t, g) in enumerate(zip(out, guards, strict=True)):
            cond = z3.And(g, before[index]) if first_match and index else g
            moves.append(Move(state, t.target, cond, t))
        self.guards[state] = tuple(guards)
        if self.machine.otherwise == "stay":
            moves.append(Move(state, state, before[-1], None))
        else:
            self.gaps[state] = before[-1]
        self.moves[state] = tuple(moves)

    def can_go(self, state: str, target: str) -> z3.BoolRef:
        """The inputs under which `state` may step to `target`."""
        conds = [m.cond for m in self.moves.get(state, ()) if m.target == target]
        return z3.Or(*conds) if conds else z3.BoolVal(False)

    def outcomes(self, state: str, inputs: dict[str, bool], label: str | None = None) -> tuple[Outcome, ...]:
        """Every outcome of `state` under concrete inputs (empty: a gap)."""
        values = [(v, z3.BoolVal(inputs.get(n, False))) for n, v in self.solver.vars.items()]
        moves = self.moves.get(state, ())
        fired = []
        for move, guard in zip(moves, self.guards.get(state, ()), strict=False):
            if z3.is_true(z3.simplify(z3.substitute(guard, *values))):
                fired.append(move)
                if self.machine.semantics == "first-match":
                    break
        if not fired and len(moves) > len(self.guards.get(state, ())):
            fired.append(moves[-1])  # otherwise: stay
        return tuple(m.outcome(self.machine, label) for m in fired)


@dataclass
class Reach:
    """States reachable from the initial state, by breadth-first search: shortest paths come for free."""

    order: list[str] = field(default_factory=list)
    dist: dict[str, int] = field(default_factory=dict)
    parent: dict[str, Move] = field(default_factory=dict)
    edges: dict[str, list[Move]] = field(default_factory=dict)
    uncertain: bool = False

    def moves(self) -> Iterator[Move]:
        """Every feasible move from a reachable state, nearest states first, then in file order."""
        for state in self.order:
            yield from self.edges[state]

    def path_to(self, state: str) -> list[Move]:
        path: list[Move] = []
        while state in self.parent:
            move = self.parent[state]
            path.append(move)
            state = move.source
        return path[::-1]


def explore(enc: Encoding) -> Reach:
    """Breadth-first search over states; a move exists when its condition is satisfiable."""
    reach = Reach()
    initial = enc.machine.initial
    reach.order.append(initial)
    reach.dist[initial] = 0
    queue = deque([initial])
    while queue:
        state = queue.popleft()
        reach.edges[state] = []
        for move in enc.moves[state]:
            answer = enc.solver.check(move.cond)
            reach.uncertain |= answer == "unknown"
            if answer != "sat":
                continue
            reach.edges[state].append(move)
            if move.target not in reach.dist:
                reach.dist[move.target] = reach.dist[state] + 1
                reach.parent[move.target] = move
                reach.order.append(move.target)
                queue.append(move.target)
    return reach


def make_step(enc: Encoding, move: Move, extra: z3.BoolRef | None = None) -> Step:
    """A trace step taking `move`, with canonical inputs (and satisfying `extra` when given)."""
    cond = move.cond if extra is None else z3.And(move.cond, extra)
    inputs = enc.solver.witness(cond)
    if inputs is None:
        raise AssertionError(f"internal error: no inputs for move {move.id} from {move.source}")
    return Step(move.source, inputs, move.outcome(enc.machine))


def trace_steps(enc: Encoding, moves: list[Move]) -> list[Step]:
    return [make_step(enc, m) for m in moves]
