"""The spec's proved invariants as contracts of the generated C, each with its certificate as precondition.

For every invariant the engine proves for all params in range, with a certificate a separate query confirmed
(an inductive invariant over the mode, the variables, the `prev()` registers and the first-step flag), this
module writes the certificate and the invariant in ACSL. A register the code does not keep (it reads the context
alone) and, without any kept one, the first-step flag are members of a ghost struct `g` that the proof's wrapper of
the step updates as the engine updates its frame. `conform` puts them on a wrapper of the step in a proof
file of its own (the certificates come from the solver, so they stay out of the checked-in code): WP then
proves, from the step's own contract, that a step from a context satisfying the certificates keeps them and
leaves every such invariant true, and that the initial context satisfies them.

A certificate is read from its SMT-LIB text (the `certificate` of the check's JSON); a symbol that is not part of
the C context (a bounded response's counter) leaves that invariant out, with the reason.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction

from mlca_verify.codegen.acsl import AcslLowering
from mlca_verify.codegen.ir import binary64
from mlca_verify.logic.symbolic import input_only
from mlca_verify.model import (
    Expr,
    Input,
    Machine,
    Prev,
    Type,
    observer_variables,
    own,
    prevs_of,
    stored_registers,
)

Sexpr = str | list["Sexpr"]


def compares_floats(reals: str) -> str:
    """Why an invariant that compares reals is not stated to WP, in the machine's format."""
    return f"it compares {reals} values, which z3 bit-blasts; the exhaustive checks cover it"


COMPARES_BINARY64 = compares_floats("binary64")
_TOKEN = re.compile(r"\(|\)|[^\s()]+")
MAX_TOKENS = 100_000


class Untranslatable(ValueError):
    """The certificate reads something the C context does not hold."""


def parse(text: str) -> Sexpr:
    tokens = _TOKEN.findall(text)
    if len(tokens) > MAX_TOKENS:
        raise Untranslatable(f"certificate of {len(tokens)} tokens")
    stack: list[list[Sexpr]] = [[]]
    for tok in tokens:
        if tok == "(":
            stack.append([])
        elif tok == ")":
            if len(stack) < 2:
                raise Untranslatable("unbalanced certificate")
            done = stack.pop()
            stack[-1].append(done)
        else:
            stack[-1].append(tok)
    if len(stack) != 1 or len(stack[0]) != 1:
        raise Untranslatable("malformed certificate")
    return stack[0][0]


@dataclass(frozen=True)
class Frame:
    """How the engine's frame symbols read in ACSL over the context `c` and params `p` (struct values)."""

    terms: Mapping[str, tuple[str, Type]]  # symbol -> (ACSL term, type)


def holder(k: int | None, stored: frozenset[int], name: str, member: str = ".") -> str:
    """Which struct holds register `k` (None: the first-step flag): the context `c` where the code keeps it
    (see `model.stored_registers`), else the proof's ghost `g`, which the wrapper of the step keeps as the engine
    keeps its frame."""
    kept = bool(stored) if k is None else k in stored
    return f"{'c' if kept else 'g'}{member}{name}"


def frame_of(
    m: Machine, prev_index: Mapping[Prev, int], inv_prevs: Sequence[Prev], types: Sequence[Type], stored: frozenset[int]
) -> Frame:
    terms: dict[str, tuple[str, Type]] = {
        own("mode@p0"): ("c.mode", "int"),
        own("first@p0"): (holder(None, stored, "first"), "bool"),
    }
    watched = observer_variables(m)  # kept by the monitor: the proof's ghost keeps them too
    for v in m.variables:
        terms[f"{v.name}@p0"] = (f"g.obs.{v.name}" if v.name in watched else f"c.{v.name}", v.type)
    for j, prev in enumerate(inv_prevs):
        k = prev_index[prev]
        terms[own(f"prev{j}@p0")] = (holder(k, stored, f"prev{k}"), types[j])
    for p in m.params:
        terms[f"param!{p.name}"] = (f"p.{p.name}", p.type)
    return Frame(terms)


class Translate:
    """One certificate as an ACSL predicate over `c` and `p`."""

    def __init__(self, frame: Frame) -> None:
        self.frame = frame
        self.lets: dict[str, tuple[str, bool]] = {}  # name -> (ACSL text, is a predicate)

    def pred(self, e: Sexpr) -> str:
        text, is_pred = self.go(e)
        return text if is_pred else f"({text} != 0)"

    def term(self, e: Sexpr) -> str:
        text, is_pred = self.go(e)
        if is_pred:
            raise Untranslatable("a boolean where a number is expected")
        return text

    def go(self, e: Sexpr) -> tuple[str, bool]:
        if isinstance(e, str):
            return self.atom(e)
        if not e or not isinstance(e[0], str):
            raise Untranslatable("malformed certificate")
        op, args = e[0], e[1:]
        if op == "let":
            return self.let(args)
        if op in ("and", "or", "not", "=>", "=", "ite"):
            return self.logical(op, args)
        return self.arithmetic(op, args)

    def logical(self, op: str, args: list[Sexpr]) -> tuple[str, bool]:
        if op in ("and", "or"):
            if not args:
                return ("\\true" if op == "and" else "\\false"), True
            return "(" + f" {'&&' if op == 'and' else '||'} ".join(self.pred(a) for a in args) + ")", True
        if op == "not":
            return f"(!{self.pred(args[0])})", True
        if op == "=>":
            return f"({self.pred(args[0])} ==> {self.pred(args[1])})", True
        if op == "=":
            return self.equal(args[0], args[1])
        return self.ite(args)

    def arithmetic(self, op: str, args: list[Sexpr]) -> tuple[str, bool]:
        if op in ("<=", ">=", "<", ">"):
            return f"({self.term(args[0])} {op} {self.term(args[1])})", True
        if op in ("+", "*"):
            return "(" + f" {op} ".join(self.term(a) for a in args) + ")", False
        if op == "-":
            if len(args) == 1:
                return f"(-{self.term(args[0])})", False
            return "(" + " - ".join(self.term(a) for a in args) + ")", False
        if op == "/" and len(args) == 2:
            return f"({self.term(args[0])} / {self.term(args[1])})", False
        if op == "to_real" and len(args) == 1:
            return f"((real){self.term(args[0])})", False
        raise Untranslatable(f"operator {op!r}")

    def atom(self, name: str) -> tuple[str, bool]:
        if name in ("true", "false"):
            return f"\\{name}", True
        if name in self.lets:
            return self.lets[name]
        if re.fullmatch(r"\d+", name):
            return name, False
        if re.fullmatch(r"\d+\.\d+", name):
            return _real(Fraction(name)), False
        if name in self.frame.terms:
            text, kind = self.frame.terms[name]
            return (f"({text} != 0)", True) if kind == "bool" else (text, False)
        raise Untranslatable(f"symbol {name!r} is not in the C context")

    def let(self, args: list[Sexpr]) -> tuple[str, bool]:
        bindings, body = args[0], args[1]
        if not isinstance(bindings, list):
            raise Untranslatable("malformed let")
        for binding in bindings:
            if not isinstance(binding, list) or len(binding) != 2 or not isinstance(binding[0], str):
                raise Untranslatable("malformed let")
            self.lets[binding[0]] = self.go(binding[1])
        return self.go(body)

    def equal(self, a: Sexpr, b: Sexpr) -> tuple[str, bool]:
        left, right = self.go(a), self.go(b)
        if left[1] or right[1]:
            return f"({self.pred(a)} <==> {self.pred(b)})", True
        return f"({left[0]} == {right[0]})", True

    def ite(self, args: list[Sexpr]) -> tuple[str, bool]:
        cond = self.pred(args[0])
        then, other = self.go(args[1]), self.go(args[2])
        if then[1] or other[1]:
            return f"({cond} ? {self.pred(args[1])} : {self.pred(args[2])})", True
        return f"({cond} ? {then[0]} : {other[0]})", False  # a predicate condition in a term: ACSL allows it


def _real(value: Fraction) -> str:
    return f"({value.numerator}.0 / {value.denominator}.0)" if value.denominator != 1 else f"{value.numerator}.0"


@dataclass(frozen=True)
class Certified:
    """An invariant the proof file states: its id, the certificate and the invariant in ACSL."""

    index: int
    id: str
    certificate: str  # over c, p
    invariant: str  # over c, i, p, o (after the step) and the prev values
    cite: str


def invariant_text(
    lowering: AcslLowering, expr: Expr, prev_index: Mapping[Prev, int], prefix: str, stored: frozenset[int]
) -> str:
    """The invariant over the context after the step; prev(e) is e over the context before it, or at the first
    step e over that same context (as the engine and the monitor read it)."""
    prevs: dict[Prev, str] = {}
    first = holder(None, stored, "first", "p->")
    for prev in prevs_of(expr):
        k = prev_index[prev]
        register = holder(k, stored, f"prev{k}", "p->")
        fresh = f"{prefix}_lprev{k}(\\at(*cp, Pre), i, p)"
        if lowering.type_of(prev.arg) == "bool":
            prevs[prev] = f"((\\at({first}, Pre) != 0) ? {fresh} : (\\at({register}, Pre) != 0))"
        else:
            prevs[prev] = f"(\\at({first}, Pre) ? {fresh} : \\at({register}, Pre))"
    return lowering.go(expr, prevs)


def assumed_text(m: Machine, lowering: AcslLowering) -> str:
    """The environment assumptions over the context before the step, its inputs and params: the engine proved
    the invariants of the steps they allow, so the wrapper requires them. One that compares binary64 values is
    left out (z3 bit-blasts it); an invariant that needs it is then not proved on the step, never proved wrongly."""
    parts = [lowering.go(a.expr, {}) for a in m.assumptions if not binary64(a.expr, lowering.n.types)]
    return " && ".join(f"({x})" for x in parts) or "\\true"


@dataclass(frozen=True)
class Proved:
    """What the engine proved of one invariant: its id and certificate (SMT-LIB), for every param in range."""

    id: str
    certificate: str


def as_wp_sees(m: Machine, types: Mapping[str, Type]) -> tuple[Machine, tuple[str, ...]]:
    """The machine with each boolean definition WP cannot look into made a boolean input of its own: one that
    computes on reals and reads only the step's inputs, signals and params, whose logic function has no body (see
    `data_ir.binary64`). An invariant proved of this machine holds whatever values those definitions take, as WP
    must show it does; one proved only of the machine itself needs their arithmetic (a tank's `low` and `high`
    never both true), which WP does not see."""
    free = input_only(m)
    opaque = [d for d in m.definitions if d.type == "bool" and d.name in free and binary64(d.expr, types)]
    if not opaque:
        return m, ()
    inputs = m.inputs + tuple(Input(d.name, d.doc, d.cite, d.loc) for d in opaque)
    kept = tuple(d for d in m.definitions if d not in opaque)
    return replace(m, inputs=inputs, definitions=kept), tuple(d.name for d in opaque)


def needs_arithmetic(
    m: Machine, types: Mapping[str, Type], ids: Sequence[str], opaque: Sequence[str]
) -> list[tuple[str, str]]:
    """Why each of the invariants `ids`, proved of the machine but not as WP sees it (`as_wp_sees`), is left out."""
    why = f"its proof needs the arithmetic of {', '.join(opaque)}, which compute on reals: WP sees them as "
    why += f"functions without a body (z3 bit-blasts {m.reals}); the exhaustive and sequence checks cover it"
    exprs = {inv.id: inv.expr for inv in m.invariants}
    return [(i, compares_floats(m.reals) if binary64(exprs[i], types) else why) for i in ids]


def certify(
    m: Machine, lowering: AcslLowering, proved: Sequence[Proved]
) -> tuple[list[Certified], list[tuple[str, str]]]:
    """The invariants stated with their certificates, and those left out with the reason."""
    all_prevs = prevs_of(*(inv.expr for inv in m.invariants))
    prev_index = {p: k for k, p in enumerate(all_prevs)}
    stored = stored_registers(m, all_prevs)
    by_id = {inv.id: inv for inv in m.invariants}
    stated: list[Certified] = []
    left: list[tuple[str, str]] = []
    for item in proved:
        inv = by_id[item.id]
        if binary64(inv.expr, lowering.n.types):
            left.append((inv.id, compares_floats(m.reals)))
            continue
        own = prevs_of(inv.expr)
        frame = frame_of(m, prev_index, own, [lowering.type_of(p.arg) for p in own], stored)
        try:
            certificate = Translate(frame).pred(parse(item.certificate))
        except (Untranslatable, IndexError) as err:
            left.append((inv.id, str(err) or "malformed certificate"))
            continue
        text = invariant_text(lowering, inv.expr, prev_index, lowering.n.prefix, stored)
        stated.append(Certified(len(stated), inv.id, certificate, text, inv.cite))
    return stated, left


def ranges(m: Machine, c: str | None, p: str, pointer: bool, g: str = "gp") -> str:
    """The int variables (none without `c`) and int params in their ranges, over `c` and `p` (pointers or
    struct values), an observer over the ghost `g`'s observers. The real params' ranges are left out, as in the
    step's own contract: a binary64 term among the hypotheses makes z3 bit-blast (see `codegen.ir.binary64`)."""
    dot = "->" if pointer else "."
    watched = observer_variables(m)
    parts = [
        f"{int(v.range[0])} <= {f'{g}{dot}obs.' if v.name in watched else f'{c}{dot}'}{v.name} <= {int(v.range[1])}"
        for v in m.variables
        if c is not None and v.type == "int" and v.range is not None
    ]
    for q in m.params:
        if q.range is not None and q.type == "int":
            parts.append(f"{int(q.range[0])} <= {p}{dot}{q.name} <= {int(q.range[1])}")
    return " && ".join(parts) or "\\true"
