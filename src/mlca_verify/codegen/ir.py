"""The intermediate form of a machine: every expression already lowered to C and to Python (see `lower`),
per state the branches in priority order, per variable its update on each transition and every step.
The templates print it; they never re-derive semantics from the spec."""

from __future__ import annotations

import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field, replace
from fractions import Fraction
from functools import partial

from mlca_verify.codegen.acsl import AcslLowering, context_free
from mlca_verify.codegen.lower import Lowering, Names, c_type, names_of, output_type, real_literal
from mlca_verify.codegen.once import computed_once, mode_paths
from mlca_verify.codegen.rounded import Part as RoundedPart
from mlca_verify.codegen.rounded import rounded_parts
from mlca_verify.codegen.shapes import Shape, Use, shared_shapes
from mlca_verify.codegen.tidy import known_false, tidy, with_known, without_known
from mlca_verify.codegen.widths import widths
from mlca_verify.floats import FORMATS, Format
from mlca_verify.logic.kept import kept_ranges
from mlca_verify.model import (
    Const,
    Expr,
    Invariant,
    Machine,
    Not,
    Num,
    Transition,
    Type,
    Var,
    Variable,
    nodes,
    observer_variables,
    prevs_of,
    show,
    stateful_definitions,
    stored_registers,
    substitute,
)
from mlca_verify.model import Definition as SpecDefinition
from mlca_verify.model import names_of as read_names


@dataclass(frozen=True)
class Code:
    """One expression in both languages, with the spec's text for comments."""

    c: str
    py: str
    text: str
    acsl: str = ""  # the same value in the contracts' logic (see `acsl`)


@dataclass(frozen=True)
class Field:
    name: str
    ctype: str
    pytype: str
    doc: str
    cite: str
    unit: str = ""
    default: Code | None = None  # a param's default, a variable's initial value
    low: Code | None = None
    high: Code | None = None
    kept: bool = True  # a variable's range: kept by every step from a context in range (`logic.kept`)
    observer: bool = False  # a variable only invariants read: the monitor keeps it (see `MachineIR.observers`)


@dataclass(frozen=True)
class Definition:
    name: str
    ctype: str
    pytype: str
    code: Code
    doc: str
    cite: str
    exact: bool = True  # its logic function has a body: it computes on no real itself (see `binary64`)
    free: bool = False  # its logic function takes no context (see `acsl.context_free`)
    within: str = ""  # an output's declared range, as the header's comment says it: "in [0, 5.0]"


@dataclass(frozen=True)
class SharedShape:
    """One function for definitions that are the same rule over different samples."""

    index: int
    ctype: str
    pytype: str
    args: tuple[tuple[str, str, str], ...]  # name, C type, Python type
    code: Code
    users: tuple[str, ...]
    exact: bool = True


@dataclass(frozen=True)
class Branch:
    number: int  # the transition's position in the spec, from 1: what `fired` holds
    transition: str
    target: str
    guard: Code
    cite: str
    expr: Expr = field(compare=False, repr=False)  # the guard as the code writes it


@dataclass(frozen=True)
class Case:
    """A mode's transitions in priority order. The code writes `code`: the first `written` of them, but for a
    guard that repeats an earlier one of the mode (never taken there: `repeats` names each with the one it
    repeats), is false as written (`never`) or once the earlier guards are false (`decided`). When `closes`, the
    last written is enabled whenever the ones before it are not (its guard negates an earlier one, or is `true`),
    so it is the chain's `else` and nothing after it is reachable. The contracts keep every branch."""

    state: str
    index: int
    branches: tuple[Branch, ...]
    written: int = 0
    closes: bool = False
    repeats: tuple[tuple[Branch, Branch], ...] = ()
    never: tuple[Branch, ...] = ()  # a guard its own text makes false (see `tidy`)
    hoisted: int = 0  # the leading branches the step tests before telling the modes apart (see `MachineIR.hoisted`)
    dropped: tuple[Branch, ...] = ()  # those just before the chain's end that go where it goes (see `_trimmed`)
    once: tuple[str, ...] = ()  # the definitions the step computes once for this mode, read from `d` (see `once`)
    decided: tuple[Branch, ...] = ()  # a guard the earlier ones' being false makes false (see `tidy.with_known`)

    @property
    def code(self) -> tuple[Branch, ...]:
        """What the C step tests, after the hoisted branches."""
        dropped = {id(b) for b in self.dropped}
        return tuple(b for b in self.chain[self.hoisted :] if id(b) not in dropped)

    @property
    def chain(self) -> tuple[Branch, ...]:
        """What a chain that tells every transition apart tests (the Python's, and the C adapter's that reports
        the transition that fired): every branch written but those never taken."""
        left_out = {id(b) for b, _ in self.repeats} | {id(b) for b in (*self.never, *self.decided)}
        return tuple(b for b in self.branches[: self.written] if id(b) not in left_out)

    @property
    def end(self) -> str:
        """The mode the chain ends in when no branch it tests is taken: its own, or the closing branch's target."""
        return self.branches[self.written - 1].target if self.closes else self.state


def closing(guards: Sequence[Expr]) -> int | None:
    """The first guard that holds whenever the guards before it do not: `true`, or the negation of an earlier
    one (either way round). Read from the text alone, so it is never wrong; a guard that only z3 could show
    complete is written as the others are."""
    for k, g in enumerate(guards):
        if g == Const(True) or any(g == Not(e) or e == Not(g) for e in guards[:k]):
            return k
    return None


def _case(
    state: str, index: int, branches: tuple[Branch, ...], guards: Sequence[Expr], hoisted: int, *, keys: Sequence[Expr]
) -> Case:
    """`guards` as the code tests them; `keys` the same before what the earlier guards decide deeper in them was
    decided (see `tidy.with_known`), which tell a guard that repeats an earlier one."""
    last = closing(guards[hoisted:])
    written = len(branches) if last is None else hoisted + last + 1
    first = {g: branches[k] for k, g in reversed(list(enumerate(keys[:written])))}
    repeats = tuple((b, first[g]) for b, g in zip(branches[:written], keys, strict=False) if first[g] is not b)
    repeated = {id(b) for b, _ in repeats}
    false = [(b, k) for b, g, k in zip(branches[:written], guards, keys, strict=False) if g == Const(False)]
    never = tuple(b for b, k in false if k == Const(False) and id(b) not in repeated)
    decided = tuple(b for b, k in false if k != Const(False) and id(b) not in repeated)
    return Case(state, index, branches, written, last is not None, repeats, never, hoisted, decided=decided)


_CALL = re.compile(r"\w\(")  # a function called in C code


def _trimmed(case: Case) -> Case:
    """A direct step's chain without the branches just before its end that go where the end goes (the same
    statement in an `if` and its `else`: cppcheck's duplicateBranch), but for one that calls a function (the C
    of a definition it alone reads would then be defined and never called). The closing branch stays, as the
    `else`; the contracts, the Python and the adapter's report of the transition that fired keep them all."""
    code, end = case.code, case.end
    kept = len(code) - 1 if case.closes else len(code)
    while kept > 0 and code[kept - 1].target == end and not _CALL.search(code[kept - 1].guard.c):
        kept -= 1
    return replace(case, dropped=code[kept : len(code) - 1 if case.closes else None])


Chain = Callable[..., Case]  # a mode's chain: (state, index, hoisted[, once]) -> Case
Modes = tuple[tuple[Case, ...], dict[str, frozenset[str]]]


def _modes(
    m: Machine, chain: Chain, parts: Sequence[RoundedPart], observers: frozenset[str], *, direct: bool, hoisted: int
) -> Modes:
    """Each mode's chain (trimmed in a direct step) and the definitions it computes once."""
    trim = _trimmed if direct else _as_is
    cases = tuple(trim(chain(s, k, hoisted)) for k, s in enumerate(m.states))
    # a hoisted guard runs before the mode is told, so it reads no definition a mode computes once
    once = {} if hoisted else _once_sets(m, cases, parts, observers)
    if any(once.values()):
        cases = tuple(trim(chain(s, k, hoisted, once[s])) for k, s in enumerate(m.states))
    return cases, once


def _step_form(
    m: Machine, direct: bool, types: Mapping[str, Type], modes: Callable[..., Modes]
) -> tuple[bool, int, tuple[Case, ...], dict[str, frozenset[str]]]:
    """Whether the step is direct (`direct` when the spec allows it), how many transitions it hoists, each mode's
    chain and what it computes once. A direct chain that must keep a branch going where its end goes falls back
    to the numbered step, which tells those branches apart."""
    hoisted = _hoisted(m, types) if direct else 0
    cases, once = modes(direct=direct, hoisted=hoisted)
    if direct and any(_ends_twice(case) for case in cases):
        return False, 0, *modes(direct=False, hoisted=0)
    return direct, hoisted, cases, once


def _as_is(case: Case) -> Case:
    return case


def _ends_twice(case: Case) -> bool:
    """Whether a trimmed chain still holds, just before its end, a branch that goes where the end goes (one that
    calls a function, see `_trimmed`): a direct step would write the same statement in an `if` and its `else`."""
    body = case.code[:-1] if case.closes else case.code
    return bool(body) and body[-1].target == case.end


def _by_transition(m: Machine) -> bool:
    """Whether a transition updates a variable to anything but what its `every` rule (or keeping it) gives."""
    rules = {v.name: v.every or Var(v.name) for v in m.variables}
    return any(u.expr != rules[u.variable] for t in m.transitions for u in t.updates)


def _hoisted(m: Machine, types: Mapping[str, Type]) -> int:
    """How many leading transitions leave every mode for the fallback mode on a condition that is not constant,
    none repeating or completing the ones before it, nor holding a part they decide (a direct step whose context
    is its mode alone tests them before the modes, as each mode's chain writes them; see `MachineIR`)."""
    if any(v.name not in observer_variables(m) for v in m.variables):
        return 0  # a context that keeps a variable restarts from a mode that names no state, whatever they say
    guards = [tidy(t.guard, types) for t in m.transitions]
    count = 0
    for t, g, (_, written) in zip(m.transitions, guards, chain_guards(m.transitions, types), strict=True):
        leading = t.sources is None and t.target == m.fallback_state and not isinstance(g, Const)
        if not leading or written != g or g in guards[:count] or closing(guards[: count + 1]) == count:
            break
        count += 1
    return count


def chain_guards(transitions: Sequence[Transition], types: Mapping[str, Type]) -> list[tuple[Expr, Expr]]:
    """Each guard of a chain of `transitions` as the code writes it, where the earlier ones are false: its key,
    without the conjuncts they make true, and the guard, with the parts they decide deeper in it decided too
    (see `tidy.with_known`)."""
    known: list[Expr] = []
    written = []
    for t in transitions:
        key = tidy(without_known(t.guard, known), types)
        written.append((key, tidy(with_known(key, known, types), types)))
        known += known_false(t.guard) + known_false(tidy(t.guard, types))
    return written


@dataclass(frozen=True)
class OnceGroup:
    """Modes whose steps compute the same definitions once, before their transitions are tested (see `once`)."""

    states: tuple[str, ...]
    names: tuple[str, ...]
    every: bool  # the group holds every mode: the step computes them whatever the mode


@dataclass(frozen=True)
class Update:
    variable: str
    ctype: str
    on: tuple[tuple[int, Code], ...]  # (transition number, value) where a transition assigns it
    every: Code | None


@dataclass(frozen=True)
class Register:
    """What prev(e) reads: e over a context, kept after each step."""

    index: int
    ctype: str
    pytype: str
    code: Code
    stored: bool = True  # kept in the context; else the monitor computes it from the context before the step


@dataclass(frozen=True)
class Rounded:
    """A part of a guard, update, output or register that computes on reals, in a C function of its own (see
    `rounded`): `code.c` is its body, over the same view as a definition's."""

    index: int
    ctype: str
    code: Code
    free: bool
    users: tuple[str, ...]


@dataclass(frozen=True)
class Property:
    index: int
    id: str
    code: Code
    cite: str
    fails_py: str  # where it fails, in Python: `not e`, or `a` for `not a` (no `not (not a)`)


@dataclass(frozen=True)
class MachineIR:
    name: str
    module: str
    macro: str
    doc: str
    cite: str
    spec_path: str
    spec_sha256: str
    generator: str
    initial: str
    fallback: str  # the mode a context whose mode names no state restarts in
    states: tuple[str, ...]
    inputs: tuple[Field, ...]
    signals: tuple[Field, ...]
    params: tuple[Field, ...]
    variables: tuple[Field, ...]  # those the context keeps: every variable but the observers
    definitions: tuple[Definition, ...]
    outputs: tuple[Definition, ...]
    cases: tuple[Case, ...]
    updates: tuple[Update, ...]
    registers: tuple[Register, ...]
    invariants: tuple[Property, ...]
    transitions: tuple[tuple[int, str, str], ...] = field(default_factory=tuple)  # number, id, target
    helpers: frozenset[str] = frozenset()  # the C helpers the code calls: min_d, max_i, div, ...
    shapes: tuple[SharedShape, ...] = ()
    used: frozenset[str] = frozenset()  # the definitions whose functions the code calls
    logic: frozenset[str] = frozenset()  # those the contracts read too (a branch the code leaves out included)
    logic_shapes: tuple[SharedShape, ...] = ()  # the shared rules of `logic`
    guards: tuple[Code, ...] = ()  # of each transition, by its number from 1
    rounded: tuple[Rounded, ...] = ()  # the parts that compute on reals, each a function (see `rounded`)
    # transitions that change the mode alone (no variable updated by a transition, only by `every`; no register
    # kept): each mode's chain yields the next mode itself, with no number of the transition to look up updates
    # by, the `every` updates are made whatever fires, and the step never reads a first-step flag
    direct: bool = False
    # how many leading `from = "*"` transitions to the fallback mode a direct step whose context is its mode alone
    # tests once, before telling the modes apart: a context whose mode is not a state restarts in the fallback mode
    # too, so the order is free (a variable would be reset by the restart and not by the transition)
    hoisted: int = 0
    ints: str = "int64_t"  # the type every int expression computes in (see `widths`)
    reals: str = "binary64"  # the format every real computes in (see `floats`), and its C type:
    real: str = "double"
    int_to_single: bool = False  # whether the Python converts an int to binary32 (`_f32_int`)
    once: tuple[OnceGroup, ...] = ()  # the definitions each mode's step computes once (see `once`)
    observers: tuple[Field, ...] = ()  # the variables only invariants read, kept by the monitor (`<name>_observers_t`)
    every_variable: tuple[Field, ...] = ()  # the context's and the observers', in the spec's order
    observer_updates: tuple[Update, ...] = ()  # their updates, which the monitor makes

    @property
    def observed_by_transition(self) -> bool:
        """Whether a transition updates an observer (the monitor then needs the transition that fired)."""
        return any(u.on for u in self.observer_updates)

    @property
    def has_reals(self) -> bool:
        """Whether the code holds a real anywhere: a signal, a param, a variable, an observer or an output."""
        fields = (*self.signals, *self.params, *self.variables, *self.observers)
        return any(f.ctype == self.real for f in fields) or any(o.ctype == self.real for o in self.outputs)

    @property
    def once_fields(self) -> tuple[Definition, ...]:
        """The definitions the step computes once in some mode, in the spec's order: the fields of `d`."""
        wanted = {n for g in self.once for n in g.names}
        return tuple(d for d in self.definitions if d.name in wanted)

    @property
    def kept(self) -> tuple[Register, ...]:
        """The registers the context keeps between steps (see `model.stored_registers`)."""
        return tuple(r for r in self.registers if r.stored)

    @property
    def context_words(self) -> str:
        """What the context holds, in words for the code's comments."""
        parts = [
            "the mode",
            *(["the variables"] if self.variables else []),
            *(["what prev() in a property reads"] if self.kept else []),
        ]
        return parts[0] if len(parts) == 1 else f"{', '.join(parts[:-1])} and {parts[-1]}"

    @property
    def first_flag(self) -> bool:
        """Whether the context keeps a first-step flag: only a kept register (what prev() reads) needs one."""
        return bool(self.kept)


GENERATOR_NAME = "mlca-verify"
PY_TYPES = {"bool": "bool", "int": "int", "real": "float"}


def _literal(v: Fraction, kind: Type, fmt: Format) -> Code:
    """A constant of the spec (a default, a range end) as both languages write it."""
    if kind != "real":
        return Code(str(int(v)), str(int(v)), str(v), str(int(v)))
    return Code(real_literal(v, fmt, "c"), real_literal(v, fmt, "py"), str(v), AcslLowering.real(v, fmt))


def build_ir(m: Machine, module: str, spec_path: str, sha: str, generator: str) -> MachineIR:
    macro = module.upper()
    ints, bounds = widths(m)  # the ints' type, and each int output's bounds: declared, or what the ranges give
    prevs = {p: k for k, p in enumerate(prevs_of(*(inv.expr for inv in m.invariants)))}
    # a register of an output keeps what the output computes
    register_args = [substitute(p.arg, {o.name: o.expr for o in m.outputs}) for p in prevs]
    stateful = stateful_definitions(m.definitions, (v.name for v in m.variables))
    parts, at = rounded_parts(m, names_of(m, module, macro).types, stateful, register_args)
    observers = observer_variables(m)  # kept by the monitor, not the context
    names = replace(names_of(m, module, macro, observers), ints=ints)
    c, py = Lowering(names, "c"), Lowering(names, "py")
    logic = AcslLowering(names, context_free(m))
    part_calls = {n: f"{module}_b64_{k}(c, i, p)" for n, k in at.items()}
    stated_cs: dict[frozenset[str], Lowering] = {}
    stated_l = AcslLowering(
        names, logic.free, {n: f"{module}_lb64_{k}({'i, p' if parts[k].free else 'c, i, p'})" for n, k in at.items()}
    )
    c_prev = {p: f"prev{k}" for p, k in prevs.items()}

    def code(e: Expr, with_prev: bool = False) -> Code:
        prev = c_prev if with_prev else None
        return Code(c.go(e, prev), py.go(e, prev), show(e), "" if with_prev else logic.go(e))

    def stated(e: Expr, kind: Type, once: frozenset[str] = frozenset()) -> Code:
        """What the step's contract states: the parts that compute on reals read through their functions, and in
        C the definitions in `once` from the fields the step computed them into."""
        stated_c = stated_cs.setdefault(once, Lowering(names, "c", part_calls, once))
        if id(e) in at and parts[at[id(e)]].kind == kind:  # the whole value, converted inside the function
            return Code(stated_c.go(e), py.as_type(e, kind, None), show(e), stated_l.go(e))
        return Code(
            stated_c.as_type(e, kind, None), py.as_type(e, kind, None), show(e), stated_l.as_type(e, kind, None)
        )

    shapes, uses = shared_shapes(m)
    keeps = kept_ranges(m)
    numbers = {t.id: k for k, t in enumerate(m.transitions, 1)}

    def chain(state: str, index: int, hoisted: int, once: frozenset[str] = frozenset()) -> Case:
        """The mode's branches, each guard written without what the earlier guards' being false decides."""
        outgoing = m.outgoing(state)
        written = chain_guards(outgoing, names.types)
        branches = tuple(
            Branch(numbers[t.id], t.id, t.target, replace(stated(g, "bool", once), text=show(t.guard)), t.cite, g)
            for t, (_, g) in zip(outgoing, written, strict=True)
        )
        keys, guards = [k for k, _ in written], [g for _, g in written]
        return replace(_case(state, index, branches, guards, hoisted, keys=keys),
                       once=tuple(d.name for d in m.definitions if d.name in once))  # fmt: skip

    stored = stored_registers(m, tuple(prevs))
    modes = partial(_modes, m, chain, parts, observers)
    direct, hoisted, cases, once = _step_form(m, not stored and not _by_transition(m), names.types, modes)
    updates = tuple(
        _update(v, m, numbers, stated, _nothing if v.name in observers else partial(_common, once), types=names.types)
        for v in m.variables
    )  # the monitor's update of an observer reads no definition computed once (the step's alone)
    fields = tuple(
        _number_field(v, v.type, v.range, names.fmt, default=_literal(v.initial, v.type, names.fmt),
                      kept=v.name in keeps or v.type != "int", observer=v.name in observers)
        for v in m.variables
    )  # fmt: skip
    ir = MachineIR(
        name=m.name,
        module=module,
        macro=macro,
        doc=m.doc,
        cite=m.cite,
        spec_path=spec_path,
        spec_sha256=sha,
        generator=generator,
        ints=names.ints,
        reals=m.reals,
        real=names.real,
        initial=m.initial,
        fallback=m.fallback_state,
        states=m.states,
        inputs=tuple(Field(i.name, "bool", "bool", i.doc, i.cite) for i in m.inputs),
        signals=tuple(_number_field(s, s.type, s.range, names.fmt) for s in m.signals),
        params=tuple(
            _number_field(p, p.type, p.range, names.fmt, default=_literal(p.default, p.type, names.fmt))
            for p in m.params
        ),
        variables=tuple(f for f in fields if not f.observer),
        observers=tuple(f for f in fields if f.observer),
        every_variable=fields,
        definitions=tuple(_definition(d, c, py, logic, uses.get(d.name)) for d in m.definitions),
        shapes=tuple(_shape(sh, names, uses) for sh in shapes),
        outputs=tuple(
            Definition(
                o.name,
                output_type(o.type, bounds.get(o.name), names.real),
                PY_TYPES[o.type],
                stated(o.expr, o.type),
                o.doc,
                o.cite,
                within=_within(o.range, o.type, names.fmt),
            )
            for o in m.outputs
        ),
        cases=cases,
        hoisted=hoisted,
        direct=direct,
        updates=tuple(u for u in updates if u.variable not in observers),
        observer_updates=tuple(u for u in updates if u.variable in observers),
        registers=tuple(_register(k, arg, c, stated, k in stored) for k, arg in enumerate(register_args)),
        invariants=tuple(_property(k, inv, code) for k, inv in enumerate(m.invariants)),
        transitions=tuple((numbers[t.id], t.id, t.target) for t in m.transitions),
        guards=tuple(stated(t.guard, "bool") for t in m.transitions),
        rounded=tuple(_rounded(p, c) for p in parts),
        once=_once_groups(m.states, once, [d.name for d in m.definitions]),
    )
    written = tuple(
        replace(case, branches=(*case.branches[: case.hoisted], *case.code), written=case.hoisted + len(case.code),
                repeats=(), never=(), decided=(), dropped=())
        for case in ir.cases
    )  # fmt: skip
    in_code = replace(ir, guards=(), cases=written)  # what the code holds, not the contracts
    computed_values = [*register_args, *(part.expr for part in parts)]
    used, contracts = _definition_reads(m, written, cases, computed_values, types=names.types, shared=uses)
    code_shapes = tuple(sh for sh in ir.shapes if set(sh.users) & used)
    text = repr(replace(in_code, definitions=tuple(d for d in ir.definitions if d.name in used), shapes=code_shapes))
    helpers = frozenset(h for h in HELPERS if f"{module}_{h}(" in text)
    return replace(
        ir,
        helpers=helpers,
        int_to_single="_f32_int(" in text,
        used=used,
        logic=contracts,
        shapes=code_shapes,
        logic_shapes=tuple(sh for sh in ir.shapes if set(sh.users) & contracts),
    )


def _number_field(
    item: object, kind: Type, bounds: tuple[Fraction, Fraction] | None, fmt: Format, **extra: object
) -> Field:
    """A signal, param or variable as a field of the code."""
    low, high = (_literal(bounds[0], kind, fmt), _literal(bounds[1], kind, fmt)) if bounds is not None else (None, None)
    return Field(
        item.name,  # type: ignore[attr-defined]
        c_type(kind, bounds, real=fmt.ctype),
        PY_TYPES[kind],
        item.doc,  # type: ignore[attr-defined]
        item.cite,  # type: ignore[attr-defined]
        low=low,
        high=high,
        **extra,  # type: ignore[arg-type]
    )


def _property(index: int, inv: Invariant, code: Callable[[Expr, bool], Code]) -> Property:
    holds = code(inv.expr, True)
    fails = code(inv.expr.arg, True).py if isinstance(inv.expr, Not) else f"not {holds.py}"
    return Property(index, inv.id, holds, inv.cite, fails)


def _update(
    v: Variable,
    m: Machine,
    numbers: Mapping[str, int],
    stated: Callable[[Expr, Type, frozenset[str]], Code],
    once: Callable[[Sequence[str]], frozenset[str]],
    *,
    types: Mapping[str, Type],
) -> Update:
    """The variable's update by each transition and every step, reading the definitions `once` gives (for the
    modes the update runs in) from the fields the step computed them into. An update the code writes as it
    writes the `every` rule (or keeping the value) is left to the chain's `else` (cppcheck's duplicateBranch)."""
    anyway = tidy(v.every or Var(v.name), types)
    return Update(
        v.name,
        c_type(v.type, v.range, real=FORMATS[m.reals].ctype),
        tuple(
            (numbers[t.id], stated(u.expr, v.type, once(t.sources or m.states)))
            for t in m.transitions
            for u in t.updates
            if u.variable == v.name and tidy(u.expr, types) != anyway  # else: what the step does anyway
        ),
        stated(v.every, v.type, once(m.states)) if v.every is not None else None,
    )


def _nothing(sources: Sequence[str]) -> frozenset[str]:
    """No definition computed once: for the monitor's updates of the observers."""
    return frozenset()


def _common(once: Mapping[str, frozenset[str]], sources: Sequence[str]) -> frozenset[str]:
    """What every mode an update runs in (`sources`) computes once."""
    return frozenset.intersection(*(once[s] for s in sources)) if once else frozenset()


def _once_sets(
    m: Machine, cases: Sequence[Case], parts: Sequence[RoundedPart], observers: frozenset[str]
) -> dict[str, frozenset[str]]:
    """Each mode's definitions the step computes once (see `once`): the guards its chain evaluates (a closing
    branch is the chain's `else`, its guard never evaluated) and the updates of the variables it keeps (not the
    observers', which the monitor makes)."""
    rules = {d.name: d.expr for d in m.definitions}
    in_parts = frozenset(n.name for p in parts for n in nodes(p.expr) if isinstance(n, Var) and n.name in rules)
    guards = {case.state: [b.expr for b in (case.code[:-1] if case.closes else case.code)] for case in cases}
    kept = replace(m, variables=tuple(v for v in m.variables if v.name not in observers),
                   transitions=tuple(replace(t, updates=tuple(u for u in t.updates if u.variable not in observers))
                                     for t in m.transitions))  # fmt: skip
    return {path.state: computed_once(path, rules, in_parts) for path in mode_paths(kept, guards)}


def _once_groups(
    states: Sequence[str], once: Mapping[str, frozenset[str]], order: Sequence[str]
) -> tuple[OnceGroup, ...]:
    """The modes that compute the same definitions once, grouped, in the order of the states (the names in the
    spec's order). Those every mode computes come first, as one group computed whatever the mode: an `every`
    update reads them, and a direct step makes it before it knows whether the mode is a state."""
    common = frozenset.intersection(*(once.get(s, frozenset()) for s in states)) if states else frozenset()
    rest = {s: once.get(s, frozenset()) - common for s in states}
    sets = sorted({rest[s] for s in states if rest[s]}, key=lambda names: min(
        states.index(s) for s in states if rest[s] == names))  # fmt: skip
    first = (OnceGroup(tuple(states), tuple(n for n in order if n in common), True),) if common else ()
    return first + tuple(
        OnceGroup(tuple(s for s in states if rest[s] == names), tuple(n for n in order if n in names), False)
        for names in sets
    )


def _definition_reads(
    m: Machine,
    written: Sequence[Case],
    cases: Sequence[Case],
    computed: Sequence[Expr],
    *,
    types: Mapping[str, Type],
    shared: Mapping[str, Use],
) -> tuple[frozenset[str], frozenset[str]]:
    """The definitions the code calls (its branches as `written`, every update, output, register, invariant and
    real part, the `computed` registers and parts among them), and those the contracts read (every branch of
    `cases`, and every transition's guard as the spec writes it)."""
    values = [
        *(u.expr for t in m.transitions for u in t.updates),
        *(v.every for v in m.variables if v.every is not None),
        *(o.expr for o in m.outputs),
        *(inv.expr for inv in m.invariants),
        *computed,
    ]
    in_step = [b.expr for case in written for b in case.branches]
    stated = [*(b.expr for case in cases for b in case.branches), *(t.guard for t in m.transitions)]
    return (
        _read_definitions(m, types, [*in_step, *values], shared),
        _read_definitions(m, types, [*stated, *values], shared),
    )


def _read_definitions(
    m: Machine, types: Mapping[str, Type], exprs: Sequence[Expr], shared: Mapping[str, Use]
) -> frozenset[str]:
    """The definitions `exprs` read as the code writes them (what their own text decides taken out, see `tidy`),
    and those their rules read: the ones whose functions the code calls. A definition that is one of a shared
    rule's users is computed by the rule's function from samples alone."""
    rules = {d.name: d.expr for d in m.definitions}
    found: set[str] = set()
    todo = [name for e in exprs for name in read_names(tidy(e, types)) if name in rules]
    while todo:
        name = todo.pop()
        if name not in found:
            found.add(name)
            if name not in shared:
                todo += [n for n in read_names(tidy(rules[name], types)) if n in rules]
    return frozenset(found)


def _within(bounds: tuple[Fraction, Fraction] | None, kind: Type, fmt: Format) -> str:
    if bounds is None:
        return ""
    low, high = (_literal(x, kind, fmt).c for x in bounds)
    return f"in [{low}, {high}]"


def _rounded(part: RoundedPart, c: Lowering) -> Rounded:
    code = Code(c.as_type(part.expr, part.kind, None), "", show(part.expr))
    return Rounded(part.index, c_type(part.kind, None, c.n.ints, c.n.real), code, part.free, part.users)


def _register(index: int, arg: Expr, c: Lowering, stated: Callable[[Expr, Type], Code], stored: bool) -> Register:
    kind = c.type_of(arg)
    return Register(index, c_type(kind, None, c.n.ints, c.n.real), PY_TYPES[kind], stated(arg, kind), stored)


HELPERS = ("min_d", "max_d", "abs_d", "min_i", "max_i", "abs_i", "div")


def _gated(body: Code, valid: Code, if_invalid: bool) -> Code:
    """A boolean that reads samples: its `if_invalid` value unless every one is valid (tested first)."""
    c, py, acsl = ("true", "True", "\\true") if if_invalid else ("false", "False", "\\false")
    return Code(
        f"(({valid.c}) ? {body.c} : {c})",
        f"({body.py} if ({valid.py}) else {py})",
        body.text,
        f"(({valid.acsl}) ? {body.acsl} : {acsl})",
    )


def _validity(signals: Sequence[str], c: Lowering, py: Lowering, logic: Lowering) -> Code:
    return Code(
        " && ".join(c.valid(s) for s in signals),
        " and ".join(py.valid(s) for s in signals),
        "",
        " && ".join(logic.valid(s) for s in signals),
    )


def _definition(d: SpecDefinition, c: Lowering, py: Lowering, logic: AcslLowering, use: Use | None) -> Definition:
    if use is not None:
        args_c, args_py, args_l = (", ".join(f"{v}{s}" for s in use.signals) for v in ("i->", "i.", "i."))
        call = Code(
            f"{c.n.prefix}_shape{use.shape}({args_c}, p)",
            f"_shape{use.shape}({args_py}, p)",
            show(d.expr),
            f"{c.n.prefix}_lshape{use.shape}({args_l}, p)",
        )
        kind = c_type(d.type, None, c.n.ints, c.n.real)
        return Definition(d.name, kind, PY_TYPES[d.type], call, d.doc, d.cite, free=d.name in logic.free)
    exact = not binary64(d.expr, c.n.types)
    body = Code(
        c.as_type(d.expr, d.type, None),
        py.as_type(d.expr, d.type, None),
        show(d.expr),
        logic.as_type(d.expr, d.type, None),
    )
    if d.type == "bool" and d.signals:
        body = _gated(body, _validity(d.signals, c, py, logic), d.if_invalid)
    kind = c_type(d.type, None, c.n.ints, c.n.real)
    return Definition(d.name, kind, PY_TYPES[d.type], body, d.doc, d.cite, exact, d.name in logic.free)


def binary64(e: Expr, types: Mapping[str, Type]) -> bool:
    """Whether `e` itself computes on reals. Its logic function is then left without a body: z3, through Why3,
    decides binary64 by bit-blasting and runs out of memory on any goal that has such a body among its
    hypotheses (measured on MLCA-T's gap rules), so the C function's link to it is left to the exhaustive and
    sequence comparisons, which check that C bit for bit against z3's own semantics of the spec."""
    return any(
        (isinstance(x, Num) and (x.real or x.value.denominator != 1))
        or (isinstance(x, Var) and types.get(x.name) == "real")
        for x in nodes(e)
    )


def _shape(sh: Shape, names: Names, uses: dict[str, Use]) -> SharedShape:
    kinds = {**names.kinds, **{a: "arg" for a, _, _ in sh.args}}
    types = {**names.types, **{a: kind for a, kind, _ in sh.args}}
    ranges = {**names.ranges, **{a: bounds for a, _, bounds in sh.args}}
    view = replace(names, kinds=kinds, types=types, ranges=ranges)
    c, py = Lowering(view, "c"), Lowering(view, "py")
    logic = AcslLowering(view)
    code = Code(
        c.as_type(sh.expr, sh.kind, None),
        py.as_type(sh.expr, sh.kind, None),
        show(sh.expr),
        logic.as_type(sh.expr, sh.kind, None),
    )
    if sh.guarded:
        code = _gated(code, _validity([a for a, _, _ in sh.args], c, py, logic), sh.if_invalid)
    args = tuple((a, c_type(kind, bounds, real=names.real), PY_TYPES[kind]) for a, kind, bounds in sh.args)
    users = tuple(sorted(name for name, use in uses.items() if use.shape == sh.index))
    exact = not binary64(sh.expr, types)
    kind = c_type(sh.kind, None, names.ints, names.real)
    return SharedShape(sh.index, kind, PY_TYPES[sh.kind], args, code, users, exact)
