"""Many transitions out of one state: check and codegen finish, and their work grows linearly, not quadratically.

Work is measured as solver queries and z3 term sizes, never as wall time."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import z3
from bench.wide import wide_spec

from mlca_verify.codegen import machine_ir
from mlca_verify.errors import SpecError
from mlca_verify.logic import check_all
from mlca_verify.logic.boolean import Checker
from mlca_verify.logic.solver import Solver
from mlca_verify.logic.tables import MAX_TABLE_INPUTS, MAX_WRITTEN_OUT
from mlca_verify.model import Machine
from mlca_verify.spec import load_spec, load_text


def wide(n: int, style: str = "shadowed", semantics: str = "first-match", n_inputs: int = 5) -> Machine:
    return load_text(wide_spec(n, style, semantics, n_inputs), "<wide>")


def dag_size(term: z3.ExprRef) -> int:
    """Distinct nodes of a z3 term."""
    seen: set[int] = set()
    todo = [term]
    while todo:
        node = todo.pop()
        if node.get_id() not in seen:
            seen.add(node.get_id())
            todo.extend(node.children())
    return len(seen)


@pytest.fixture
def queries(monkeypatch: pytest.MonkeyPatch) -> Iterator[list[int]]:
    """A one-element list holding the number of solver queries made since the test started."""
    count = [0]
    check = Solver.check

    def counted(self: Solver, formula: z3.BoolRef) -> str:
        count[0] += 1
        return check(self, formula)

    monkeypatch.setattr(Solver, "check", counted)
    yield count


def work(queries: list[int], tmp_path: Path, n: int, style: str, semantics: str, n_inputs: int) -> int:
    """Solver queries made by `check` and (for a first-match machine) by codegen's IR."""
    before = queries[0]
    spec = tmp_path / f"wide{n}.toml"
    spec.write_text(wide_spec(n, style, semantics, n_inputs), encoding="utf-8")
    loaded = load_spec(spec, compare=False)
    check_all(loaded.machine)
    if semantics == "first-match":
        machine_ir(loaded, tmp_path / "generated")
    return queries[0] - before


@pytest.mark.parametrize(
    ("style", "semantics", "n_inputs"),
    [("shadowed", "first-match", 5), ("cubes", "first-match", 9), ("cubes", "any-enabled", 9)],
)
def test_queries_grow_linearly(queries: list[int], tmp_path: Path, style: str, semantics: str, n_inputs: int) -> None:
    small = work(queries, tmp_path, 200, style, semantics, n_inputs)
    large = work(queries, tmp_path, 400, style, semantics, n_inputs)
    assert large <= 2.2 * small, (small, large)


@pytest.mark.parametrize("style", ["shadowed", "cubes"])
def test_first_match_conditions_do_not_grow_with_the_chain(style: str) -> None:
    def largest(n: int) -> int:
        checker = Checker(wide(n, style, n_inputs=8))
        return max(dag_size(m.cond) for m in checker.enc.moves["A"])

    small, large = largest(200), largest(400)
    assert large <= small + 8 * 3, (small, large)


@pytest.mark.slow
def test_two_thousand_transitions_out_of_one_state(tmp_path: Path) -> None:
    spec = tmp_path / "wide.toml"
    spec.write_text(wide_spec(2000), encoding="utf-8")
    loaded = load_spec(spec, compare=False)
    results = {r.prop: r for r in check_all(loaded.machine)}
    assert all(results[f"fires:t{k}"].verdict == "holds" for k in range(5))
    assert results["fires:t1999"].verdict == "violated"
    assert results["fires:t1999"].detail == "never fires: in A it is shadowed by t0, t1, t2, t3, t4"
    ir = machine_ir(loaded, tmp_path / "generated")
    branches = ir.cases[0].branches
    assert len(branches) == 2000 and branches[0].transition == "t0"


def test_a_long_chain_over_many_inputs_is_refused_in_one_line() -> None:
    machine = wide(MAX_WRITTEN_OUT + 1, "cubes", n_inputs=MAX_TABLE_INPUTS)
    with pytest.raises(SpecError, match=r"state A has \d+ transitions whose guards read 17 inputs"):
        Checker(machine)
