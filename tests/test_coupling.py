"""Which MC/DC conditions no suite can show independent as clang counts them (unique cause, short circuits free),
against a brute-force enumeration of every pair of contexts written apart from the z3 encoding."""

from __future__ import annotations

import itertools

from hypothesis import given, settings
from hypothesis import strategies as st

from mlca_verify.model import Machine
from mlca_verify.spec import load_text
from mlca_verify.testgen.coupling import coupling_reason, unique_cause_impossible
from mlca_verify.testgen.objectives import atoms

HEAD = """\
[machine]
name = "U"
initial = "A"
states = ["A", "B"]
[inputs]
go = {{ doc = "go" }}
[variables]
x = {{ type = "int", initial = 0, range = [0, 2], every = "x", doc = "x" }}
y = {{ type = "int", initial = 0, range = [0, 2], every = "y", doc = "y" }}
[definitions]
d = {{ expr = "{expr}", doc = "d" }}
[[transition]]
from = "A"
to = "B"
when = "go and d"
"""
ATOMS = ["x == 0", "x == 1", "x == 2", "y == 0", "y < 2", "x <= y", "x != y"]
PY = {
    "x == 0": lambda x, y: x == 0,
    "x == 1": lambda x, y: x == 1,
    "x == 2": lambda x, y: x == 2,
    "y == 0": lambda x, y: y == 0,
    "y < 2": lambda x, y: y < 2,
    "x <= y": lambda x, y: x <= y,
    "x != y": lambda x, y: x != y,
}


def _machine(expr: str) -> Machine:
    return load_text(HEAD.format(expr=expr), "u.toml")


def _run(tree: object, x: int, y: int, values: list[bool | None]) -> bool:
    """Evaluates the tree as C does, writing each condition's value or None where it is short-circuited."""
    if isinstance(tree, str):
        values.append(bool(PY[tree](x, y)))
        return bool(values[-1])
    op, left, right = tree  # type: ignore[misc]
    a = _run(left, x, y, values)
    if (op == "and" and not a) or (op == "or" and a):
        values.extend([None] * _count(right))
        return a
    return _run(right, x, y, values)


def _count(tree: object) -> int:
    return 1 if isinstance(tree, str) else _count(tree[1]) + _count(tree[2])  # type: ignore[index]


def _text(tree: object) -> str:
    return tree if isinstance(tree, str) else f"({_text(tree[1])} {tree[0]} {_text(tree[2])})"  # type: ignore[index]


def _brute_impossible(tree: object, k: int) -> bool:
    runs = []
    for x, y in itertools.product(range(3), repeat=2):
        values: list[bool | None] = []
        runs.append((_run(tree, x, y, values), values))
    for (out_a, a), (out_b, b) in itertools.product(runs, repeat=2):
        if out_a == out_b or a[k] is None or b[k] is None or a[k] == b[k]:
            continue
        if all(j == k or a[j] is None or b[j] is None or a[j] == b[j] for j in range(len(a))):
            return False
    return True


trees = st.recursive(st.sampled_from(ATOMS), lambda sub: st.tuples(st.sampled_from(["and", "or"]), sub, sub),
                     max_leaves=5)  # fmt: skip


@settings(max_examples=60, deadline=None)
@given(trees, st.data())
def test_z3_and_brute_force_agree_on_which_conditions_have_no_unique_cause_pair(
    tree: object, data: st.DataObject
) -> None:
    machine = _machine(_text(tree))
    expr = next(d.expr for d in machine.definitions if d.name == "d")
    assert len(atoms(expr)) == _count(tree)
    k = data.draw(st.integers(0, _count(tree) - 1))
    assert unique_cause_impossible(machine, expr, k) == _brute_impossible(tree, k)


def test_a_condition_coupled_with_the_ones_before_it_gets_its_reason() -> None:
    """The elevator's `here` has a pair for `floor == 0` but none for `floor == 2`: once the two before it are
    false, the floor is 2 whatever the suite does."""
    text = "(x == 0 and y == 0) or (x == 1 and y == 0) or (x == 2 and y == 0)"
    machine = _machine(text)
    expr = next(d.expr for d in machine.definitions if d.name == "d")
    assert [unique_cause_impossible(machine, expr, k) for k in range(6)] == [False, False, False, False, True, False]
    reason = coupling_reason(machine, "d", 4, 6)
    assert reason.startswith("x == 2 in d: clang counts MC/DC by unique cause")
    assert "(coupled with x == 0, x == 1: they read the same names)" in reason
    assert coupling_reason(machine, "d", 0, 6) == "" and coupling_reason(machine, "d", 4, 5) == ""
