"""The machine model: frozen dataclasses, no I/O, no solver, no file format.

A `Machine` is what every consumer (the z3 engine, the code generators, the simulator) reads.
Expressions are a small AST over names (boolean inputs, and in a machine with data also params, signals,
variables, definitions and outputs) and the machine's state.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Literal, TypeAlias

from mlca_verify.errors import Loc
from mlca_verify.floats import Reals

Semantics = Literal["first-match", "any-enabled"]
Otherwise = Literal["stay", "undefined"]
Verdict = Literal["holds", "violated", "unknown"]
ANY_STATE = "*"
OTHERWISE_ID = "otherwise"
IN_MEMORY = Loc("<memory>", 1, 1)


# --- expressions -------------------------------------------------------------------------------


@dataclass(frozen=True)
class Const:
    value: bool


@dataclass(frozen=True)
class Var:
    """A name: a boolean input (the only kind in a machine without data), or a param, signal, variable,
    definition or output."""

    name: str


@dataclass(frozen=True)
class Num:
    """A numeric literal, exact; `real` when written with a point or an exponent."""

    value: Fraction
    real: bool


@dataclass(frozen=True)
class Arith:
    op: Literal["+", "-", "*", "/"]
    left: Expr
    right: Expr


@dataclass(frozen=True)
class Neg:
    arg: Expr


@dataclass(frozen=True)
class Cmp:
    op: Literal["<", "<=", ">", ">=", "==", "!="]
    left: Expr
    right: Expr


@dataclass(frozen=True)
class Call:
    """`min(a, b, ...)`, `max(a, b, ...)`, `abs(a)`, or `valid(signal)` (the sample lies in the signal's range)."""

    fn: Literal["min", "max", "abs", "valid"]
    args: tuple[Expr, ...]


@dataclass(frozen=True)
class Ite:
    cond: Expr
    then: Expr
    other: Expr


@dataclass(frozen=True)
class Prev:
    """The value of `arg` at the previous step (at the first step: over the initial state and variables)."""

    arg: Expr


@dataclass(frozen=True)
class StateIn:
    """`state == X` (one name), `state in {X, Y}` or, negated, `state != X`."""

    states: tuple[str, ...]


@dataclass(frozen=True)
class Not:
    arg: Expr


@dataclass(frozen=True)
class BinOp:
    """`and`, `or`, `->` (implies), `<->` (iff)."""

    op: Literal["and", "or", "->", "<->"]
    left: Expr
    right: Expr


Expr: TypeAlias = Const | Var | StateIn | Not | BinOp | Num | Arith | Neg | Cmp | Call | Ite | Prev
BOOLEAN_NODES = (Const, Var, StateIn, Not, BinOp)


def children(expr: Expr) -> tuple[Expr, ...]:
    if isinstance(expr, Not | Neg | Prev):
        return (expr.arg,)
    if isinstance(expr, BinOp | Arith | Cmp):
        return (expr.left, expr.right)
    if isinstance(expr, Call):
        return expr.args
    if isinstance(expr, Ite):
        return (expr.cond, expr.then, expr.other)
    return ()


def substitute(expr: Expr, by: Mapping[str, Expr]) -> Expr:
    """`expr` with each name in `by` replaced by its expression; the parts that do not change are shared."""
    if isinstance(expr, Var):
        return by.get(expr.name, expr)
    return with_children(expr, tuple(substitute(c, by) for c in children(expr)))


def without_prev(expr: Expr) -> Expr:
    """`expr` with each prev(e) read as e (the values it can take are those e can take)."""
    if isinstance(expr, Prev):
        return without_prev(expr.arg)
    return with_children(expr, tuple(without_prev(c) for c in children(expr)))


def with_children(expr: Expr, new: tuple[Expr, ...]) -> Expr:
    """`expr` with its children (see `children`) replaced by `new`; `expr` itself where none changed."""
    if all(a is b for a, b in zip(new, children(expr), strict=True)):
        return expr
    if isinstance(expr, Not | Neg | Prev):
        return replace(expr, arg=new[0])
    if isinstance(expr, BinOp | Arith | Cmp):
        return replace(expr, left=new[0], right=new[1])
    if isinstance(expr, Call):
        return replace(expr, args=new)
    assert isinstance(expr, Ite)
    return replace(expr, cond=new[0], then=new[1], other=new[2])


def nodes(expr: Expr) -> Iterator[Expr]:
    """Every node of the tree, without recursion."""
    todo = [expr]
    while todo:
        node = todo.pop()
        yield node
        todo.extend(children(node))


def type_of(expr: Expr, types: Mapping[str, Type]) -> Type:
    """The type of an expression, as the loader checked it; `types` gives each name's (a name not in it is a
    boolean input)."""
    if isinstance(expr, Const | StateIn | Not | BinOp | Cmp):
        return "bool"
    if isinstance(expr, Num):
        return "real" if expr.real or expr.value.denominator != 1 else "int"
    if isinstance(expr, Var):
        return types.get(expr.name, "bool")
    if isinstance(expr, Call) and expr.fn == "valid":
        return "bool"
    if isinstance(expr, Prev):
        return type_of(expr.arg, types)
    if isinstance(expr, Arith) and expr.op == "/":
        return "real"
    operands = (expr.then, expr.other) if isinstance(expr, Ite) else children(expr)
    kinds = {type_of(c, types) for c in operands}
    return "real" if "real" in kinds else "bool" if kinds == {"bool"} else "int"


def prevs_of(*exprs: Expr) -> tuple[Prev, ...]:
    """The distinct prev() nodes of the expressions, in the order first met (each is one register of the frame)."""
    return tuple(dict.fromkeys(n for e in exprs for n in nodes(e) if isinstance(n, Prev)))


def names_of(expr: Expr) -> frozenset[str]:
    """Every name an expression reads (not counting states)."""
    return frozenset(n.name for n in nodes(expr) if isinstance(n, Var))


def is_boolean_only(expr: Expr) -> bool:
    """True when the expression uses only the grammar of machines without data."""
    return all(isinstance(n, BOOLEAN_NODES) for n in nodes(expr))


def as_binop(expr: Expr) -> BinOp:
    """The node as a boolean connective, for code that handles only machines without data (which have no other
    node left once constants, names, states and `not` are handled)."""
    if not isinstance(expr, BinOp):
        raise TypeError(f"{type(expr).__name__} belongs to machines with data; this path handles boolean machines")
    return expr


def inputs_of(expr: Expr) -> frozenset[str]:
    """The input names an expression mentions."""
    if isinstance(expr, Var):
        return frozenset([expr.name])
    if isinstance(expr, Not):
        return inputs_of(expr.arg)
    if isinstance(expr, BinOp):
        return inputs_of(expr.left) | inputs_of(expr.right)
    return frozenset()


def mentions_state(expr: Expr) -> bool:
    """True when the expression compares the machine's state."""
    return any(isinstance(n, StateIn) for n in nodes(expr))


def evaluate(expr: Expr, inputs: Mapping[str, bool], state: str | None = None) -> bool:
    """Evaluate an expression on concrete inputs and (when it mentions it) a concrete state."""
    if isinstance(expr, Const):
        return expr.value
    if isinstance(expr, Var):
        return inputs[expr.name]
    if isinstance(expr, StateIn):
        return state in expr.states
    if isinstance(expr, Not):
        return not evaluate(expr.arg, inputs, state)
    expr = as_binop(expr)
    a = evaluate(expr.left, inputs, state)
    b = evaluate(expr.right, inputs, state)
    return {"and": a and b, "or": a or b, "->": (not a) or b, "<->": a == b}[expr.op]


_PRECEDENCE = {"<->": 1, "->": 2, "or": 3, "and": 4}
_NOT, _CMP, _SUM, _PROD, _NEG = 5, 6, 7, 8, 9


def show_number(value: Fraction, real: bool) -> str:
    if value.denominator == 1:
        return f"{value.numerator}.0" if real else str(value.numerator)
    return repr(float(value)) if Fraction(float(value)) == value else f"({value.numerator} / {value.denominator})"


def show(expr: Expr, parent: int = 0) -> str:
    """Render an expression in the spec's own syntax, with only the parentheses it needs."""
    if isinstance(expr, Const):
        return "true" if expr.value else "false"
    if isinstance(expr, Var):
        return expr.name
    if isinstance(expr, StateIn):
        if len(expr.states) == 1:
            return f"state == {expr.states[0]}"
        return "state in {" + ", ".join(expr.states) + "}"
    if isinstance(expr, Not):
        return "not " + show(expr.arg, _NOT)
    if isinstance(expr, BinOp):
        prec = _PRECEDENCE[expr.op]
        text = f"{show(expr.left, prec)} {expr.op} {show(expr.right, prec)}"
        return f"({text})" if prec <= parent and not (prec == parent and expr.op in ("and", "or")) else text
    return _show_data(expr, parent)


def _show_data(expr: Expr, parent: int) -> str:
    if isinstance(expr, Num):
        return show_number(expr.value, expr.real)
    if isinstance(expr, Neg):
        return "-" + show(expr.arg, _NEG)
    if isinstance(expr, Call | Prev):
        name, args = ("prev", (expr.arg,)) if isinstance(expr, Prev) else (expr.fn, expr.args)
        return f"{name}(" + ", ".join(show(a) for a in args) + ")"
    if isinstance(expr, Ite):
        text = f"if {show(expr.cond)} then {show(expr.then)} else {show(expr.other)}"
        return f"({text})" if parent else text
    assert isinstance(expr, Arith | Cmp)
    prec = _CMP if isinstance(expr, Cmp) else _SUM if expr.op in "+-" else _PROD
    text = f"{show(expr.left, prec)} {expr.op} {show(expr.right, prec + (0 if isinstance(expr, Cmp) else 1))}"
    return f"({text})" if prec <= parent and not (prec == parent and isinstance(expr, Arith)) else text


# --- machine elements ----------------------------------------------------------------------------


@dataclass(frozen=True)
class Input:
    name: str
    doc: str
    cite: str
    loc: Loc


Type = Literal["bool", "int", "real"]
Unit: TypeAlias = tuple[tuple[str, int], ...]  # base units with their exponents, sorted; () is dimensionless
Range: TypeAlias = tuple[Fraction, Fraction]
Value: TypeAlias = bool | int | Fraction


@dataclass(frozen=True)
class Param:
    """A named constant. Proved for `default`; for every value in `range` when a proof is parametric."""

    name: str
    type: Type
    default: Fraction
    range: Range | None
    unit: Unit
    doc: str
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Signal:
    """A numeric input, fresh each step. A sample outside `range` (NaN and the infinities included) is invalid."""

    name: str
    type: Type
    unit: Unit
    range: Range
    doc: str
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Variable:
    """A numeric state variable: `initial` before the first step; each step it takes the value of the firing
    transition's update, else of `every`, else keeps its value."""

    name: str
    type: Type
    initial: Fraction
    range: Range | None
    every: Expr | None
    unit: Unit
    doc: str
    cite: str
    loc: Loc
    observer: bool = False  # declared `observer = true`: only invariants read it (see `observer_variables`)


@dataclass(frozen=True)
class Definition:
    """A named expression. A boolean definition that reads a signal (directly or through a numeric definition)
    takes the value `if_invalid` whenever one of those samples is invalid."""

    name: str
    type: Type
    expr: Expr
    unit: Unit
    if_invalid: bool
    signals: tuple[str, ...]
    doc: str
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Output:
    """A value emitted each step, over the state and variables after the step. One that reads signals (directly or
    through numeric definitions) is `if_invalid` at a step where one of those samples is invalid: its `expr` is
    already that choice (`if valid(a) and ... then rule else if_invalid`). An int or real one may declare a
    `range`, proved by the check `range:<name>`; an int's generated type is chosen from it."""

    name: str
    type: Type
    expr: Expr
    unit: Unit
    doc: str
    cite: str
    loc: Loc
    range: Range | None = None
    signals: tuple[str, ...] = ()


@dataclass(frozen=True)
class Assumption:
    """A constraint on the environment at every step: over that step's inputs and the state and variables
    before it."""

    id: str
    expr: Expr
    doc: str
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Update:
    variable: str
    expr: Expr


@dataclass(frozen=True)
class Transition:
    """A guarded edge. `sources` is `None` for `from = "*"` (every state)."""

    id: str
    sources: tuple[str, ...] | None
    target: str
    guard: Expr
    cite: str
    loc: Loc
    doc: str = ""
    updates: tuple[Update, ...] = ()

    def applies_to(self, state: str) -> bool:
        return self.sources is None or state in self.sources


@dataclass(frozen=True)
class Invariant:
    """Must hold after every step, over that step's inputs and the state it led to."""

    id: str
    expr: Expr
    cite: str
    expect: Verdict
    loc: Loc
    doc: str = ""
    parametric: bool = False


@dataclass(frozen=True)
class Liveness:
    """Response under persistence: if `assume` holds at every step from some step on,
    `goal` holds at some step from then on (within `within` steps when given)."""

    id: str
    assume: Expr
    goal: Expr
    within: int | None
    cite: str
    expect: Verdict
    loc: Loc
    doc: str = ""
    parametric: bool = False
    bound: Expr | None = None  # in a machine with data: the bound in steps, over params (`within` when constant)

    @property
    def steps_bound(self) -> Expr | None:
        """The bound in steps as an expression (`bound`, or the constant `within`); None when unbounded."""
        if self.bound is None and self.within is not None:
            return Num(Fraction(self.within), False)
        return self.bound


@dataclass(frozen=True)
class Lemma:
    """A statement about the spec's definitions that must hold for every value of the signals in their declared
    ranges (and of the params in theirs when `parametric`, else at their defaults), decided over the reals."""

    id: str
    expr: Expr
    cite: str
    expect: Verdict
    loc: Loc
    doc: str = ""
    parametric: bool = False


@dataclass(frozen=True)
class Comparison:
    """A declared equivalence check against another machine."""

    other: Machine
    expect: Verdict
    cite: str
    loc: Loc


@dataclass(frozen=True)
class Machine:
    """A loaded spec: its states, inputs, data, transitions and properties, as the engines and the code
    generator read them (frozen; `load_spec` builds it)."""

    name: str
    initial: str
    states: tuple[str, ...]
    inputs: tuple[Input, ...]
    transitions: tuple[Transition, ...]
    semantics: Semantics = "first-match"
    otherwise: Otherwise = "stay"
    cite: str = ""
    doc: str = ""
    invariants: tuple[Invariant, ...] = ()
    liveness: tuple[Liveness, ...] = ()
    comparisons: tuple[Comparison, ...] = ()
    expect: Mapping[str, Verdict] = field(default_factory=dict)
    loc: Loc = IN_MEMORY
    params: tuple[Param, ...] = ()
    signals: tuple[Signal, ...] = ()
    variables: tuple[Variable, ...] = ()
    definitions: tuple[Definition, ...] = ()  # each after the definitions it reads
    outputs: tuple[Output, ...] = ()
    assumptions: tuple[Assumption, ...] = ()
    step_s: Fraction | None = None
    lemmas: tuple[Lemma, ...] = ()
    data: bool = False  # declared data, or uses an expression a machine without data cannot (arithmetic, prev)
    fallback: str = ""  # the state a context whose mode names no state restarts in ("": the initial state)
    reals: Reals = "binary64"  # the IEEE 754 format the generated code computes reals in (see `floats`)

    @property
    def fallback_state(self) -> str:
        """The state the generated code restarts a corrupted context in (its mode names no state): the spec's
        `fallback`, or the initial state."""
        return self.fallback or self.initial

    @property
    def input_names(self) -> tuple[str, ...]:
        """The boolean inputs' names, in the spec's order."""
        return tuple(i.name for i in self.inputs)

    @property
    def has_data(self) -> bool:
        """Whether the machine has data: declared, or used where a machine without data has none (arithmetic, prev)."""
        return self.data

    def outgoing(self, state: str) -> tuple[Transition, ...]:
        """Transitions that apply in `state`, in priority (file) order."""
        return tuple(t for t in self.transitions if t.applies_to(state))

    def expected(self, prop: str) -> Verdict:
        """The declared expectation for a built-in check (default: holds)."""
        return self.expect.get(prop, "holds")


def stateful_definitions(definitions: Iterable[Definition], variables: Iterable[str]) -> frozenset[str]:
    """The definitions (given in dependency order) that read the mode or a variable, directly or through other
    definitions."""
    found: set[str] = set()
    named = set(variables)
    for d in definitions:
        if any(
            isinstance(x, StateIn) or (isinstance(x, Var) and (x.name in named or x.name in found))
            for x in nodes(d.expr)
        ):
            found.add(d.name)
    return frozenset(found)


def name_types(m: Machine) -> dict[str, Type]:
    """The type of every numeric or boolean name of a machine but its boolean inputs (see `type_of`)."""
    found: dict[str, Type] = {p.name: p.type for p in m.params}
    found.update({v.name: v.type for v in m.variables})
    found.update({s.name: s.type for s in m.signals})
    found.update({d.name: d.type for d in m.definitions})
    found.update({o.name: o.type for o in m.outputs})
    return found


def bodies(m: Machine) -> dict[str, Expr]:
    """The expression of each definition (in dependency order) and then of each output."""
    found = {d.name: d.expr for d in m.definitions}
    found.update({o.name: o.expr for o in m.outputs})
    return found


def own(name: str) -> str:
    """The solver's name of a constant the engine defines for itself (a mode, a register, a counter, a flag), as
    its certificates print it. It starts with '!', which no spec name holds, so a spec symbol (`<name>@<step>`)
    can never be one of them."""
    return f"!{name}"


def reads_context_only(expr: Expr, m: Machine) -> bool:
    """True when the expression reads nothing but the mode, the variables and the params, directly or through
    definitions and outputs: its value is then a function of the context and the params alone."""
    context = {v.name for v in m.variables} | {p.name for p in m.params}
    found = bodies(m)
    todo, seen = [expr], set()
    while todo:
        for node in nodes(todo.pop()):
            if isinstance(node, Prev):
                return False
            if isinstance(node, Var) and node.name not in context:
                if node.name not in found:
                    return False  # an input or a signal
                if node.name not in seen:
                    seen.add(node.name)
                    todo.append(found[node.name])
    return True


def stored_registers(m: Machine, prevs: Sequence[Prev]) -> frozenset[int]:
    """The prev() registers (by index in `prevs`) that a step must store: those whose expression reads an input or
    a signal, directly or through a definition or an output. Any other one is its expression over the context
    before the step (at the first step as after it, see `symbolic.System.build_step`), which the monitor computes
    from that context: the generated step keeps no copy of it."""
    return frozenset(k for k, p in enumerate(prevs) if not reads_context_only(p.arg, m))


def observer_variables(m: Machine) -> frozenset[str]:
    """The variables declared `observer = true` (MLCA-T's `need_age`): only invariants read them, which the loader
    checks (`observer_readers`). The product step need not keep them; the monitor keeps them beside the context
    (see the generated code's `<name>_observers_t`)."""
    return frozenset(v.name for v in m.variables if v.observer)


def observer_readers(m: Machine) -> Iterator[tuple[Variable, str]]:
    """Each declared observer that something other than an invariant or an observer's update reads, with what
    reads it, and each that computes on reals (the generated code's binary64 parts read the context alone)."""
    types = name_types(m)
    readers: list[tuple[str, Expr]] = [(f"the guard of transition '{t.id}'", t.guard) for t in m.transitions]
    readers += [(f"output '{o.name}'", o.expr) for o in m.outputs]
    readers += [(f"definition '{d.name}'", d.expr) for d in m.definitions]
    readers += [(f"a prev() of invariant '{inv.id}'", p.arg) for inv in m.invariants for p in prevs_of(inv.expr)]
    readers += [(f"liveness '{live.id}'", x) for live in m.liveness for x in (live.assume, live.goal, live.steps_bound)
                if x is not None]  # fmt: skip
    readers += [(f"assumption '{a.id}'", a.expr) for a in m.assumptions]
    for v in m.variables:
        if not v.observer:
            readers += [(f"the update of variable '{v.name}'", e) for e in _updates_of(m, v)]
    for v in m.variables:
        if not v.observer:
            continue
        if v.type == "real" or any(type_of(n, types) == "real" for e in _updates_of(m, v) for n in nodes(e)):
            yield v, "it computes on reals (an observer is an int or a bool computed from ints and booleans)"
            continue
        found = next((words for words, e in readers if v.name in names_of(e)), None)
        if found is not None:
            yield v, f"{found} reads it (only invariants and other observers' updates may)"


def _updates_of(m: Machine, v: Variable) -> list[Expr]:
    """What a variable's value is computed from: its transitions' updates and its `every`."""
    found = [u.expr for t in m.transitions for u in t.updates if u.variable == v.name]
    return [*found, *([v.every] if v.every is not None else [])]
