"""The parts of a machine's guards, updates, outputs and `prev()` registers that compute on reals, each given a C
function of its own whose link to its logic symbol is the one contract WP is not asked to prove.

z3, through Why3, decides binary64 by bit-blasting and runs out of memory on a goal that holds a binary64
operation or comparison among its hypotheses (see `data_ir.binary64`). A definition that computes on reals is
already a function of its own with a logic symbol that has no body; a guard such as `go and x > 0.25`, or an
update `min(x + step, 100.0)` of a real variable, would otherwise put that arithmetic into the step's contract.
Here each such part becomes a call: the comparison `x > 0.25` a boolean function, the update's whole value a
double function. Everything else (the booleans, the ints, which transition fires, the ranges of the int
variables) stays exact in the contract, and the exhaustive and sequence checks compare each part's C bit for
bit with z3's semantics of the spec.
"""

from __future__ import annotations

from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass

from mlca_verify.model import Call, Cmp, Expr, Machine, Neg, Num, StateIn, Type, Var, children, nodes, type_of


@dataclass(frozen=True)
class Part:
    """One distinct part, by its position among the machine's parts, with every node of the spec that is it."""

    index: int
    expr: Expr
    kind: Type  # bool for a comparison or a validity test, real for a value
    free: bool  # reads neither the mode nor a variable (its function then takes no context, see `acsl.context_free`)
    users: tuple[str, ...]  # where the code reads it: "the guard of t1", "the update of x by t2", ...


def _literal(e: Expr) -> bool:
    return isinstance(e, Num) or (isinstance(e, Neg) and isinstance(e.arg, Num))


def _compares_reals(e: Expr, types: Mapping[str, Type]) -> bool:
    if isinstance(e, Cmp):
        return "real" in (type_of(e.left, types), type_of(e.right, types))
    if isinstance(e, Call) and e.fn == "valid":
        return any(isinstance(a, Var) and types.get(a.name) == "real" for a in e.args)
    return False


def parts_of(e: Expr, target: Type, types: Mapping[str, Type]) -> Iterator[tuple[Expr, Type]]:
    """The nodes of `e` (a value of type `target`) that compute on reals, outermost first, each with the type its
    function returns: the whole value when it is a real computed from others (a literal or a name read as it is
    needs no rounding; an int value is converted inside the function), else each comparison with a real operand
    and each validity test of a real signal."""
    if target == "real" and not _literal(e) and not isinstance(e, Var):
        yield e, "real"
        return
    todo = [e]
    while todo:
        node = todo.pop()
        if _compares_reals(node, types):
            yield node, "bool"
        else:
            todo.extend(reversed(children(node)))


def _sites(m: Machine, types: Mapping[str, Type], registers: Sequence[Expr]) -> Iterator[tuple[str, Expr, Type]]:
    """Each expression the step contract states, with where it is read and the type it is read as."""
    for t in m.transitions:
        yield f"the guard of {t.id}", t.guard, "bool"
    for v in m.variables:
        for t in m.transitions:
            for u in t.updates:
                if u.variable == v.name:
                    yield f"the update of {v.name} by {t.id}", u.expr, v.type
        if v.every is not None:
            yield f"the every-step update of {v.name}", v.every, v.type
    for o in m.outputs:
        yield f"the output {o.name}", o.expr, o.type
    for k, arg in enumerate(registers):
        yield f"the register prev{k}", arg, type_of(arg, types)


def rounded_parts(
    m: Machine, types: Mapping[str, Type], stateful: Iterable[str], registers: Sequence[Expr]
) -> tuple[tuple[Part, ...], dict[int, int]]:
    """The machine's distinct parts that compute on reals, and for every node of the spec that is one of them
    (by the node's identity) the part's index. Parts equal as expressions are one part. `registers` are what each
    `prev()` register keeps, as the code computes it (the very nodes the code is lowered from)."""
    context = set(stateful) | {v.name for v in m.variables}
    index: dict[tuple[Expr, Type], int] = {}
    users: dict[int, list[str]] = {}
    at: dict[int, int] = {}
    for where, e, target in _sites(m, types, registers):
        for node, kind in parts_of(e, target, types):
            k = index.setdefault((node, kind), len(index))
            users.setdefault(k, []).append(where)
            at[id(node)] = k
    parts = tuple(
        Part(k, node, kind, not _reads_context(node, context), tuple(dict.fromkeys(users[k])))
        for (node, kind), k in index.items()
    )
    return parts, at


def _reads_context(e: Expr, context: set[str]) -> bool:
    return any(isinstance(x, StateIn) or (isinstance(x, Var) and x.name in context) for x in nodes(e))
