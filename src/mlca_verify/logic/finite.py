"""The explicit-state engine for the checks of one machine with data whose params are fixed: what `DataChecker`
asks of it before (and after) the symbolic engines.

One search holds every built-in check and invariant as a goal. A goal met gives the classes of the shortest
run that meets it, which the caller replays on the symbolic system (as a check that both engines agree on it)
and the `Tracer` turns into a counterexample; a search that saw every configuration proves each goal it never
met. Responses are decided over the graph of all configurations once the search is complete: a bounded one by the
longest stretch of waiting steps, one without a bound by a loop of them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from fractions import Fraction
from functools import cache, partial

import z3

from mlca_verify.logic.classes import InputClass, TooManyClasses, input_classes
from mlca_verify.logic.concrete import (
    Compiler,
    Env,
    Eval,
    NotFinite,
    Sampled,
    Undecidable,
    Value,
    param_values,
)
from mlca_verify.logic.explicit import (
    Config,
    Counter,
    Goal,
    Labels,
    Search,
    Test,
    compile_step,
    count_after,
    lasso,
    restricted_edges,
    sustained,
)
from mlca_verify.logic.induction import Path
from mlca_verify.logic.results import Counterexample, Number, Outcome, Step
from mlca_verify.logic.symbolic import Frame, System, python_value, value_of
from mlca_verify.model import BinOp, Cmp, Expr, Liveness, Machine, Num, Range, Type, Var, prevs_of

WITNESS_STEPS = 200_000  # steps a first search may take to find every witness before the symbolic engines try
STEPS = 3_000_000  # steps a search may take in all


@dataclass(frozen=True)
class Answer:
    """What the explicit engine says of one goal: `run` (the classes of the shortest run meeting it), or
    `never` (no run meets it: every configuration was seen), or neither (not decided, `why`)."""

    run: list[int] | None = None
    never: bool = False
    loop_start: int | None = None
    why: str = ""


class Finite:
    """Searches over the configurations of `machine` (params at their defaults) for its non-parametric checks."""

    def __init__(self, machine: Machine, timeout_ms: int, steps: int = STEPS) -> None:
        self.m = machine
        self.budget = steps
        self.timeout_ms = timeout_ms
        self.compiler = Compiler(machine, param_values(machine))
        self.reason = ""
        self.classes: tuple[InputClass, ...] = ()
        self.base: Search | None = None
        self.counters: dict[str, Counter] = {}
        self.unbounded: dict[str, Callable[[Env], bool]] = {}
        self.goals: dict[str, Goal] = {}
        try:
            self._build()
        except (NotFinite, TooManyClasses) as exc:
            self.reason = str(exc)
            self.base = None

    # --- building ------------------------------------------------------------------------------------

    def _build(self) -> None:
        m, c = self.m, self.compiler
        frame = [a.expr for a in m.assumptions if c.reads_frame(a.expr)]
        inputs_only = [a.expr for a in m.assumptions if not c.reads_frame(a.expr)]
        step = compile_step(m, c, frame)
        goals = self._builtins()
        for inv in m.invariants:
            test = None if inv.parametric else self._compiled(partial(_invariant, c, inv.expr))
            if test is not None:
                goals[inv.id] = Goal(inv.id, test)
        for live in m.liveness:
            if not live.parametric:
                self._compiled(partial(self._liveness, live, goals))
        registers = [c.compile(p.arg) for p in list(c.prevs)]
        if len(registers) != len(c.prevs):
            raise NotFinite("prev() inside prev()")
        self.classes = input_classes(System(m), list(c.atoms), inputs_only, self.timeout_ms)
        self.goals = goals
        self.labelled = [*self.counters, *self.unbounded]  # the responses, each read through a label of the search
        tests = [self._waiting(live_id) for live_id in self.labelled]
        labels = Labels(tests) if tests else None
        self.base = Search(step, self.classes, registers, list(goals.values()), labels)

    def _waiting(self, live_id: str) -> Callable[[Env], bool]:
        """The steps a response waits on: its assumption holds and its goal does not."""
        if live_id in self.unbounded:
            return self.unbounded[live_id]
        counter = self.counters[live_id]
        return lambda e: bool(counter.assume(e)) and not counter.goal(e)

    def _builtins(self) -> dict[str, Goal]:
        m, c = self.m, self.compiler
        found: dict[str, Goal] = {}
        for s in m.states:
            found[f"reach:{s}"] = Goal(f"reach:{s}", _reaches(c.states[s]), witness=True)
        for k, t in enumerate(m.transitions):
            found[f"fires:{t.id}"] = Goal(f"fires:{t.id}", _fires(k), witness=True)
        for k, v in enumerate(m.variables):
            if v.range is not None:
                low, high = (int(x) if v.type == "int" and x.denominator == 1 else x for x in v.range)
                found[f"range:{v.name}"] = Goal(f"range:{v.name}", _leaves(k, low, high))
        for o in m.outputs:
            test = None if o.range is None else self._compiled(partial(_invariant, c, _within(o.name, o.type, o.range)))
            if test is not None:
                found[f"range:{o.name}"] = Goal(f"range:{o.name}", test)
        if m.otherwise == "undefined":
            found["completeness"] = Goal("completeness", _stuck)
        return found

    def _compiled(self, make: Callable[[], Test | None]) -> Test | None:
        """A property's test, or None when it cannot be compiled (the symbolic engine decides it); a property
        that fails to compile leaves no atom or register behind."""
        atoms, prevs = dict(self.compiler.atoms), dict(self.compiler.prevs)
        try:
            return make()
        except NotFinite:
            self.compiler.atoms, self.compiler.prevs = atoms, prevs
            return None

    def _liveness(self, live: Liveness, goals: dict[str, Goal]) -> None:
        """A response: its waiting steps (a label, or a counter for a bound) and, where the machine may be stuck,
        the goal stall:<id> (stuck where its assumption holds and its goal does not; read before a step, so not
        for a response that reads prev())."""
        c = self.compiler
        assume, goal, bound = c.compile(live.assume), c.compile(live.goal), live.steps_bound
        if bound is None:
            self.unbounded[live.id] = lambda e: bool(assume(e)) and not goal(e)
        else:
            self.counters[live.id] = Counter(assume, goal, c.compile(bound))
        if self.m.otherwise == "undefined" and not prevs_of(live.assume, live.goal):
            goals[f"stall:{live.id}"] = Goal(f"stall:{live.id}", _stalls(assume, goal))

    # --- answers -------------------------------------------------------------------------------------

    @property
    def usable(self) -> bool:
        return self.base is not None

    def witnesses(self) -> None:
        """The first search: until every reachability goal is met (or the witness budget is spent)."""
        if self.base is not None and not self.base.complete:
            self.base.run(min(WITNESS_STEPS, self.budget), until_found=True)

    def ask(self, name: str, deepen: bool) -> Answer:
        """The answer for a goal of the main search (a built-in check or an invariant); with `deepen`, the
        search goes on to its whole budget first."""
        if self.base is None or name not in self.goals:
            return self.undecided()
        search, goal = self.base, self.goals[name]
        if deepen and goal.found is None and not search.complete:
            search.run(self.budget)
        return _answer(search, goal)

    def respond(self, live_id: str, deepen: bool) -> Answer:
        """A bounded response: the shortest run that ends with `bound` steps in a row at which the assumption
        holds and the goal does not, over every configuration (searched to the whole budget with `deepen`)."""
        counter = self.counters.get(live_id)
        if self.base is None or counter is None:
            return self.undecided()
        if deepen:
            self.base.run(self.budget)
        if not self.base.complete:
            return Answer(why=self.base.undecidable or self.incomplete(self.base))
        steps = Fraction(counter.bound(Env(0, (), (), ())))  # over params only: the loader keeps it from 1 on
        try:
            edges = restricted_edges(self.base, self.labelled.index(live_id))
        except Undecidable as exc:
            return Answer(why=f"the explicit-state search stopped: {exc}")
        run = sustained(self.base, edges, max(int(steps), 1))
        return Answer(never=True) if run is None else Answer(run=run)

    def loop(self, live_id: str) -> Answer:
        """A response without a bound: a reachable loop of steps that keep `assume and not goal`."""
        restricted = self.unbounded.get(live_id)
        if self.base is None or restricted is None:
            return self.undecided()
        self.base.run(self.budget)
        if self.base.undecidable:
            return Answer(why=self.base.undecidable)
        try:
            found = lasso(self.base, restricted_edges(self.base, self.labelled.index(live_id)))
        except Undecidable as exc:
            return Answer(why=f"the explicit-state search stopped: {exc}")
        if found is not None:
            return Answer(run=found[0], loop_start=found[1])
        if self.base.complete:
            return Answer(never=True)
        return Answer(why=self.incomplete(self.base))

    def undecided(self) -> Answer:
        """The answer for a goal the engine does not hold (the machine, or the property, is not finite)."""
        return Answer(why=self.reason or "not a goal of the explicit engine")

    def incomplete(self, search: Search) -> str:
        return (
            f"the explicit-state search stopped after {search.steps():,} steps and {len(search.configs):,}"
            f" configurations, short of all of them"
        )

    def size(self) -> str:
        """How large the search was, for a proof's note."""
        search = self.base
        assert search is not None
        return (
            f"explicit-state search: {len(search.configs):,} configurations, {len(self.classes):,}"
            f" input {'class' if len(self.classes) == 1 else 'classes'}, every step checked"
        )


Paths = dict[tuple[int, tuple[int, ...], int | None], "Path | None"]


def replay(
    finite: Finite,
    name: str,
    real: System,
    run: Sequence[int],
    final: Callable[[Path], z3.BoolRef],
    *,
    loop_start: int | None = None,
    paths: Paths | None = None,
) -> Path | None:
    """The explicit run `run` (for the goal `name`) as a path of the symbolic system `real`: every frame and
    input fixed to the explicit engine's values, and z3's own evaluation of each symbolic step (and of `final`:
    the goal's bad step, or its loop) confirming that the symbolic semantics takes the same run. None when it
    does not (the callers then ask the symbolic engines). `paths` keeps the paths built, for runs asked again
    (a state reached and the transition that enters it often share theirs)."""
    paths = {} if paths is None else paths
    key = (id(real), tuple(run), loop_start)
    if key not in paths:
        paths[key] = _prefix(paths, key) or _path(finite, name, real, run, loop_start)
    path = paths[key]
    return path if path is not None and z3.is_true(path.model.eval(final(path), model_completion=True)) else None


def prebuild(finite: Finite, real: System, runs: Sequence[Sequence[int]], paths: Paths) -> None:
    """Build the paths of `runs` longest first, so that a run that begins another is taken from it (the witnesses
    of a search are branches of one tree of shortest runs, and most end inside a longer one)."""
    for run in sorted(runs, key=len, reverse=True):
        key = (id(real), tuple(run), None)
        if key not in paths:
            paths[key] = _prefix(paths, key) or _path(finite, "", real, run, None)


def _prefix(paths: Paths, key: tuple[int, tuple[int, ...], int | None]) -> Path | None:
    """The path of a run that a longer run already built begins with, cut to its length."""
    system, run, loop_start = key
    if loop_start is not None:
        return None
    n = len(run)
    for (other, longer, start), path in paths.items():
        if other == system and start is None and path is not None and len(longer) > n and longer[:n] == run:
            return Path(path.system, path.model, path.frames[: n + 1], path.inputs[:n], path.terms[:n])
    return None


def _path(finite: Finite, name: str, real: System, run: Sequence[int], loop_start: int | None) -> Path | None:
    search, counter = finite.base, finite.counters.get(name)
    assert search is not None
    configs, counts = [search.configs[0]], [Fraction(0)]
    try:
        for c in run:
            taken = search.take(configs[-1], finite.classes[c], total=True)
            assert taken is not None and taken[1] is not None and taken[3] is not None
            configs.append(taken[3])
            counts.append(Fraction(0 if counter is None else count_after(counter, taken[1], counts[-1])))
    except Undecidable:  # a step the search never took (the last of a stuck run) divides by zero
        return None
    frames = [real.frame(f"x{n}") for n in range(len(configs))]
    inputs = [real.inputs(f"x{n}") for n in range(len(run))]
    links = [real.step(frames[n], inputs[n], frames[n + 1]) for n in range(len(run))]
    pins = [  # a frame's `first` is its place in the run (a configuration keeps it only where a register reads it)
        t == v
        for n, (f, config, count) in enumerate(zip(frames, configs, counts, strict=True))
        for t, v in _frame_values(finite, real, f, (config[0], n == 0, *config[2:]), count)
    ]
    for i, c in zip(inputs, run, strict=True):
        cls = finite.classes[c]
        pins += [b == _numeral(v, "bool") for b, v in zip(i.bools.values(), cls.bools, strict=True)]
        pins += [x == v for x, v in zip(i.signals.values(), cls.signals, strict=True)]
    solver = z3.Solver()
    solver.add(*pins)
    if solver.check() != z3.sat:
        return None
    model = solver.model()
    steps = [(link, real.assumptions(frames[n], inputs[n])) for n, (link, _) in enumerate(links)]
    if not all(z3.is_true(model.eval(z3.And(*pair), model_completion=True)) for pair in steps):
        return None
    return Path(real, model, frames, inputs, [t for _, t in links], loop_start)


def _frame_values(
    finite: Finite, real: System, frame: Frame, config: Config, count: Value
) -> list[tuple[z3.ExprRef, z3.ExprRef]]:
    """Each constant of a symbolic frame with its value in an explicit configuration (and the value of the
    response counter, where the frame has one)."""
    m, prevs = finite.m, finite.compiler.prevs
    n_vars = len(m.variables)
    pairs: list[tuple[z3.ExprRef, z3.ExprRef]] = [
        (frame.mode, _numeral(config[0], "int")),
        (frame.first, _numeral(config[1], "bool")),
    ]
    for k, v in enumerate(m.variables):
        pairs.append((frame.variables[v.name], _numeral(config[2 + k], v.type)))
    for k, p in enumerate(real.prevs):
        value = config[2 + n_vars + prevs[p]]
        if value is not None:
            pairs.append((frame.registers[k], _numeral(value, real.prev_types[k])))
    for c in real.monitors:
        pairs.append((frame.counters[c.name], _numeral(count, "int")))
    return pairs


@cache
def _numeral(value: Value | None, kind: str) -> z3.ExprRef:
    """The z3 numeral of a value (made once: a long run pins the same few values again and again)."""
    if kind == "bool":
        return z3.BoolVal(bool(value))
    return value_of(Fraction(value), kind)  # type: ignore[arg-type]


def _answer(search: Search, goal: Goal) -> Answer:
    if goal.found is not None:
        return Answer(run=search.run_to(goal))
    if search.undecidable:
        return Answer(why=f"the explicit-state search stopped: {search.undecidable}")
    if search.complete:
        return Answer(never=True)
    return Answer(why="not decided within the explicit-state search's budget")


def _reaches(mode: int) -> Test:
    return lambda before, after, fired, nxt: after is not None and after.mode == mode


def _fires(k: int) -> Test:
    return lambda before, after, fired, nxt: fired == k


def _leaves(k: int, low: object, high: object) -> Test:
    return lambda before, after, fired, nxt: after is not None and not (low <= after.variables[k] <= high)  # type: ignore[operator]


def _within(name: str, kind: Type, bounds: Range) -> Expr:
    """`low <= name and name <= high`: the range check of an output, as an invariant."""
    low, high = (Num(x, kind == "real") for x in bounds)
    return BinOp("and", Cmp("<=", low, Var(name)), Cmp("<=", Var(name), high))


def _stuck(before: Env, after: Env | None, fired: int, nxt: Config | None) -> bool:
    return after is None


def _stalls(assume: Eval, goal: Eval) -> Test:
    """A step the machine cannot take (stuck: it keeps its state) under inputs that keep a response's assumption
    where its goal does not hold: the goal never comes."""

    def test(before: Env, after: Env | None, fired: int, nxt: Config | None) -> bool:
        return after is None and bool(assume(before)) and not goal(before)

    return test


def _invariant(c: Compiler, expr: Expr) -> Test:
    return _fails(c.compile(expr))


def _fails(expr: Eval) -> Test:
    return lambda before, after, fired, nxt: after is not None and not expr(after)


class Tracer:
    """Counterexamples of explicit runs built from the explicit engine's own values (the symbolic trace of a
    long run evaluates every definition and output as z3 terms at each step, which costs far more): each
    definition and output that reads nothing of the frame is evaluated once per class in its witness, the
    others by the compiler at each step. None for a machine where some of them cannot be (then the symbolic
    trace is used)."""

    def __init__(self, finite: Finite) -> None:
        self.f = finite
        m, c = finite.m, finite.compiler
        self.ok = True
        atoms, prevs = dict(c.atoms), dict(c.prevs)
        self.per_step: dict[str, Eval] = {}
        self.sampled: dict[tuple[int, str], Eval] = {}  # (class, name): one that reads the frame and a sample
        frame_free = [
            n for n in [*(d.name for d in m.definitions), *(o.name for o in m.outputs)] if not c.reads_frame(Var(n))
        ]
        for name in [*(d.name for d in m.definitions), *(o.name for o in m.outputs)]:
            if name not in frame_free:
                before = dict(c.atoms), dict(c.prevs)
                try:
                    self.per_step[name] = c.compile(Var(name))
                except NotFinite:  # it reads a sample's value: evaluated with each class's witness (`_value`)
                    c.atoms, c.prevs = before
        if c.atoms != atoms or c.prevs != prevs:
            self.ok = False
        c.atoms, c.prevs = atoms, prevs
        system = System(m)
        self._inputs = system.inputs("w")
        at = system.valuation(system.frame("w"), self._inputs)
        self._terms = [system.ev(Var(name), at) for name in frame_free] if self.ok else []
        self.per_class = [self._witness_values(cls, frame_free) for cls in finite.classes] if self.ok else []

    def _witness_values(self, cls: InputClass, names: list[str]) -> dict[str, Number]:
        """The values of the frame-free definitions and outputs, and of the signals, in a class's witness."""
        bools, signals = self._inputs.bools.values(), self._inputs.signals
        pairs = [(b, z3.BoolVal(v)) for b, v in zip(bools, cls.bools, strict=True)]
        pairs += list(zip(signals.values(), cls.signals, strict=True))
        values = {
            name: python_value(z3.simplify(z3.substitute(t, *pairs)))
            for name, t in zip(names, self._terms, strict=True)
        }
        values.update({s: python_value(z3.simplify(v)) for s, v in zip(signals, cls.signals, strict=True)})
        return values

    def counterexample(self, run: Sequence[int], loop_start: int | None) -> Counterexample | None:
        """The counterexample of `run`; None where a value along it is one the engine's arithmetic leaves open
        (a division by zero, which z3's trace shows as some value)."""
        if not self.ok:
            return None
        try:
            return self._counterexample(run, loop_start)
        except Undecidable:
            return None

    def _counterexample(self, run: Sequence[int], loop_start: int | None) -> Counterexample:
        f, m = self.f, self.f.m
        search = f.base
        assert search is not None
        config, steps = search.configs[0], []
        signal_names = [s.name for s in m.signals]
        for c in run:
            cls = f.classes[c]
            taken = search.take(config, cls, total=True)
            assert taken is not None
            before, after, fired, nxt = taken
            assert after is not None and nxt is not None
            known = self.per_class[c]
            t = m.transitions[fired] if fired >= 0 else None
            steps.append(
                Step(
                    m.states[config[0]],  # type: ignore[index]
                    dict(zip(m.input_names, cls.bools, strict=True)),
                    Outcome(t.id if t else None, t.cite if t else None, m.states[nxt[0]]),  # type: ignore[index]
                    signals={s: known[s] for s in signal_names},
                    definitions={d.name: self._value(d.name, c, before) for d in m.definitions},
                    variables={v.name: _number(x) for v, x in zip(m.variables, after.variables, strict=True)},
                    outputs={o.name: self._value(o.name, c, after) for o in m.outputs},
                )
            )
            config = nxt
        params = {p.name: _number(v) for p, v in zip(m.params, param_values(m).values(), strict=True)}
        return Counterexample(tuple(steps), loop_start, params)

    def _value(self, name: str, cls: int, env: Env) -> Number:
        known = self.per_class[cls]
        if name in known:
            return known[name]
        env.cache.clear()
        run = self.per_step.get(name) or self._sampled(cls, name)
        return _number(run(env))

    def _sampled(self, cls: int, name: str) -> Eval:
        """A value that reads the frame and a sample's value, compiled with the samples of the class's witness."""
        if (cls, name) not in self.sampled:
            m = self.f.m
            samples = {s.name: _exact(v) for s, v in zip(m.signals, self.f.classes[cls].signals, strict=True)}
            self.sampled[cls, name] = Sampled(m, param_values(m), samples).compile(Var(name))
        return self.sampled[cls, name]


def _exact(value: z3.ExprRef) -> Value:
    """A witness's sample as an exact number; Undecidable for an irrational one (the symbolic trace shows it)."""
    if isinstance(value, z3.IntNumRef):
        return int(value.as_long())
    if isinstance(value, z3.RatNumRef):
        return Fraction(value.numerator_as_long(), value.denominator_as_long())
    raise Undecidable(f"the sample {value} is not a rational number")


def _number(value: Value | None) -> Number:
    """A value as the symbolic trace shows it (`symbolic.python_value`): a bool, an int, or the nearest float."""
    if isinstance(value, bool | int):
        return value
    assert isinstance(value, Fraction)
    return int(value) if value.denominator == 1 else float(value)
