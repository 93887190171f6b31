"""Equivalence of two machines, and where they differ.

States are observable (they are the machine's output), so two machines agree on an input sequence when they can
produce the same state sequences. They start to differ at a state both can reach along the same path, under an
input for which the sets of possible next states differ. Breadth-first search over the states both reach by the
same moves therefore finds a shortest distinguishing sequence. Inputs one machine does not declare are ignored
by it.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field

import z3

from mlca_verify.logic.graph import Encoding
from mlca_verify.logic.results import Counterexample, Outcome, Step
from mlca_verify.logic.solver import DEFAULT_TIMEOUT_MS, Solver
from mlca_verify.model import Machine, Verdict

MAX_CUBES = 64


@dataclass(frozen=True)
class Region:
    """Inputs (a conjunction of literals) under which the machines do different things in one state."""

    state: str
    cube: dict[str, bool]
    left: tuple[Outcome, ...]
    right: tuple[Outcome, ...]
    witness: tuple[dict[str, bool], ...] = ()  # inputs from the initial state: the path, then the differing step


@dataclass
class EquivalenceResult:
    verdict: Verdict
    counterexample: Counterexample | None = None
    regions: list[Region] = field(default_factory=list)
    detail: str = ""


def _union(a: tuple[str, ...], b: tuple[str, ...]) -> tuple[str, ...]:
    return a + tuple(x for x in b if x not in a)


class Comparator:
    def __init__(self, left: Machine, right: Machine, timeout_ms: int = DEFAULT_TIMEOUT_MS) -> None:
        self.left, self.right = left, right
        self.solver = Solver(_union(left.input_names, right.input_names), timeout_ms)
        self.enc_l = Encoding(left, self.solver)
        self.enc_r = Encoding(right, self.solver)
        self.states = _union(left.states, right.states)
        self.unknown = False
        self.order: list[str] = []
        self.parent: dict[str, tuple[str, str]] = {}

    def ask(self, formula: z3.BoolRef) -> bool:
        answer = self.solver.check(formula)
        self.unknown |= answer == "unknown"
        return answer == "sat"

    def differs(self, state: str) -> z3.BoolRef:
        return z3.Or(*[z3.Xor(self.enc_l.can_go(state, t), self.enc_r.can_go(state, t)) for t in self.states])

    def both(self, state: str, target: str) -> z3.BoolRef:
        return z3.And(self.enc_l.can_go(state, target), self.enc_r.can_go(state, target))

    def run(self, all_regions: bool = False) -> EquivalenceResult:
        if self.left.initial != self.right.initial:
            detail = f"initial states differ: {self.left.initial} vs {self.right.initial}"
            return EquivalenceResult("violated", Counterexample(()), detail=detail)
        first: Counterexample | None = None
        regions: list[Region] = []
        for state in self.common_states():
            if not self.ask(self.differs(state)):
                continue
            if first is None:
                first = self.distinguishing(state)
                if not all_regions:
                    break
            regions.extend(self.regions(state))
        if first is not None:
            detail = f"they first differ in {first.steps[-1].state} after {len(first.steps) - 1} common steps"
            return EquivalenceResult("violated", first, regions, detail)
        verdict: Verdict = "unknown" if self.unknown else "holds"
        return EquivalenceResult(verdict, detail=f"same behaviour in all {len(self.order)} states both reach")

    def common_states(self) -> list[str]:
        """States both machines reach by the same sequence of states, breadth-first."""
        start = self.left.initial
        self.order = [start]
        queue = deque([start])
        while queue:
            state = queue.popleft()
            for target in self.states:
                if target not in self.parent and target != start and self.ask(self.both(state, target)):
                    self.parent[target] = (state, target)
                    self.order.append(target)
                    queue.append(target)
        return self.order

    def path_to(self, state: str) -> list[tuple[str, str]]:
        path = []
        while state in self.parent:
            path.append(self.parent[state])
            state = self.parent[state][0]
        return path[::-1]

    def outcomes(self, state: str, inputs: dict[str, bool]) -> tuple[tuple[Outcome, ...], tuple[Outcome, ...]]:
        def gap_if_empty(outs: tuple[Outcome, ...], name: str) -> tuple[Outcome, ...]:
            return outs or (Outcome(None, None, None, name),)

        left = gap_if_empty(self.enc_l.outcomes(state, inputs, self.left.name), self.left.name)
        right = gap_if_empty(self.enc_r.outcomes(state, inputs, self.right.name), self.right.name)
        return left, right

    def step(self, state: str, formula: z3.BoolRef, target: str | None) -> Step:
        inputs = self.solver.witness(formula)
        assert inputs is not None
        left, right = self.outcomes(state, inputs)
        main = next((o for o in left if o.next == target), left[0])
        rest = tuple(o for o in left if o is not main) + right
        return Step(state, inputs, main, rest)

    def distinguishing(self, state: str) -> Counterexample:
        steps = [self.step(src, self.both(src, dst), dst) for src, dst in self.path_to(state)]
        steps.append(self.step(state, self.differs(state), None))
        return Counterexample(tuple(steps))

    def regions(self, state: str) -> list[Region]:
        """Cover the inputs where the machines differ in `state` with cubes of uniform behaviour."""
        result: list[Region] = []
        blocked: list[z3.BoolRef] = []
        names = self.solver.names
        path = [self.solver.witness(self.both(src, dst)) or {} for src, dst in self.path_to(state)]
        while len(result) < MAX_CUBES:
            inputs = self.solver.witness(z3.And(self.differs(state), *[z3.Not(b) for b in blocked]))
            if inputs is None:
                break
            same = self.same_behaviour(state, inputs)
            cube = dict(inputs)
            for name in names:
                trial = {k: v for k, v in cube.items() if k != name}
                if self.solver.check(z3.And(self.solver.point(trial), z3.Not(same))) == "unsat":
                    cube = trial
            blocked.append(self.solver.point(cube))
            left, right = self.outcomes(state, inputs)
            result.append(Region(state, cube, left, right, (*path, inputs)))
        return result

    def same_behaviour(self, state: str, inputs: dict[str, bool]) -> z3.BoolRef:
        """Inputs under which both machines fire the same transitions (or have the same gap) as under `inputs`."""
        point = self.solver.point(inputs)
        parts = []
        for enc in (self.enc_l, self.enc_r):
            conds = [m.cond for m in enc.moves.get(state, ())]
            conds += [enc.gaps[state]] if state in enc.gaps else []
            for cond in conds:
                parts.append(cond if self.solver.check(z3.And(point, cond)) == "sat" else z3.Not(cond))
        return z3.And(*parts)


def compare(
    left: Machine, right: Machine, timeout_ms: int = DEFAULT_TIMEOUT_MS, all_regions: bool = False
) -> EquivalenceResult:
    """Are `left` and `right` equivalent? With `all_regions`, list every difference, not only the first."""
    return Comparator(left, right, timeout_ms).run(all_regions)
