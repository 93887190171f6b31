"""Is a bad step reachable? Bounded model checking, k-induction and PDR (z3's Spacer) on a `System`.

Every question is "can some run take a step that satisfies `bad`?". BMC answers yes with the shortest run;
k-induction answers no with the k it needed; PDR answers no with an inductive invariant (the certificate), which a
separate query checks: it holds initially, is kept by every step, and excludes every bad step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import z3

from mlca_verify.logic import spacer
from mlca_verify.logic.results import Engine
from mlca_verify.logic.solver import budget
from mlca_verify.logic.symbolic import Frame, StepInputs, StepTerms, System, variable_bounds
from mlca_verify.model import Var

Bad = Callable[[System, Frame, StepInputs, Frame, StepTerms], z3.BoolRef]
Answer = Literal["reachable", "unreachable", "unknown"]


@dataclass
class Limits:
    induction: int = 4  # the largest k tried by k-induction before PDR (PDR proves what needs more)
    depth: int = 60  # the deepest BMC run searched for a counterexample
    lasso: int = 12  # the longest lasso searched for an unbounded response
    timeout_ms: int = 10_000
    steps: int = 3_000_000  # the steps the explicit-state engine may take on one search (0: not used)


@dataclass
class Path:
    """A run found by BMC (on the real system): frames, inputs and step terms, with the model that fixes them."""

    system: System
    model: z3.ModelRef
    frames: list[Frame]
    inputs: list[StepInputs]
    terms: list[StepTerms]
    loop_start: int | None = None


@dataclass
class Search:
    answer: Answer
    path: Path | None = None
    engine: Engine = ""
    k: int | None = None
    certificate: str | None = None
    certificate_checked: bool = False
    reason: str = ""
    notes: list[str] = field(default_factory=list)
    on_real: bool = False  # decided on the real system after an abstract counterexample proved spurious
    invariant: z3.BoolRef | None = None  # PDR's certificate as a formula over its frame `p0`


class Unrolling:
    """Frames 0..n of a system in one incremental solver; from the initial frame when `initial`. Step n holds
    only under its activation literal, so a query about the first k steps asks for those k (`check(k, ...)`) and
    leaves the later frames free: one unrolling serves queries of every depth, and every property."""

    def __init__(self, system: System, initial: bool, tag: str, timeout_ms: int) -> None:
        self.system = system
        self.tag = tag
        self.timeout_ms = timeout_ms
        self.solver = z3.Solver()
        budget(self.solver, timeout_ms)
        self.frames = [system.frame(f"{tag}0")]
        self.inputs: list[StepInputs] = []
        self.terms: list[StepTerms] = []
        self.active: list[z3.BoolRef] = []
        self.solver.add(system.well_formed(self.frames[0]))
        if initial:
            self.solver.add(system.init(self.frames[0]))

    def extend(self) -> int:
        """Add one step; return its index."""
        n = len(self.inputs)
        pre, i, post = self.frames[n], self.system.inputs(f"{self.tag}{n}"), self.system.frame(f"{self.tag}{n + 1}")
        link, terms = self.system.step(pre, i, post)
        on = z3.Bool(f"!step@{self.tag}{n}")
        self.solver.add(z3.Implies(on, z3.And(link, self.system.assumptions(pre, i), self.system.well_formed(post))))
        self.frames.append(post)
        self.inputs.append(i)
        self.terms.append(terms)
        self.active.append(on)
        return n

    def reach(self, steps: int) -> None:
        """Extend to at least `steps` steps."""
        while len(self.inputs) < steps:
            self.extend()

    def bad(self, bad: Bad, n: int) -> z3.BoolRef:
        return bad(self.system, self.frames[n], self.inputs[n], self.frames[n + 1], self.terms[n])

    def check(self, steps: int, *extra: z3.BoolRef) -> z3.CheckSatResult:
        """Is there a run of the first `steps` steps (from any frame, or the initial one) that meets `extra`?"""
        self.reach(steps)
        return self.solver.check(*self.active[:steps], *extra)

    def path(self, steps: int, loop_start: int | None = None) -> Path:
        n = steps
        return Path(self.system, self.solver.model(), self.frames[: n + 1], self.inputs[:n], self.terms[:n], loop_start)


class Unrollings:
    """The unrollings of a machine's systems, one from the initial frame and one from any frame for each, shared
    by all of the machine's queries: a spec's cost grows with its deepest query, not with its number of
    properties."""

    def __init__(self, timeout_ms: int) -> None:
        self.timeout_ms = timeout_ms
        self._made: dict[tuple[int, bool], tuple[System, Unrolling]] = {}
        self._invariants: dict[int, tuple[System, list[z3.BoolRef]]] = {}

    def invariants(self, system: System) -> list[z3.BoolRef]:
        """The inductive invariants found so far on `system` (checked certificates, over PDR's frame `p0`)."""
        return self._invariants.setdefault(id(system), (system, []))[1]

    def pdr(self, system: System, bad: Bad) -> Search:
        """PDR on `system`; a proof whose certificate is confirmed is kept among the system's invariants."""
        proof = pdr(system, bad, self.timeout_ms)
        if proof.answer == "unreachable" and proof.certificate_checked and proof.invariant is not None:
            self.invariants(system).append(proof.invariant)
        return proof

    def of(self, system: System, initial: bool) -> Unrolling:
        key = (id(system), initial)  # the system is kept beside its unrolling, so its id is never reused
        if key not in self._made:
            tag = f"{'b' if initial else 'i'}{len(self._made)}_"
            self._made[key] = (system, Unrolling(system, initial, tag, self.timeout_ms))
        return self._made[key][1]


def deeper(base: Unrolling, real: System, bad: Bad, limits: Limits, *, start: int, pool: Unrollings) -> Search:
    """Carry BMC on from step `start` (where k-induction stopped), up to `limits.depth` steps. An unknown's k is
    the number of steps searched."""
    for k in range(start, limits.depth):
        found = base_case(base, real, bad, k, limits, pool=pool)
        if found is not None and found.answer == "unknown" and found.engine == "bmc":
            found.k = k
        if found is not None:
            return found
    return Search("unknown", engine="bmc", k=limits.depth, reason=f"no counterexample within {limits.depth} steps")


Probes = dict[tuple[str, ...], list[z3.ExprRef]]


def concretize(abstract: Unrolling, run: Unrolling, bad: Bad, steps: int, probes: Probes | None = None) -> Path | None:
    """A run of the real system along an abstract counterexample: at each step, signals for which every abstracted
    definition takes the abstract run's value (one small query per step, remembered in `probes` for steps that
    ask the same). None when some step has none. `run` is the real system's shared unrolling: the run is pinned
    inside a push and pop."""
    run.reach(steps)
    run.solver.push()
    try:
        return _follow(abstract, run, bad, steps, {} if probes is None else probes)
    finally:
        run.solver.pop()


def _follow(abstract: Unrolling, run: Unrolling, bad: Bad, steps: int, probes: Probes) -> Path | None:
    model = abstract.solver.model()
    real = run.system

    def fixed(term: z3.ExprRef) -> z3.ExprRef:
        return model.eval(term, model_completion=True)

    for n in range(steps):
        seen = abstract.inputs[n]
        pins = [run.inputs[n].bools[k] == fixed(v) for k, v in seen.bools.items()]
        if seen.abstract:
            frame = list(zip(run.frames[n].terms(), abstract.frames[n].terms(), strict=True))
            if not real.assumptions_read_frame:
                frame = list(zip(run.frames[n].params.values(), abstract.frames[n].params.values(), strict=True))
            asked = [*seen.bools.values(), *seen.abstract.values(), *(b for _, b in frame)]
            key = tuple(str(fixed(t)) for t in asked)
            if key not in probes:
                before = run.terms[n].pre
                wanted = [real.ev(Var(name), before) == fixed(v) for name, v in seen.abstract.items()]
                probe = z3.Solver()
                budget(probe, run.timeout_ms)
                probe.add(*[a == fixed(b) for a, b in frame], *pins, *wanted)
                probe.add(real.assumptions(run.frames[n], run.inputs[n]))
                found = probe.model() if probe.check() == z3.sat else None
                signals = run.inputs[n].signals.values()
                probes[key] = [] if found is None else [found.eval(v, model_completion=True) for v in signals]
            if not probes[key] and run.inputs[n].signals:
                return None
            pins += [v == value for v, value in zip(run.inputs[n].signals.values(), probes[key], strict=False)]
        run.solver.add(*pins)
    if run.check(steps, run.bad(bad, steps - 1)) != z3.sat:
        return None
    return run.path(steps)


def witnesses(
    system: System, real: System, targets: dict[str, Bad], limits: Limits, pool: Unrollings
) -> dict[str, Path]:
    """One BMC run for many targets (the built-in reachability checks): for each, the shortest real run whose last
    step satisfies it, up to `limits.depth` steps; targets not met are left out."""
    run = pool.of(system, True)
    found: dict[str, Path] = {}
    dropped: set[str] = set()  # met only by abstract runs that no real run follows: left to a search of its own
    probes: Probes = {}
    shared = pool.of(real, True)  # real runs along each witness, pinned in turn
    for k in range(limits.depth):
        left = {name: bad for name, bad in targets.items() if name not in found and name not in dropped}
        if not left:
            break
        run.reach(k + 1)
        bad_here = {name: run.bad(bad, k) for name, bad in left.items()}
        if run.check(k + 1, z3.Or(*bad_here.values())) == z3.unsat:
            continue  # no target at this depth: one query instead of one per target
        for name, bad in left.items():
            if run.check(k + 1, bad_here[name]) != z3.sat:
                continue
            path = run.path(k + 1) if system is real else concretize(run, shared, bad, k + 1, probes)
            if path is None:
                dropped.add(name)
            else:
                found[name] = path
    return found


def k_induction(system: System, bad: Bad, real: System, limits: Limits, pool: Unrollings) -> Search:
    """BMC and the induction step on `system` (the real one, or an abstraction of it), for k = 0, 1, ...: a bad
    step from the initial frame is replayed on the real system and reported; an induction step that closes
    proves. Both run on the system's shared unrollings; the induction step assumes no bad step before step k
    for this query only."""
    base, step = pool.of(system, True), pool.of(system, False)
    good: list[z3.BoolRef] = []
    for k in range(limits.induction + 1):
        found = base_case(base, real, bad, k, limits, pool=pool)
        if found is not None:
            return found
        step.reach(k + 1)
        here = step.bad(bad, k)
        if step.check(k + 1, *good, here) == z3.unsat:
            return Search("unreachable", engine="k-induction", k=k + 1)
        good.append(z3.Not(here))
    return Search("unknown", engine="k-induction", k=limits.induction + 1, reason="induction not closed")


def base_case(base: Unrolling, real: System, bad: Bad, k: int, limits: Limits, *, pool: Unrollings) -> Search | None:
    """Is step k of `base` bad? A real counterexample, an unknown, or None (no bad step k)."""
    base.reach(k + 1)
    answer = base.check(k + 1, base.bad(bad, k))
    if answer == z3.unknown:
        why = stopped(base.solver.reason_unknown(), limits.timeout_ms)
        return Search("unknown", engine="bmc", reason=f"BMC at depth {k + 1}: {why}")
    if answer == z3.sat:
        if base.system is real:
            return Search("reachable", base.path(k + 1), "bmc", k + 1)
        path = concretize(base, pool.of(real, True), bad, k + 1)
        if path is not None:
            return Search("reachable", path, "bmc", k + 1)
        why = f"the abstraction has a bad run of {k + 1} steps that no real run follows"
        return Search("unknown", engine="abstraction", reason=why)
    return None


def pdr(system: System, bad: Bad, timeout_ms: int) -> Search:
    """Spacer (z3's PDR for constrained Horn clauses, with global guidance) on `system`: an inductive invariant
    that excludes every bad step. The clauses are written as SMT-LIB text (built in a z3 context of their own,
    from the formulas' text) and solved by a z3 process of their own (`logic.spacer`): in this process Spacer's
    search would depend on every check run before, so the same query could come out proved in one command and
    unknown in the next; in its own process its answer is the same in every call."""
    f0, i, f1, link, terms = system.transition("p")
    ctx = z3.Context()
    named = {t.decl().name(): t for t in [*f0.terms(), *i.terms(), *f1.terms()]}
    decls = {name: z3.Const(name, t.sort().translate(ctx)) for name, t in named.items()}

    def here(formula: z3.BoolRef) -> z3.BoolRef:
        found: z3.BoolRef = z3.parse_smt2_string(f"(assert {formula.sexpr()})", decls=decls, ctx=ctx)[0]
        return found

    state = [decls[t.decl().name()] for t in f0.terms()]
    inv = z3.Function("Inv", *[t.sort() for t in state], z3.BoolSort(ctx))
    err = z3.Function("Err", z3.BoolSort(ctx))
    clauses = z3.Fixedpoint(ctx=ctx)
    clauses.register_relation(inv, err)
    after = [decls[t.decl().name()] for t in f1.terms()]
    clauses.declare_var(*decls.values())
    clauses.rule(inv(*state), here(z3.And(system.init(f0), system.well_formed(f0))))
    step = here(z3.And(link, system.assumptions(f0, i), system.well_formed(f1)))
    moves = z3.And(inv(*state), step)
    clauses.rule(inv(*after), moves)
    clauses.rule(err(), z3.And(moves, here(bad(system, f0, i, f1, terms))))
    answer, printed = spacer.solve(clauses.sexpr(), "Err", timeout_ms)
    if answer == "sat":
        return Search("reachable", engine="pdr", reason="PDR found a bad step reachable (on the abstraction)")
    if answer == "unknown":
        return Search("unknown", engine="pdr", reason=f"PDR: {stopped(printed or 'unknown', timeout_ms)}")
    defined = spacer.invariant(printed, inv, state)
    if defined is None:
        return Search("unknown", engine="pdr", reason="PDR proved it, but its invariant could not be read back")
    certificate = z3.simplify(defined).translate(z3.main_ctx())
    checked = check_certificate(system, bad, certificate, timeout_ms)
    return Search(
        "unreachable", engine="pdr", certificate=certificate.sexpr(), certificate_checked=checked, invariant=certificate
    )


def stopped(raw: str, timeout_ms: int) -> str:
    """Why z3 gave up, in words, with what to try: its own words ("canceled", "timeout") say only that it ran out of
    time."""
    said = raw.strip().lower()
    if any(word in said for word in ("canceled", "cancelled", "timeout", "resource limit")):
        return (
            f"it ran out of its budget (z3's resources for {timeout_ms:,} ms; try a larger --timeout-ms or a smaller"
            " param range)"
        )
    return raw


def _same(term: z3.ExprRef, among: list[z3.ExprRef]) -> bool:
    return any(term.eq(t) for t in among)


def check_certificate(system: System, bad: Bad, certificate: z3.BoolRef, timeout_ms: int) -> bool:
    """A query of its own: the certificate holds initially, every step keeps it, and no step from it is bad."""
    f0, i, f1, link, terms = system.transition("c")
    pdr_frame = system.frame("p0")
    at0 = z3.substitute(certificate, *zip(pdr_frame.terms(), f0.terms(), strict=True))
    at1 = z3.substitute(certificate, *zip(pdr_frame.terms(), f1.terms(), strict=True))
    moves = z3.And(at0, link, system.assumptions(f0, i), system.well_formed(f0), system.well_formed(f1))
    queries = [
        z3.And(system.init(f0), system.well_formed(f0), z3.Not(at0)),
        z3.And(moves, z3.Not(at1)),
        z3.And(moves, bad(system, f0, i, f1, terms)),
    ]
    for query in queries:
        solver = z3.Solver()
        budget(solver, timeout_ms)
        if solver.check(query) != z3.unsat:
            return False
    return True


def lasso(
    real: System, restricted: Callable[[StepTerms], z3.BoolRef], limits: Limits, pool: Unrollings
) -> tuple[Answer, Path | None]:
    """The shortest run that reaches a frame, then returns to it through steps that all satisfy `restricted`."""
    run = pool.of(real, True)
    for n in range(limits.lasso):
        k = n + 1
        run.reach(k)
        loops = []
        for j in range(k):
            same = z3.And(*[a == b for a, b in zip(run.frames[j].looped(), run.frames[k].looped(), strict=True)])
            loops.append(z3.And(same, *[restricted(run.terms[m]) for m in range(j, k)]))
        answer = run.check(k, z3.Or(*loops))
        if answer == z3.sat:
            model = run.solver.model()
            start = next(j for j, loop in enumerate(loops) if z3.is_true(model.eval(loop, model_completion=True)))
            return "reachable", run.path(k, start)
        if answer == z3.unknown:
            return "unknown", None
    return "unknown", None


def decide(
    system: System,
    real: System,
    bad: Bad,
    limits: Limits,
    certify: bool = True,
    *,
    quick: bool = False,
    pool: Unrollings | None = None,
) -> Search:
    """k-induction first. When a bad step is expected (`certify` false: a witness is wanted), deeper BMC, then PDR;
    otherwise PDR (for a proof, or for the certificate of a k-induction proof), then deeper BMC. `quick` stops
    after k-induction (what it leaves open is unknown). The unrollings come from `pool` (the machine's, shared by
    its queries), or are made for this query alone."""
    pool = Unrollings(limits.timeout_ms) if pool is None else pool
    found = k_induction(system, bad, real, limits, pool)
    if quick and found.answer == "unknown":
        return found
    if found.engine == "abstraction":
        return refined(real, bad, limits, certify, found, pool=pool)
    if found.answer == "reachable" or (found.answer == "unknown" and found.engine == "bmc"):
        return found
    start = (found.k or 0) if found.answer == "unknown" else 0
    witness = Search("unknown", k=start)
    if found.answer == "unknown" and not certify:
        witness = deeper(pool.of(system, True), real, bad, limits, start=start, pool=pool)
        if witness.engine == "abstraction":
            return refined(real, bad, limits, certify, witness, pool=pool)
        if witness.answer == "reachable":
            return witness
    if found.answer == "unreachable":
        return certified(found, system, bad, limits.timeout_ms, pool) if certify else found
    proof = pool.pdr(system, bad)
    if proof.answer == "unreachable":
        proof.k = found.k
        proof.notes.append(f"k-induction did not close up to k = {found.k}")
        return proof
    if certify:
        witness = deeper(pool.of(system, True), real, bad, limits, start=start, pool=pool)
        if witness.engine == "abstraction":
            return refined(real, bad, limits, certify, witness, pool=pool)
        if witness.answer == "reachable":
            return witness
    reason = f"induction not closed at k = {found.k}; {proof.reason}; no counterexample within {witness.k} steps"
    return Search("unknown", engine="k-induction+pdr", k=found.k, reason=reason)


def certified(found: Search, system: System, bad: Bad, timeout_ms: int, pool: Unrollings) -> Search:
    """A k-induction proof with a certificate, each checked by queries of its own: `true` when it is 1-inductive
    (no step from any frame is bad); else what is already known of the system, when it is inductive and
    excludes every bad step (the variables' declared ranges, and the invariants PDR found for its other
    properties); else PDR's invariant."""
    if found.k == 1:
        found.certificate, found.certificate_checked = (
            "true",
            check_certificate(system, bad, z3.BoolVal(True), timeout_ms),
        )
        return found
    known = z3.And(*variable_bounds(system.m, system.frame("p0").variables), *pool.invariants(system))
    if check_certificate(system, bad, known, timeout_ms):
        found.certificate, found.certificate_checked = z3.simplify(known).sexpr(), True
        found.notes.append("certificate: the declared ranges and the invariants proved before")
        return found
    proof = pool.pdr(system, bad)
    found.certificate, found.certificate_checked = proof.certificate, proof.certificate_checked
    if proof.answer != "unreachable":
        found.notes.append(f"no certificate: {proof.reason or proof.answer}")
    return found


def refined(real: System, bad: Bad, limits: Limits, certify: bool, spurious: Search, *, pool: Unrollings) -> Search:
    """Decide again on the real system, after an abstract counterexample that no real run follows."""
    found = decide(real, real, bad, limits, certify, pool=pool)
    found.notes.append(f"on the real system: {spurious.reason}")
    found.on_real = True
    return found
