"""Built-in checks, invariants and liveness for one machine. Every violation carries a shortest trace."""

from __future__ import annotations

import heapq
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from functools import partial

import z3

from mlca_verify.logic.graph import Encoding, Move, Reach, explore, make_step, trace_steps
from mlca_verify.logic.results import Counterexample, Kind, Outcome, Result, Step
from mlca_verify.logic.solver import DEFAULT_TIMEOUT_MS, Solver, encode
from mlca_verify.logic.tables import Tables, firing, later_elsewhere, tables_for
from mlca_verify.model import Invariant, Liveness, Machine, Verdict
from mlca_verify.words import count


@dataclass(frozen=True)
class Finding:
    verdict: Verdict
    counterexample: Counterexample | None = None
    detail: str = ""


def _verdict_if_clean(reach: Reach, unknown: bool) -> Verdict:
    return "unknown" if unknown or reach.uncertain else "holds"


class Checker:
    """Runs every check of one machine against one z3 solver."""

    def __init__(self, machine: Machine, timeout_ms: int = DEFAULT_TIMEOUT_MS) -> None:
        self.machine = machine
        self.solver = Solver(machine.input_names, timeout_ms)
        self.enc = Encoding(machine, self.solver)
        self.reach = explore(self.enc)
        self.first_use: dict[str, Move] = {}
        self.transitions = {t.id: t for t in machine.transitions}
        self.position = {t.id: i for i, t in enumerate(machine.transitions)}
        self.fire: dict[str, tuple[Tables | None, dict[str, int]]] = {}
        for move in self.reach.moves():
            self.first_use.setdefault(move.id, move)

    # --- plumbing ------------------------------------------------------------------------------------

    def timed(self, prop: str, kind: Kind, expected: Verdict, cite: str, run: Callable[[], Finding]) -> Result:
        start = time.perf_counter()
        found = run()
        seconds = time.perf_counter() - start
        return Result(prop, kind, found.verdict, expected, cite, seconds, found.counterexample, found.detail)

    def prefix(self, state: str) -> list[Step]:
        return trace_steps(self.enc, self.reach.path_to(state))

    def first_sat(self, candidates: Iterable[tuple[Move, z3.BoolRef]]) -> tuple[Move, z3.BoolRef] | bool | None:
        """The first (nearest) candidate whose formula is satisfiable; False when one answered unknown."""
        unknown = False
        for move, formula in candidates:
            answer = self.solver.check(formula)
            if answer == "sat":
                return move, formula
            unknown |= answer == "unknown"
        return False if unknown else None

    def run_all(self) -> list[Result]:
        m = self.machine
        results = [
            self.timed("determinism", "determinism", m.expected("determinism"), m.cite, self.determinism),
            self.timed("completeness", "completeness", m.expected("completeness"), m.cite, self.completeness),
        ]
        for state in m.states:
            prop = f"reach:{state}"
            results.append(self.timed(prop, "reachability", m.expected(prop), m.cite, partial(self.reachable, state)))
        for t in m.transitions:
            prop = f"fires:{t.id}"
            results.append(self.timed(prop, "dead-transition", m.expected(prop), t.cite, partial(self.fires, t.id)))
        for inv in m.invariants:
            results.append(self.timed(inv.id, "invariant", inv.expect, inv.cite, partial(self.invariant, inv)))
        for live in m.liveness:
            results.append(self.timed(live.id, "liveness", live.expect, live.cite, partial(self.liveness, live)))
        return results

    # --- built-in checks -----------------------------------------------------------------------------

    def determinism(self) -> Finding:
        if self.machine.semantics == "first-match":
            return Finding("holds", detail="first-match: the first enabled transition in file order fires")
        conflicts = ((a, z3.And(a.cond, other)) for state in self.reach.order for a, other in self.conflicts(state))
        hit = self.first_sat(conflicts)
        if isinstance(hit, tuple):
            hit = self.first_pair(hit[0])
        if isinstance(hit, tuple):
            move, formula = hit
            inputs = self.solver.witness(formula)
            assert inputs is not None
            outs = self.enc.outcomes(move.source, inputs)
            step = Step(move.source, inputs, outs[0], outs[1:])
            detail = f"in {move.source} {len(outs)} transitions are enabled at once"
            return Finding("violated", Counterexample((*self.prefix(move.source), step)), detail)
        verdict = _verdict_if_clean(self.reach, hit is False)
        return Finding(verdict, detail="no reachable state has two transitions to different states enabled at once")

    def conflicts(self, state: str) -> list[tuple[Move, z3.BoolRef]]:
        """Each transition of `state`, with the condition that a later one with another target is enabled."""
        moves = [m for m in self.enc.moves[state] if m.transition is not None]
        out = [m.transition for m in moves if m.transition is not None]
        later = later_elsewhere(self.machine, state, out, self.enc.guards[state], self.solver.vars)
        return list(zip(moves, later, strict=True))

    def first_pair(self, a: Move) -> tuple[Move, z3.BoolRef] | bool | None:
        """The first later transition that `a` can be enabled with, to another target."""
        moves = self.enc.moves[a.source]
        later = moves[next(i for i, m in enumerate(moves) if m is a) + 1 :]
        return self.first_sat((a, z3.And(a.cond, b.cond)) for b in later if a.target != b.target)

    def completeness(self) -> Finding:
        if self.machine.otherwise == "stay":
            return Finding("holds", detail="otherwise = stay: a state with no enabled transition keeps its state")
        gaps = ((state, self.enc.gaps[state]) for state in self.reach.order)
        unknown = False
        for state, gap in gaps:
            answer = self.solver.check(gap)
            if answer == "sat":
                inputs = self.solver.witness(gap)
                assert inputs is not None
                step = Step(state, inputs, Outcome(None, None, None))
                detail = f"in {state} no transition is enabled and otherwise = undefined"
                return Finding("violated", Counterexample((*self.prefix(state), step)), detail)
            unknown |= answer == "unknown"
        verdict = _verdict_if_clean(self.reach, unknown)
        return Finding(verdict, detail="every reachable state has a transition enabled for every input")

    def reachable(self, state: str) -> Finding:
        if state in self.reach.dist:
            return Finding("holds", detail=f"reached in {count(self.reach.dist[state], 'step')}")
        verdict: Verdict = "unknown" if self.reach.uncertain else "violated"
        return Finding(verdict, detail=f"no run from {self.machine.initial} reaches {state}")

    def fires(self, tid: str) -> Finding:
        used = self.first_use.get(tid)
        if used is not None:
            return Finding(
                "holds", detail=f"fires from {used.source}, {count(self.reach.dist[used.source], 'step')} in"
            )
        if self.reach.uncertain:
            return Finding("unknown")
        return Finding("violated", detail=self.why_dead(tid))

    def why_dead(self, tid: str) -> str:
        """Explain a dead transition: unreachable sources, an unsatisfiable guard, or earlier transitions."""
        transition = self.transitions[tid]
        guard = self.enc.guard(transition)
        reasons = []
        for state in self.machine.states if transition.sources is None else transition.sources:
            if state not in self.reach.dist:
                reasons.append(f"{state} is unreachable")
            elif self.solver.check(guard) != "sat":
                reasons.append(f"in {state} its guard is unsatisfiable")
            else:
                reasons.append(f"in {state} it is shadowed by {', '.join(self.shadowing(state, tid, guard))}")
        return "never fires: " + "; ".join(reasons)

    def shadowing(self, state: str, tid: str, guard: z3.BoolRef) -> list[str]:
        """The earlier transitions of `state` that fire on some input enabling `guard`. Only moves that fire at
        all can (the reachable state's feasible moves), and over few inputs only those whose truth table meets
        the guard's: z3 is asked about no other."""
        tables, fire = self.fire_tables(state)
        mine = None if tables is None else tables.table(self.transitions[tid].guard)
        earlier = []
        for move in self.reach.edges[state]:
            if move.transition is None or self.position[move.transition.id] >= self.position[tid]:
                break
            if mine is not None and fire[move.id] & mine == 0:
                continue
            if self.solver.check(z3.And(guard, move.cond)) != "unsat":
                earlier.append(move.id)
        return earlier

    def fire_tables(self, state: str) -> tuple[Tables | None, dict[str, int]]:
        """Over few inputs: the truth table of the inputs under which each transition of `state` fires."""
        if state not in self.fire:
            out = [m.transition for m in self.enc.moves[state] if m.transition is not None]
            guards = [t.guard for t in out]
            tables = tables_for(self.machine, guards, self.solver.vars)
            fire = [] if tables is None else firing(tables, guards)
            self.fire[state] = (tables, {t.id: table for t, table in zip(out, fire, strict=False)})
        return self.fire[state]

    # --- declared properties -------------------------------------------------------------------------

    def invariant(self, inv: Invariant) -> Finding:
        vars_ = self.solver.vars
        candidates = ((m, z3.And(m.cond, z3.Not(encode(inv.expr, vars_, m.target)))) for m in self.reach.moves())
        hit = self.first_sat(candidates)
        if isinstance(hit, tuple):
            move, _ = hit
            last = make_step(self.enc, move, z3.Not(encode(inv.expr, vars_, move.target)))
            detail = f"after {move.id} from {move.source} the state is {move.target} and {inv.id} fails"
            return Finding("violated", Counterexample((*self.prefix(move.source), last)), detail)
        return Finding(
            _verdict_if_clean(self.reach, hit is False),
            detail=f"proved over {sum(1 for _ in self.reach.moves())} reachable moves",
        )

    def liveness(self, live: Liveness) -> Finding:
        return LivenessSearch(self, live).run()


class LivenessSearch:
    """Looks for a run on which `assume` holds from some step on while `goal` never does.

    The restricted graph keeps the moves whose step satisfies `assume and not goal`. A violation is a reachable
    lasso in it, or a path in it to a gap (the machine is stuck while the assumption holds and the goal does not
    hold where it is stuck); with `within = K`, any K restricted steps in a row."""

    def __init__(self, checker: Checker, live: Liveness) -> None:
        self.c = checker
        self.live = live
        vars_ = checker.solver.vars
        self.assume = encode(live.assume, vars_)
        self.unknown = False
        self.succ: dict[str, list[Move]] = {}
        self.stuck: set[str] = set()
        for move in checker.reach.moves():
            bad = z3.And(move.cond, self.assume, z3.Not(encode(live.goal, vars_, move.target)))
            if self.ask(bad):
                self.succ.setdefault(move.source, []).append(move)
        for state in checker.reach.order:
            if state in checker.enc.gaps and self.ask(self.stalls(state)):
                self.stuck.add(state)

    def stalls(self, state: str) -> z3.BoolRef:
        """Inputs under which the machine is stuck in `state` (a gap: no transition enabled, otherwise =
        undefined) while the assumption holds and the goal does not hold there: the run ends in `state`, which
        it keeps, so the goal never comes. Stuck where the goal holds, it has come."""
        goal = encode(self.live.goal, self.c.solver.vars, state)
        return z3.And(self.c.enc.gaps[state], self.assume, z3.Not(goal))

    def ask(self, formula: z3.BoolRef) -> bool:
        answer = self.c.solver.check(formula)
        self.unknown |= answer == "unknown"
        return answer == "sat"

    def restrict(self, move: Move) -> z3.BoolRef:
        return z3.And(self.assume, z3.Not(encode(self.live.goal, self.c.solver.vars, move.target)))

    def run(self) -> Finding:
        found = self.bounded() if self.live.within is not None else self.lasso()
        if found is not None:
            return found
        verdict = _verdict_if_clean(self.c.reach, self.unknown)
        moves = count(sum(1 for _ in self.c.reach.moves()), "reachable move")
        if self.live.within is not None:
            how = f"no run keeps the assumption for {count(self.live.within, 'step')} without the goal"
        else:
            how = "no reachable loop keeps the goal away, and no run gets stuck while the assumption holds"
        return Finding(verdict, detail=f"{how} (over {moves})" if verdict == "holds" else "")

    def steps(self, moves: list[Move]) -> list[Step]:
        return [make_step(self.c.enc, m, self.restrict(m)) for m in moves]

    def stuck_step(self, state: str) -> Step:
        inputs = self.c.solver.witness(self.stalls(state))
        assert inputs is not None
        return Step(state, inputs, Outcome(None, None, None))

    def lasso(self) -> Finding | None:
        """Shortest stem-plus-loop (or stem-plus-gap), by Dijkstra from every reachable state at its distance."""
        dist, via = self.dijkstra()
        best: tuple[int, str, list[Move] | None] | None = None
        rank = {s: i for i, s in enumerate(self.c.reach.order)}
        for state in sorted(dist, key=lambda s: (dist[s], rank[s])):
            if best is not None and dist[state] >= best[0]:
                break
            if state in self.stuck:
                best = (dist[state] + 1, state, None)
            cycle = self.shortest_cycle(state)
            if cycle is not None and (best is None or dist[state] + len(cycle) < best[0]):
                best = (dist[state] + len(cycle), state, cycle)
        if best is None:
            return None
        _, state, cycle = best
        stem, restricted = self.unwind(state, via)
        steps = self.c.prefix(stem) + self.steps(restricted)
        if cycle is None:
            detail = f"the assumption holds, the goal never does, and the machine gets stuck in {state}"
            return Finding("violated", Counterexample((*steps, self.stuck_step(state))), detail)
        detail = f"the assumption holds forever and the goal never does: the run loops through {state}"
        return Finding("violated", Counterexample((*steps, *self.steps(cycle)), loop_start=len(steps)), detail)

    def dijkstra(self) -> tuple[dict[str, int], dict[str, Move]]:
        reach = self.c.reach
        order = {s: i for i, s in enumerate(reach.order)}
        dist = dict(reach.dist)
        via: dict[str, Move] = {}
        heap = [(d, order[s], s) for s, d in dist.items()]
        heapq.heapify(heap)
        while heap:
            d, _, state = heapq.heappop(heap)
            if d > dist[state]:
                continue
            for move in self.succ.get(state, []):
                if d + 1 < dist[move.target]:
                    dist[move.target] = d + 1
                    via[move.target] = move
                    heapq.heappush(heap, (d + 1, order[move.target], move.target))
        return dist, via

    def unwind(self, state: str, via: dict[str, Move]) -> tuple[str, list[Move]]:
        """Split the path to `state` into its unrestricted stem (ending state) and its restricted moves."""
        moves: list[Move] = []
        while state in via:
            moves.append(via[state])
            state = via[state].source
        return state, moves[::-1]

    def shortest_cycle(self, start: str) -> list[Move] | None:
        parent: dict[str, Move] = {}
        queue = deque([start])
        seen = {start}
        while queue:
            state = queue.popleft()
            for move in self.succ.get(state, []):
                if move.target == start:
                    path = [move]
                    while path[-1].source != start:
                        path.append(parent[path[-1].source])
                    return path[::-1]
                if move.target not in seen:
                    seen.add(move.target)
                    parent[move.target] = move
                    queue.append(move.target)
        return None

    def bounded(self) -> Finding | None:
        """Some reachable state starts `within` restricted steps in a row, or fewer that end in a gap."""
        k = self.live.within
        assert k is not None
        chain = self.chains(k)
        for state in self.c.reach.order:
            if state not in chain[k]:
                continue
            moves = self.follow(state, chain, k)
            steps = self.c.prefix(state) + self.steps(moves)
            if len(moves) < k:
                steps.append(self.stuck_step(moves[-1].target if moves else state))
            detail = f"the assumption holds for {k} steps and the goal is not met"
            return Finding("violated", Counterexample(tuple(steps)), detail)
        return None

    def chains(self, k: int) -> list[dict[str, Move | None]]:
        """chain[j] holds the states that start j restricted steps in a row: the move to take, or None where
        the state is stuck (a gap under the assumption), which ends the run before the goal."""
        chain: list[dict[str, Move | None]] = [{s: None for s in self.c.reach.order}]
        for _ in range(k):
            layer: dict[str, Move | None] = {s: None for s in self.stuck}
            for state in self.c.reach.order:
                move = next((m for m in self.succ.get(state, []) if m.target in chain[-1]), None)
                if move is not None and state not in self.stuck:
                    layer[state] = move
            chain.append(layer)
        return chain

    def follow(self, state: str, chain: list[dict[str, Move | None]], k: int) -> list[Move]:
        moves: list[Move] = []
        for j in range(k, 0, -1):
            move = chain[j][state]
            if move is None:
                break
            moves.append(move)
            state = move.target
        return moves


def check_machine(machine: Machine, timeout_ms: int = DEFAULT_TIMEOUT_MS) -> list[Result]:
    """Every built-in check and every declared property of `machine`."""
    return Checker(machine, timeout_ms).run_all()
