"""Definitions that are one rule over different signals (MLCA-T's L and R: the same gap rule, left and right)
share one generated function, which takes the samples as arguments; each definition calls it with its own.

Two definitions share a shape when, with the numeric definitions they read written out and their signals
renamed in order of first use, they are the same expression over signals of the same types and ranges, with the
same `if_invalid`. Only definitions that read nothing but signals, params and constants are considered.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from fractions import Fraction

from mlca_verify.model import (
    Arith,
    BinOp,
    Call,
    Cmp,
    Const,
    Definition,
    Expr,
    Ite,
    Machine,
    Neg,
    Not,
    Num,
    Prev,
    StateIn,
    Type,
    Var,
    show,
)

ARG = "s__{}"  # argument names: '__' is refused in spec names, so they cannot clash


@dataclass(frozen=True)
class Shape:
    index: int
    expr: Expr  # over the arguments s__0, s__1, ...
    args: tuple[tuple[str, Type, tuple[Fraction, Fraction]], ...]  # name, type, range
    kind: Type
    if_invalid: bool
    guarded: bool  # a boolean that reads samples: invalid ones give if_invalid


@dataclass(frozen=True)
class Use:
    shape: int
    signals: tuple[str, ...]  # the definition's samples, in argument order


class _Open:
    """Writes a definition out over its signals, renamed in order of first use; None when it reads anything
    else than signals, params, constants and numeric definitions of the same kind."""

    def __init__(self, m: Machine) -> None:
        self.defs = {d.name: d for d in m.definitions}
        self.signals = {s.name: s for s in m.signals}
        self.params = {p.name for p in m.params}

    def open(self, d: Definition) -> tuple[Expr, list[str]] | None:
        order: list[str] = []
        try:
            return self.walk(d.expr, order), order
        except LookupError:
            return None

    def walk(self, e: Expr, order: list[str]) -> Expr:
        if isinstance(e, Const | Num):
            return e
        if isinstance(e, Var):
            return self.name(e.name, order)
        if isinstance(e, StateIn | Prev):
            raise LookupError(e)
        if isinstance(e, Not | Neg):
            return replace(e, arg=self.walk(e.arg, order))
        if isinstance(e, BinOp | Arith | Cmp):
            return replace(e, left=self.walk(e.left, order), right=self.walk(e.right, order))
        if isinstance(e, Ite):
            return Ite(self.walk(e.cond, order), self.walk(e.then, order), self.walk(e.other, order))
        assert isinstance(e, Call)
        return Call(e.fn, tuple(self.walk(a, order) for a in e.args))

    def name(self, name: str, order: list[str]) -> Expr:
        if name in self.signals:
            if name not in order:
                order.append(name)
            return Var(ARG.format(order.index(name)))
        if name in self.params:
            return Var(name)
        d = self.defs.get(name)
        if d is None or d.type == "bool":
            raise LookupError(name)
        return self.walk(d.expr, order)


def shared_shapes(m: Machine) -> tuple[tuple[Shape, ...], dict[str, Use]]:
    """The shapes two or more definitions share, and which definitions use which (with their samples)."""
    opener = _Open(m)
    groups: dict[tuple[object, ...], list[tuple[Definition, Expr, list[str]]]] = {}
    for d in m.definitions:
        opened = opener.open(d)
        if opened is None or not opened[1]:
            continue
        expr, order = opened
        sigs = [opener.signals[s] for s in order]
        if d.type == "bool" and sorted(d.signals) != sorted(order):
            continue
        key = (show(expr), d.type, d.if_invalid, tuple((s.type, s.range) for s in sigs))
        groups.setdefault(key, []).append((d, expr, order))
    shapes: list[Shape] = []
    uses: dict[str, Use] = {}
    for members in groups.values():
        if len(members) < 2:
            continue
        d, expr, order = members[0]
        args = tuple((ARG.format(k), opener.signals[s].type, opener.signals[s].range) for k, s in enumerate(order))
        shape = Shape(len(shapes), expr, args, d.type, d.if_invalid, d.type == "bool" and bool(d.signals))
        shapes.append(shape)
        for member, _, member_order in members:
            uses[member.name] = Use(shape.index, tuple(member_order))
    return tuple(shapes), uses
