"""Every check of a machine with data, decided symbolically (k-induction, PDR, BMC; see `induction`)."""

from __future__ import annotations

import time
from collections.abc import Callable, Collection
from dataclasses import dataclass, replace
from functools import partial

import z3

from mlca_verify.logic.binary64 import Rounding
from mlca_verify.logic.finite import Finite, Paths, Tracer, prebuild, replay
from mlca_verify.logic.induction import Bad, Limits, Path, Search, Unrollings, decide, lasso, witnesses
from mlca_verify.logic.lemmas import decide as decide_lemma
from mlca_verify.logic.replay64 import follows
from mlca_verify.logic.results import Counterexample, Kind, Number, Outcome, Proof, Result, Step
from mlca_verify.logic.sites import (
    INT64,
    OverflowSite,
    Site,
    division_cone,
    division_sites,
    divisions,
    overflow_sites,
    step_cone,
)
from mlca_verify.logic.symbolic import (
    Frame,
    Monitor,
    StepInputs,
    StepTerms,
    System,
    Valuation,
    input_only,
    python_value,
    value_of,
)
from mlca_verify.model import (
    Call,
    Definition,
    Expr,
    Invariant,
    Lemma,
    Liveness,
    Machine,
    Num,
    Output,
    Prev,
    Var,
    Variable,
    Verdict,
    nodes,
    prevs_of,
)
from mlca_verify.words import count


def _reads_validity(m: Machine, *exprs: Expr) -> bool:
    """Whether `exprs` test a sample's validity, directly or through an output that reads signals."""
    gated = {o.name: o.expr for o in m.outputs if o.signals}
    read = [*exprs, *(gated[n.name] for e in exprs for n in nodes(e) if isinstance(n, Var) and n.name in gated)]
    return any(isinstance(n, Call) and n.fn == "valid" for e in read for n in nodes(e))


WITNESSES = ("reach:", "fires:")  # the checks a run answers
Decision = tuple[Verdict, Search | None, str, Counterexample | None]


@dataclass(frozen=True)
class Job:
    prop: str
    kind: Kind
    expected: Verdict
    cite: str
    run: Callable[[], Decision]
    parametric: bool
    exprs: tuple[Expr, ...] = ()  # what the property reads beside the step (for the binary64 and division cones)


class DataChecker:
    """Runs every built-in check and declared property of one machine with data."""

    def __init__(self, machine: Machine, limits: Limits, parametric: bool = False) -> None:
        self.m = machine
        self.limits = limits
        self.parametric = parametric
        self.abstractable = input_only(machine)
        self.assumed = tuple(a.id for a in machine.assumptions)
        self._cover: dict[str, Path] | None = None
        self._systems: dict[tuple[object, ...], System] = {}
        self.unrollings = Unrollings(limits.timeout_ms)  # one per system and kind, shared by every query
        self._rounding: dict[bool, Rounding] = {}
        self.unsafe: set[str] = set()  # the elements whose div: check does not hold
        self._step_cone: frozenset[str] | None = None
        self._finite: Finite | None = None
        self._paths: Paths = {}
        self._tracer: Tracer | None = None
        self._prebuilt = False
        self._traces: dict[int, tuple[Path, Counterexample]] = {}

    # --- plumbing ------------------------------------------------------------------------------------

    def systems(
        self, exprs: tuple[Expr, ...], parametric: bool, monitors: tuple[Monitor, ...] = (), total: bool = False
    ) -> tuple[System, System]:
        """The abstract system a proof runs on, and the real one counterexamples are searched on."""
        m = self.m
        if total and m.otherwise == "undefined":
            m = replace(m, otherwise="stay")
        prevs = prevs_of(*exprs, *(e for c in monitors for e in (c.assume, c.goal)))
        abstract = frozenset() if _reads_validity(m, *exprs) else self.abstractable
        return self.system(m, prevs, monitors, abstract, parametric), self.system(
            m, prevs, monitors, frozenset(), parametric
        )

    def system(
        self,
        m: Machine,
        prevs: tuple[Prev, ...],
        monitors: tuple[Monitor, ...],
        abstract: frozenset[str],
        parametric: bool,
    ) -> System:
        """One system per distinct query shape: checks that need the same frame share its step template."""
        key = (m.otherwise, prevs, monitors, abstract, parametric)
        if key not in self._systems:
            self._systems[key] = System(m, prevs, monitors, abstract, parametric=parametric)
        return self._systems[key]

    def result(self, job: Job) -> Result:
        start = time.perf_counter()
        verdict, search, detail, trace = job.run()
        seconds = time.perf_counter() - start
        proof = None
        if search is not None:
            proof = Proof(
                engine=search.engine,
                parametric=job.parametric,
                k=search.k,
                certificate=search.certificate,
                certificate_checked=search.certificate_checked,
                assumptions=self.assumed,
                notes=tuple(search.notes) + ((search.reason,) if search.reason else ()),
            )
        replayed = self.replays(job, search)
        caveat = "" if replayed else self.caveat(job, verdict, search)
        result = Result(job.prop, job.kind, verdict, job.expected, job.cite, seconds, trace, detail, proof, caveat)
        return result if replayed else self.undivided(job, result, search)

    def replays(self, job: Job, search: Search | None) -> bool:
        """Is the job's witness a run of the code too (replayed in binary64, it fires the same transitions)?"""
        witness = job.kind in ("reachability", "dead-transition")
        return witness and search is not None and search.path is not None and follows(self.m, self.trace(search.path))

    def undivided(self, job: Job, r: Result, search: Search | None) -> Result:
        """`r`, made unknown when it depends on a division whose divisor can be zero (z3 gives x/0 any value,
        the code IEEE 754's infinity or NaN), unless no search decided it (a witness that is a run of the code is
        not brought here)."""
        if not self.unsafe:
            return r
        if self._step_cone is None:
            self._step_cone = step_cone(self.m)
        hit = sorted(self.unsafe & division_cone(self.m, self._step_cone, job.exprs, job.prop))
        if not hit or search is None or r.verdict == "unknown" or job.kind in ("division", "lemma"):
            return r
        why = (
            f"not decided for the code: it depends on div:{hit[0]}, where a divisor can be zero "
            f"(the code computes IEEE 754's infinity or NaN there; the engine's x/0 is any value)"
        )
        return replace(r, verdict="unknown", detail=why, counterexample=None, caveat="")

    def caveat(self, job: Job, verdict: Verdict, search: Search | None) -> str:
        """Why a verdict decided over the reals may not hold for the code's arithmetic (binary64 or binary32), or
        "" when it does."""
        if verdict == "unknown" or search is None or job.kind == "lemma":
            return ""
        if job.parametric not in self._rounding:
            self._rounding[job.parametric] = Rounding(self.m, job.parametric)
        proved = search.answer == "unreachable" and not search.on_real
        abstracted = self.abstractable if proved and not _reads_validity(self.m, *job.exprs) else frozenset()
        fault = self._rounding[job.parametric].at_fault(job.exprs, abstracted)
        if fault is None:
            return ""
        return f"{verdict} over the reals; not shown for {self.m.reals}: {fault} may go either way under rounding"

    def trace(self, path: Path) -> Counterexample:
        """The counterexample of a path (made once per path)."""
        if id(path) not in self._traces:  # the path is kept with its trace, so its id is never reused
            self._traces[id(path)] = (path, self.traced(path))
        return self._traces[id(path)][1]

    def traced_explicitly(self, path: Path, run: list[int], loop_start: int | None) -> None:
        """Keep the counterexample of an explicit run's path as the explicit engine builds it (when it can)."""
        if id(path) in self._traces or self._finite is None:
            return
        if self._tracer is None:
            self._tracer = Tracer(self._finite)
        found = self._tracer.counterexample(run, loop_start)
        if found is not None:
            self._traces[id(path)] = (path, found)

    def traced(self, path: Path) -> Counterexample:
        model, system = path.model, path.system
        names = system.m.states
        steps = []
        for n, terms in enumerate(path.terms):

            def val(t: z3.ExprRef) -> Number:
                return python_value(model.eval(t, model_completion=True))

            fired = next(
                (t for t in system.m.transitions if z3.is_true(model.eval(terms.fired[t.id], model_completion=True))),
                None,
            )
            state = names[int(val(path.frames[n].mode))]
            nxt = names[int(val(path.frames[n + 1].mode))]
            outcome = Outcome(fired.id if fired else None, fired.cite if fired else None, nxt)
            steps.append(
                Step(
                    state,
                    {k: bool(val(v)) for k, v in path.inputs[n].bools.items()},
                    outcome,
                    signals={k: val(v) for k, v in path.inputs[n].signals.items()},
                    definitions={d.name: val(system.ev(Var(d.name), terms.pre)) for d in system.m.definitions},
                    variables={k: val(v) for k, v in path.frames[n + 1].variables.items()},
                    outputs={k: val(v) for k, v in system.outputs_at(terms.post).items()},
                )
            )
        params = {
            p.name: val(v) for p, v in zip(system.m.params, system.param_values(path.frames[0]).values(), strict=True)
        }
        return Counterexample(tuple(steps), path.loop_start, params)

    def search(
        self,
        exprs: tuple[Expr, ...],
        bad: Bad,
        *,
        parametric: bool,
        monitors: tuple[Monitor, ...] = (),
        total: bool = False,
        certify: bool = True,
        target: str | None = None,
    ) -> Search:
        """Is a `bad` step reachable? With params fixed and a `target` the explicit engine knows: its first search,
        then k-induction, then its whole search, then the symbolic engines to the end (PDR, deeper BMC)."""
        system, real = self.systems(exprs, parametric, monitors, total)
        finite = None if parametric else self.finite()
        if finite is not None and target is not None:
            for deepen in (False, True):
                found = self.explicitly(finite, target, real, bad, deepen=deepen, bounded=bool(monitors))
                if found is not None:
                    return found
                if not deepen:
                    quick = decide(system, real, bad, self.limits, certify, quick=True, pool=self.unrollings)
                    if quick.answer != "unknown":
                        return quick
        return decide(system, real, bad, self.limits, certify, pool=self.unrollings)

    def finite(self) -> Finite | None:
        """The explicit-state engine of this machine (params at their defaults), or None where it cannot run."""
        if self._finite is None:
            self._finite = Finite(self.m, self.limits.timeout_ms, self.limits.steps)
            self._finite.witnesses()
        return self._finite if self._finite.usable and self.limits.steps > 0 else None

    def explicitly(
        self, finite: Finite, target: str, real: System, bad: Bad, *, deepen: bool, bounded: bool
    ) -> Search | None:
        """The explicit engine's answer for `target` as a search: a run (replayed on `real` for its trace), or a
        proof; None when it has not decided (or the symbolic semantics did not confirm its run)."""
        answer = finite.respond(target, deepen) if bounded else finite.ask(target, deepen)
        if answer.run is not None:
            path = replay(finite, target, real, answer.run, partial(_last_bad, bad), paths=self._paths)
            if path is not None:
                self.traced_explicitly(path, answer.run, None)
                return Search("reachable", path, "explicit", len(answer.run), on_real=True)
        if answer.never:
            return Search("unreachable", engine="explicit", notes=[finite.size()], on_real=True)
        return None

    # --- checks --------------------------------------------------------------------------------------

    def run_all(self) -> list[Result]:
        m = self.m
        results = [
            Result(
                "determinism",
                "determinism",
                "holds",
                m.expected("determinism"),
                m.cite,
                0.0,
                None,
                "first-match: the first enabled transition in file order fires",
            )
        ]
        jobs = self.jobs()
        divisions = self.divisions(jobs)
        results += [divisions[job.prop] if job.prop in divisions else self.result(job) for job in jobs]
        return results

    def divisions(self, jobs: list[Job]) -> dict[str, Result]:
        """The division checks, first: a proof that rests on a division they do not show safe says so."""
        divisions = {job.prop: self.result(job) for job in jobs if job.kind == "division"}
        self.unsafe = {p.removeprefix("div:") for p, r in divisions.items() if r.verdict != "holds"}
        return divisions

    def jobs(self) -> list[Job]:
        """Every check but determinism, in report order."""
        m, p = self.m, self.parametric
        jobs = [Job("completeness", "completeness", m.expected("completeness"), m.cite, self.completeness, p)]
        jobs += [
            Job(f"reach:{s}", "reachability", m.expected(f"reach:{s}"), m.cite, partial(self.reach, s), p)
            for s in m.states
        ]
        jobs += [
            Job(f"fires:{t.id}", "dead-transition", m.expected(f"fires:{t.id}"), t.cite, partial(self.fires, t.id), p)
            for t in m.transitions
        ]
        jobs += [
            Job(f"range:{v.name}", "range", m.expected(f"range:{v.name}"), v.cite, partial(self.in_range, v.name), p)
            for v in m.variables
            if v.range is not None
        ]
        jobs += [
            Job(
                f"range:{o.name}",
                "range",
                m.expected(f"range:{o.name}"),
                o.cite,
                partial(self.in_range, o.name),
                p,
                (o.expr,),
            )
            for o in m.outputs
            if o.range is not None
        ]
        for site in division_sites(m):
            prop = f"div:{site.name}"
            run = partial(self.division, site)
            jobs.append(Job(prop, "division", m.expected(prop), m.cite, run, p, site.exprs))
        for risky in overflow_sites(m):
            prop = f"ovf:{risky.site.name}"
            run = partial(self.overflow, risky)
            jobs.append(Job(prop, "overflow", m.expected(prop), m.cite, run, p, risky.site.exprs))
        for inv in m.invariants:
            q = p or inv.parametric
            jobs.append(Job(inv.id, "invariant", inv.expect, inv.cite, partial(self.invariant, inv, q), q, (inv.expr,)))
        for live in m.liveness:
            q = p or live.parametric
            exprs = (live.assume, live.goal) + ((live.bound,) if live.bound is not None else ())
            jobs.append(Job(live.id, "liveness", live.expect, live.cite, partial(self.liveness, live, q), q, exprs))
        for lem in m.lemmas:
            q = p or lem.parametric
            jobs.append(Job(lem.id, "lemma", lem.expect, lem.cite, partial(self.lemma, lem, q), q))
        return jobs

    def lemma(self, lem: Lemma, parametric: bool) -> Decision:
        verdict, detail, trace = decide_lemma(self.m, lem, parametric, self.limits.timeout_ms)
        return verdict, None, detail, trace

    def completeness(self) -> Decision:
        if self.m.otherwise == "stay":
            return "holds", None, "otherwise = stay: a state with no enabled transition keeps its state", None

        def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
            return z3.Not(t.enabled_any)

        found = self.search((), bad, parametric=self.parametric, total=True, target="completeness")
        if found.answer == "reachable" and found.path is not None:
            cx = self.stuck_trace(found.path)
            detail = f"in {cx.steps[-1].state} no transition is enabled and otherwise = undefined"
            return "violated", found, detail, cx
        return self.proved(found)

    def stuck_trace(self, path: Path) -> Counterexample:
        """The trace of a run whose last step the machine cannot take (a total system stays there)."""
        cx = self.trace(path)
        last = cx.steps[-1]
        stuck = Step(
            last.state, last.inputs, Outcome(None, None, None), signals=last.signals, definitions=last.definitions
        )
        return Counterexample((*cx.steps[:-1], stuck), None, cx.params)

    def proved(self, found: Search, what: str = "") -> Decision:
        if found.answer == "unreachable" and found.engine == "pdr" and not found.certificate_checked:
            return "unknown", found, "PDR proved it, but a separate query did not confirm its certificate", None
        if found.answer == "unreachable":
            how = _engine(found)
            cert = (
                ""
                if found.certificate is None
                else (", certificate checked" if found.certificate_checked else ", certificate NOT confirmed")
            )
            return "holds", found, f"proved by {how}{cert}{what}", None
        return "unknown", found, found.reason, None

    def cover(self) -> dict[str, Path]:
        """Witnesses of every reachability check (reach:S, fires:t), found by one shared BMC run."""
        if self._cover is None:
            system, real = self.systems((), self.parametric)
            targets: dict[str, Bad] = {f"reach:{s}": _reaches(s) for s in self.m.states}
            targets.update({f"fires:{t.id}": _fires(t.id) for t in self.m.transitions})
            self._cover = witnesses(system, real, targets, self.limits, self.unrollings)
        return self._cover

    def reach(self, state: str) -> Decision:
        never = f"no run from {self.m.initial} reaches {state}"

        def seen(n: int) -> str:
            steps = count(n, "step")
            return f"the initial state, entered again in {steps}" if state == self.m.initial else f"reached in {steps}"

        return self.witnessed(f"reach:{state}", _reaches(state), seen, never)

    def fires(self, tid: str) -> Decision:
        return self.witnessed(f"fires:{tid}", _fires(tid), lambda n: f"fires at step {n}", "never fires")

    def witnessed(self, prop: str, bad: Bad, seen: Callable[[int], str], never: str) -> Decision:
        """A reachability check: holds with the shortest run that meets `bad` (from the shared witness run, else
        a search of its own), violated when that search proves no run does."""
        finite = None if self.parametric else self.finite()
        found = None
        if finite is not None:
            real = self.systems((), False)[1]
            if not self._prebuilt:
                self._prebuilt = True
                runs = [finite.ask(name, deepen=False).run for name in finite.goals if name.startswith(WITNESSES)]
                prebuild(finite, real, [r for r in runs if r is not None], self._paths)
            found = self.explicitly(finite, prop, real, bad, deepen=False, bounded=False)
        if found is None:
            path = self.cover().get(prop)
            found = Search("reachable", path, "bmc", len(path.inputs)) if path is not None else None
        if found is None:
            found = self.search((), bad, parametric=self.parametric, certify=False, target=prop)
        if found.answer == "reachable" and found.path is not None:
            return "holds", found, seen(len(found.path.inputs)), None
        if found.answer == "unreachable":
            how = _engine(found) if found.engine == "explicit" else found.engine
            return "violated", found, f"{never} (proved by {how})", None
        return "unknown", found, found.reason, None

    def in_range(self, name: str) -> Decision:
        """Does a variable, or an output, leave its declared range after some step?"""
        ranged: list[Variable | Output] = [*self.m.variables, *self.m.outputs]
        element = next(e for e in ranged if e.name == name)
        assert element.range is not None
        low, high = element.range
        output = isinstance(element, Output)

        def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
            x = s.ev(Var(name), t.post) if output else post.variables[name]
            return z3.Or(x < value_of(low, element.type), x > value_of(high, element.type))

        exprs = (Var(name),) if output else ()
        found = self.search(exprs, bad, parametric=self.parametric, target=f"range:{name}")
        return self.violation(found, f"{name} leaves [{low}, {high}]")

    def division(self, site: Site) -> Decision:
        """Can a divisor in `site` be zero where its value is used? Definitions are read both before the step
        (by guards) and after it (by properties); a boolean definition's samples must be valid to be read."""
        divisors = tuple(d.right for e in site.exprs for d in divisions(e))
        found = self.search(site.exprs, self.at_site(site, divisors, lambda t: t == 0), parametric=self.parametric)
        return self.violation(found, f"a divisor in {site.name} can be zero")

    def at_site(
        self, site: Site, terms: tuple[Expr, ...], wrong: Callable[[z3.ExprRef], z3.BoolRef], signals: bool = False
    ) -> Bad:
        """A step where one of `terms` of `site`, evaluated where the code evaluates it, is `wrong`; the samples
        of a definition or an output valid (the code reads it only then); with `signals`, every int sample within
        64 bits."""
        sampled: list[Definition | Output] = [*self.m.definitions, *self.m.outputs]
        element = next((e for e in sampled if e.name == site.name), None)
        needed = element.signals if element is not None else ()
        ints = [s.name for s in self.m.signals if s.type == "int"] if signals else []
        low, high = z3.IntVal(INT64[0]), z3.IntVal(INT64[1])

        def hit(s: System, v: Valuation) -> z3.BoolRef:
            fits = [z3.And(v.inputs.signals[n] >= low, v.inputs.signals[n] <= high) for n in ints]
            return z3.And(z3.Or(*[wrong(s.ev(t, v)) for t in terms]), *[s.valid(g, v) for g in needed], *fits)

        def bad(s: System, pre: Frame, i: StepInputs, after: Frame, t: StepTerms) -> z3.BoolRef:
            where = {"pre": [t.pre], "post": [t.post], "both": [t.post, t.pre]}[site.when]
            return z3.Or(*[hit(s, v) for v in where])

        return bad

    def overflow(self, risky: OverflowSite) -> Decision:
        """Can an int value computed in an element leave the generated code's 64 bits where it is computed?"""
        low, high = z3.IntVal(INT64[0]), z3.IntVal(INT64[1])
        bad = self.at_site(risky.site, risky.nodes, lambda t: z3.Or(t < low, t > high), signals=True)
        found = self.search(risky.site.exprs, bad, parametric=self.parametric)
        return self.violation(found, f"an int value in {risky.site.name} leaves the 64 bits of the generated code")

    def violation(self, found: Search, what: str) -> Decision:
        if found.answer == "reachable" and found.path is not None:
            return "violated", found, what, self.trace(found.path)
        return self.proved(found)

    def invariant(self, inv: Invariant, parametric: bool) -> Decision:
        def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
            return z3.Not(s.ev(inv.expr, t.post))

        found = self.search((inv.expr,), bad, parametric=parametric, target=inv.id)
        return self.violation(found, f"after the last step {inv.id} fails")

    def liveness(self, live: Liveness, parametric: bool) -> Decision:
        bound = live.steps_bound
        if bound is None:
            return self.lasso(live, parametric)
        monitor = Monitor("respond", live.assume, live.goal, bound)

        def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
            return post.counters["respond"] >= s.ev(bound, t.post)

        exprs = (live.assume, live.goal, bound)
        found = self.search(exprs, bad, parametric=parametric, monitors=(monitor,), target=live.id)
        span = count(int(bound.value), "step") if isinstance(bound, Num) else "the whole bound"
        waited = self.violation(found, f"the assumption holds for {span} and the goal is not met")
        return _with_stall(self.stall(live, parametric), waited)

    def explicit_loop(
        self, finite: Finite, live: Liveness, real: System, restricted: Callable[[StepTerms], z3.BoolRef]
    ) -> Decision | None:
        """A response without a bound decided by the explicit engine: a loop it found (replayed), or none among
        all the configurations; None when it did not decide."""
        answer = finite.loop(live.id)
        if answer.run is not None and answer.loop_start is not None:
            final = _looped(restricted, answer.loop_start)
            path = replay(finite, live.id, real, answer.run, final, loop_start=answer.loop_start, paths=self._paths)
            if path is not None:
                self.traced_explicitly(path, answer.run, answer.loop_start)
                search = Search("reachable", path, "explicit", len(answer.run), on_real=True)
                return _looping(search, self.trace(path))
        if answer.never:
            search = Search("unreachable", engine="explicit", notes=[finite.size()], on_real=True)
            return "holds", search, f"proved by {_engine(search)}: no reachable loop keeps the goal away", None
        return None

    def lasso(self, live: Liveness, parametric: bool) -> Decision:
        """A response without a bound: violated by a run that gets stuck where the assumption holds and the goal
        does not (see `stall`), or by a lasso on which the assumption holds and the goal never does; the shorter
        of the two counterexamples is shown (the stuck run where they are as long)."""
        return _with_stall(self.stall(live, parametric), self.loop(live, parametric))

    def stall(self, live: Liveness, parametric: bool) -> Decision | None:
        """Where the machine may be undefined (otherwise = "undefined"): can it get stuck in a state where the
        assumption holds and the goal does not (it keeps that state, so the goal never comes, however long the
        bound)? None where it cannot get stuck at all, or where no such step is reachable."""
        if self.m.otherwise != "undefined":
            return None

        reads_prev = bool(prevs_of(live.assume, live.goal))

        def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
            at = t.post if reads_prev else t.pre  # prev() is read after a step: there, the stay the step is read as
            return z3.And(z3.Not(t.enabled_any), s.ev(live.assume, at), z3.Not(s.ev(live.goal, at)))

        target = None if parametric or reads_prev else f"stall:{live.id}"
        found = self.search((live.assume, live.goal), bad, parametric=parametric, total=True, target=target)
        if found.answer == "unreachable":
            return None
        if found.answer == "reachable" and found.path is not None:
            cx = self.stuck_trace(found.path)
            where = cx.steps[-1].state
            detail = f"the assumption holds, the goal never does, and the machine gets stuck in {where}"
            return "violated", found, detail, cx
        return "unknown", found, found.reason, None

    def loop(self, live: Liveness, parametric: bool) -> Decision:
        _, real = self.systems((live.assume, live.goal), parametric)

        def restricted(t: StepTerms) -> z3.BoolRef:
            return z3.And(real.ev(live.assume, t.post), z3.Not(real.ev(live.goal, t.post)))

        finite = None if parametric else self.finite()
        if finite is not None:
            decided = self.explicit_loop(finite, live, real, restricted)
            if decided is not None:
                return decided
        answer, path = lasso(real, restricted, self.limits, self.unrollings)
        search = Search(answer, path, "lasso", self.limits.lasso)
        if answer == "reachable" and path is not None:
            return _looping(search, self.trace(path))
        search.reason = (
            f"no lasso within {self.limits.lasso} steps; a response without a bound is not proved beyond that"
        )
        return "unknown", search, search.reason, None


def _last_bad(bad: Bad, path: Path) -> z3.BoolRef:
    return bad(path.system, path.frames[-2], path.inputs[-1], path.frames[-1], path.terms[-1])


def _looped(restricted: Callable[[StepTerms], z3.BoolRef], start: int) -> Callable[[Path], z3.BoolRef]:
    """That a replayed run ends in the frame its step `start` began in, through restricted steps."""

    def final(path: Path) -> z3.BoolRef:
        same = [a == b for a, b in zip(path.frames[start].looped(), path.frames[-1].looped(), strict=True)]
        return z3.And(*same, *[restricted(t) for t in path.terms[start:]])

    return final


def _with_stall(stuck: Decision | None, other: Decision) -> Decision:
    """A response's verdict from its runs that wait (a lasso, or the bound's steps: `other`) and from a run that
    gets stuck short of the goal (`stuck`, None where none can): violated by either, the shorter counterexample
    shown (the stuck run where they are as long); unknown where `other` holds and the stuck run is undecided."""
    if stuck is None:
        return other
    if stuck[0] == "violated":
        if other[0] == "violated" and other[3] is not None and stuck[3] is not None:
            return other if len(other[3].steps) < len(stuck[3].steps) else stuck
        return stuck
    if other[0] == "violated":
        return other
    _, search, reason, _ = stuck
    return "unknown", search, f"{other[2]}; but whether the machine can get stuck short of the goal: {reason}", None


def _looping(search: Search, trace: Counterexample) -> Decision:
    """A response without a bound violated by a lasso, and where its loop starts."""
    start = trace.steps[trace.loop_start or 0].state
    detail = f"the assumption holds forever and the goal never does: the run loops through {start}"
    return "violated", search, detail, trace


def _engine(found: Search) -> str:
    """The engine that proved a search, in words."""
    if found.engine == "k-induction":
        return f"k-induction, k = {found.k}"
    if found.engine == "explicit":
        return "an " + found.notes[0] if found.notes else "an explicit-state search"
    return "PDR"


def _reaches(state: str) -> Bad:
    def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
        return s.in_states(post.mode, [state])

    return bad


def _fires(tid: str) -> Bad:
    def bad(s: System, pre: Frame, i: StepInputs, post: Frame, t: StepTerms) -> z3.BoolRef:
        return t.fired[tid]

    return bad


def check_data_machine(machine: Machine, limits: Limits, parametric: bool = False) -> list[Result]:
    return DataChecker(machine, limits, parametric).run_all()


def check_invariants(machine: Machine, limits: Limits, ids: Collection[str], parametric: bool = False) -> list[Result]:
    """The invariants `ids` alone (after the division checks they may rest on)."""
    return check_declared(machine, limits, ids, parametric, kinds=("invariant",))


def check_declared(
    machine: Machine,
    limits: Limits,
    ids: Collection[str],
    parametric: bool = False,
    kinds: Collection[str] = ("invariant", "liveness"),
) -> list[Result]:
    """The declared properties `ids` alone, in report order (after the division checks they may rest on)."""
    checker = DataChecker(machine, limits, parametric)
    jobs = checker.jobs()
    checker.divisions(jobs)
    return [checker.result(job) for job in jobs if job.kind in kinds and job.prop in ids]


def completeness(machine: Machine, limits: Limits) -> Verdict:
    """Whether every reachable step of `machine` has a transition enabled (or otherwise = stay)."""
    checker = DataChecker(machine, limits)
    verdict, _, _, _ = checker.completeness()
    return verdict
