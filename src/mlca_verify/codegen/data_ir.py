"""The intermediate form of a machine with data: every expression already lowered to C and to Python (see
`lower`), per state the branches in priority order, per variable its update on each transition and every step.
The templates print it; they never re-derive semantics from the spec."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from fractions import Fraction

from mlca_verify.codegen.lower import Lowering, Names, c_type, names_of, real_literal
from mlca_verify.codegen.shapes import Shape, Use, shared_shapes
from mlca_verify.errors import CodegenError
from mlca_verify.model import Definition as SpecDefinition
from mlca_verify.model import Expr, Machine, Type, Var, nodes, prevs_of, show


@dataclass(frozen=True)
class Code:
    """One expression in both languages, with the spec's text for comments."""

    c: str
    py: str
    text: str


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


@dataclass(frozen=True)
class Definition:
    name: str
    ctype: str
    pytype: str
    code: Code
    doc: str
    cite: str


@dataclass(frozen=True)
class SharedShape:
    """One function for definitions that are the same rule over different samples."""

    index: int
    ctype: str
    pytype: str
    args: tuple[tuple[str, str, str], ...]  # name, C type, Python type
    code: Code
    users: tuple[str, ...]


@dataclass(frozen=True)
class Branch:
    number: int  # the transition's position in the spec, from 1: what `fired` holds
    transition: str
    target: str
    guard: Code
    cite: str


@dataclass(frozen=True)
class Case:
    state: str
    index: int
    branches: tuple[Branch, ...]


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


@dataclass(frozen=True)
class Property:
    index: int
    id: str
    code: Code
    cite: str


@dataclass(frozen=True)
class DataIR:
    name: str
    module: str
    macro: str
    doc: str
    cite: str
    spec_path: str
    spec_sha256: str
    generator: str
    initial: str
    states: tuple[str, ...]
    inputs: tuple[Field, ...]
    signals: tuple[Field, ...]
    params: tuple[Field, ...]
    variables: tuple[Field, ...]
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


PY_TYPES = {"bool": "bool", "int": "int", "real": "float"}


def _literal(v: Fraction, kind: Type) -> Code:
    """A constant of the spec (a default, a range end) as both languages write it."""
    text = real_literal(v) if kind == "real" else str(int(v))
    return Code(text, text, str(v))


def build_data_ir(m: Machine, module: str, spec_path: str, sha: str, generator: str) -> DataIR:
    macro = module.upper()
    names = names_of(m, module, macro)
    c, py = Lowering(names, "c"), Lowering(names, "py")
    for inv in m.invariants:
        if any(
            isinstance(x, Var) and names.kinds[x.name] == "output" for p in prevs_of(inv.expr) for x in nodes(p.arg)
        ):
            raise CodegenError(f"{inv.loc}: error: prev() of an output is not generated yet")
    prevs = {p: k for k, p in enumerate(prevs_of(*(inv.expr for inv in m.invariants)))}
    c_prev = {p: f"prev{k}" for p, k in prevs.items()}

    def code(e: Expr, with_prev: bool = False) -> Code:
        return Code(c.go(e, c_prev if with_prev else None), py.go(e, c_prev if with_prev else None), show(e))

    def typed(e: Expr, kind: Type) -> Code:
        return Code(c.as_type(e, kind, None), py.as_type(e, kind, None), show(e))

    def number_field(item: object, kind: Type, bounds: tuple[Fraction, Fraction] | None, **extra: object) -> Field:
        low, high = (_literal(bounds[0], kind), _literal(bounds[1], kind)) if bounds is not None else (None, None)
        return Field(
            item.name,  # type: ignore[attr-defined]
            c_type(kind, bounds),
            PY_TYPES[kind],
            item.doc,  # type: ignore[attr-defined]
            item.cite,  # type: ignore[attr-defined]
            low=low,
            high=high,
            **extra,  # type: ignore[arg-type]
        )

    shapes, uses = shared_shapes(m)
    numbers = {t.id: k for k, t in enumerate(m.transitions, 1)}
    cases = tuple(
        Case(
            s,
            k,
            tuple(
                Branch(numbers[t.id], t.id, t.target, code(t.guard), t.cite) for t in m.transitions if t.applies_to(s)
            ),
        )
        for k, s in enumerate(m.states)
    )
    updates = tuple(
        Update(
            v.name,
            c_type(v.type, v.range),
            tuple(
                (numbers[t.id], typed(u.expr, v.type)) for t in m.transitions for u in t.updates if u.variable == v.name
            ),
            typed(v.every, v.type) if v.every is not None else None,
        )
        for v in m.variables
    )
    ir = DataIR(
        name=m.name,
        module=module,
        macro=macro,
        doc=m.doc,
        cite=m.cite,
        spec_path=spec_path,
        spec_sha256=sha,
        generator=generator,
        initial=m.initial,
        states=m.states,
        inputs=tuple(Field(i.name, "bool", "bool", i.doc, i.cite) for i in m.inputs),
        signals=tuple(number_field(s, s.type, s.range) for s in m.signals),
        params=tuple(number_field(p, p.type, p.range, default=_literal(p.default, p.type)) for p in m.params),
        variables=tuple(number_field(v, v.type, v.range, default=_literal(v.initial, v.type)) for v in m.variables),
        definitions=tuple(_definition(d, c, py, uses.get(d.name)) for d in m.definitions),
        shapes=tuple(_shape(sh, names, uses) for sh in shapes),
        outputs=tuple(
            Definition(o.name, c_type(o.type), PY_TYPES[o.type], typed(o.expr, o.type), o.doc, o.cite)
            for o in m.outputs
        ),
        cases=cases,
        updates=updates,
        registers=tuple(
            Register(k, c_type(c.type_of(p.arg)), PY_TYPES[c.type_of(p.arg)], code(p.arg)) for p, k in prevs.items()
        ),
        invariants=tuple(Property(k, inv.id, code(inv.expr, True), inv.cite) for k, inv in enumerate(m.invariants)),
        transitions=tuple((numbers[t.id], t.id, t.target) for t in m.transitions),
    )
    text = repr(replace(ir, definitions=()))
    used: set[str] = set()
    todo = [d.name for d in ir.definitions if f"{module}_def_{d.name}(" in text]
    while todo:  # a called definition's body may call others
        name = todo.pop()
        if name not in used:
            used.add(name)
            body = next(d.code.c for d in ir.definitions if d.name == name)
            todo += [d.name for d in ir.definitions if f"{module}_def_{d.name}(" in body]
    helpers = frozenset(h for h in HELPERS if f"{module}_{h}(" in repr(ir))
    kept = tuple(sh for sh in ir.shapes if set(sh.users) & used)
    return replace(ir, helpers=helpers, used=frozenset(used), shapes=kept)


HELPERS = ("min_d", "max_d", "abs_d", "min_i", "max_i", "abs_i", "div")


def _gated(body_c: str, body_py: str, valid: tuple[list[str], list[str]], if_invalid: bool) -> tuple[str, str]:
    """A boolean that reads samples: its `if_invalid` value unless every one is valid (tested first)."""
    fallback_c, fallback_py = ("true", "True") if if_invalid else ("false", "False")
    valid_c, valid_py = " && ".join(valid[0]), " and ".join(valid[1])
    return f"(({valid_c}) ? {body_c} : {fallback_c})", f"({body_py} if ({valid_py}) else {fallback_py})"


def _definition(d: SpecDefinition, c: Lowering, py: Lowering, use: Use | None) -> Definition:
    if use is not None:
        call_c = f"{c.n.prefix}_shape{use.shape}(" + ", ".join(f"i->{s}" for s in use.signals) + ", p)"
        call_py = f"_shape{use.shape}(" + ", ".join(f"i.{s}" for s in use.signals) + ", p)"
        return Definition(d.name, c_type(d.type), PY_TYPES[d.type], Code(call_c, call_py, show(d.expr)), d.doc, d.cite)
    body_c, body_py = c.as_type(d.expr, d.type, None), py.as_type(d.expr, d.type, None)
    if d.type == "bool" and d.signals:
        valid = ([c.valid(s) for s in d.signals], [py.valid(s) for s in d.signals])
        body_c, body_py = _gated(body_c, body_py, valid, d.if_invalid)
    return Definition(d.name, c_type(d.type), PY_TYPES[d.type], Code(body_c, body_py, show(d.expr)), d.doc, d.cite)


def _shape(sh: Shape, names: Names, uses: dict[str, Use]) -> SharedShape:
    kinds = {**names.kinds, **{a: "arg" for a, _, _ in sh.args}}
    types = {**names.types, **{a: kind for a, kind, _ in sh.args}}
    ranges = {**names.ranges, **{a: bounds for a, _, bounds in sh.args}}
    view = replace(names, kinds=kinds, types=types, ranges=ranges)
    c, py = Lowering(view, "c"), Lowering(view, "py")
    body_c, body_py = c.as_type(sh.expr, sh.kind, None), py.as_type(sh.expr, sh.kind, None)
    if sh.guarded:
        valid = ([c.valid(a) for a, _, _ in sh.args], [py.valid(a) for a, _, _ in sh.args])
        body_c, body_py = _gated(body_c, body_py, valid, sh.if_invalid)
    args = tuple((a, c_type(kind, bounds), PY_TYPES[kind]) for a, kind, bounds in sh.args)
    users = tuple(sorted(name for name, use in uses.items() if use.shape == sh.index))
    code = Code(body_c, body_py, show(sh.expr))
    return SharedShape(sh.index, c_type(sh.kind), PY_TYPES[sh.kind], args, code, users)
