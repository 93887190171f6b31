"""The input classes of a machine with data: every way a step's inputs can set its boolean inputs and its atoms
(see `concrete`), each with signal values that realise it, found by z3.

Two steps from one frame with inputs of the same class fire the same transition and reach the same frame, so
the explicit engine needs one step per class, not one per signal value. Only environment assumptions that read
nothing of the frame constrain the classes; the others are evaluated on each frame.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import z3

from mlca_verify.logic.solver import budget
from mlca_verify.logic.symbolic import System
from mlca_verify.model import Expr

CLASS_LIMIT = 4096  # more classes than this: the steps of a frame are too many to enumerate
COLUMN_LIMIT = 16  # more linked boolean inputs and atoms than this: not split into classes at all


@dataclass(frozen=True)
class InputClass:
    """One class: the boolean inputs (in declaration order), the atoms (in the compiler's order), and a signal
    value for each signal that realises them (z3 numerals)."""

    bools: tuple[bool, ...]
    atoms: tuple[bool, ...]
    signals: tuple[z3.ExprRef, ...]


class TooManyClasses(Exception):
    """The inputs split into more classes than the limit, or z3 could not decide a class."""


def input_classes(
    system: System, atoms: Sequence[Expr], assumptions: Sequence[Expr], timeout_ms: int
) -> tuple[InputClass, ...]:
    """Every class, in a fixed order (each column false before true). `system` is the machine's real system with
    its params fixed; `assumptions` read only the step's inputs. A boolean input that no atom and no assumption
    reads takes both values freely, without a query."""
    frame, inputs = system.frame("cls"), system.inputs("cls")
    at = system.valuation(frame, inputs)
    atom_terms = [system.ev(a, at) for a in atoms]
    constraint = z3.And(*[system.ev(a, at) for a in assumptions])
    bools = list(inputs.bools.values())
    linked = _linked(bools, [*atom_terms, constraint])
    columns = [b for k, b in enumerate(bools) if k in linked] + atom_terms
    if len(columns) > COLUMN_LIMIT:  # the search below would ask up to 2 ** columns queries to find out
        raise TooManyClasses(f"{len(columns)} linked inputs and atoms: more than {COLUMN_LIMIT}")
    solver = z3.Solver()
    budget(solver, timeout_ms)
    solver.add(constraint)
    leaves = _split(solver, columns, [], [])
    free = [k for k in range(len(bools)) if k not in linked]
    if len(leaves) * 2 ** len(free) > CLASS_LIMIT:
        raise TooManyClasses(f"more than {CLASS_LIMIT} input classes")
    signals = list(inputs.signals.values())
    found = []
    for values, model in leaves:
        witness = tuple(model.eval(s, model_completion=True) for s in signals)
        tied = dict(zip(sorted(linked), values[: len(linked)], strict=True))
        for choice in itertools.product((False, True), repeat=len(free)):
            row = {**tied, **dict(zip(free, choice, strict=True))}
            found.append(InputClass(tuple(row[k] for k in range(len(bools))), values[len(linked) :], witness))
    return tuple(sorted(found, key=lambda c: (c.bools, c.atoms)))


def _linked(bools: Sequence[z3.BoolRef], terms: Sequence[z3.ExprRef]) -> set[int]:
    """The positions of the boolean inputs that some term reads."""
    read: set[int] = set()
    ids = {b.get_id(): k for k, b in enumerate(bools)}
    todo = list(terms)
    seen: set[int] = set()
    while todo:
        t = todo.pop()
        if t.get_id() in seen:
            continue
        seen.add(t.get_id())
        if t.get_id() in ids:
            read.add(ids[t.get_id()])
        todo.extend(t.children())
    return read


def _split(
    solver: z3.Solver, columns: Sequence[z3.BoolRef], fixed: list[z3.BoolRef], values: list[bool]
) -> list[tuple[tuple[bool, ...], z3.ModelRef]]:
    """The satisfiable valuations of `columns` under `fixed`, each with a model, depth first, false first."""
    answer = solver.check(*fixed)
    if answer == z3.unknown:
        raise TooManyClasses(f"z3 could not decide an input class: {solver.reason_unknown()}")
    if answer == z3.unsat:
        return []
    if len(values) == len(columns):
        return [(tuple(values), solver.model())]
    column = columns[len(values)]
    found = []
    for value in (False, True):
        found += _split(solver, columns, [*fixed, column if value else z3.Not(column)], [*values, value])
        if len(found) > CLASS_LIMIT:
            raise TooManyClasses(f"more than {CLASS_LIMIT} input classes")
    return found
