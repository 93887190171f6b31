"""Every bound is checked on its value, not its spelling: a bounded response's `within` over every param value,
literals' digits, chains of definitions; and boolean `==`/`!=` in the symbolic engine."""

from __future__ import annotations

import pytest

from mlca_verify.errors import SpecError
from mlca_verify.logic import check_all
from mlca_verify.spec import load_text
from tests.conftest import ROOT

SPEC = """
[machine]
name = "b"
initial = "A"
states = ["A", "B", "C"]
[params]
K = {{ type = "int", default = 3, range = [1, 10], doc = "k" }}
[inputs]
X = {{ doc = "x" }}
Y = {{ doc = "y" }}
[variables]
n = {{ type = "int", initial = 0, range = [0, 5], every = "min(n + 1, 5)", doc = "n" }}
[definitions]
{definitions}
[[transition]]
from = "A"
to = "B"
when = "{guard}"
[[transition]]
from = "B"
to = "C"
when = "X != Y"
[[liveness]]
id = "leave-b"
assume = "X != Y"
goal = "state != B"
within = {within}
"""


def _load(within: str = "1", guard: str = "X == Y", definitions: str = "") -> object:
    return load_text(SPEC.format(within=within, guard=guard, definitions=definitions), "b.toml")


@pytest.mark.parametrize(
    "within",
    [
        '"-5"',
        '"-K"',
        '"K - K"',
        '"100000000000000000000"',
        '"K * 100000"',
        '"K - 3"',
        '"min(K, 0)"',
        '"100001 + 0 * K"',
    ],
)
def test_a_bound_outside_one_to_a_hundred_thousand_for_some_param_value_is_refused(within: str) -> None:
    with pytest.raises(SpecError, match=r"b.toml:\d+:\d+: error: 'within' must be from 1 to 100000 steps for every"):
        _load(within)


@pytest.mark.parametrize("within", ['"K"', '"K + 990"', '"max(K - 5, 1)"', '"100 * K"', "1000"])
def test_a_bound_within_one_to_a_thousand_for_every_param_value_loads(within: str) -> None:
    _load(within)


def test_a_literal_of_thousands_of_digits_is_an_error_at_its_column() -> None:
    with pytest.raises(SpecError, match=r"has more than 40 digits"):
        _load(guard="X and n < " + "9" * 5001)


def test_a_long_chain_of_definitions_is_an_error_not_a_recursion() -> None:
    chain = (
        "\n".join(f'c{k} = {{ expr = "c{k + 1} + 1", doc = "d" }}' for k in range(300))
        + '\nc300 = { expr = "n", doc = "d" }'
    )
    with pytest.raises(SpecError, match=r"ends a chain of 65 definitions each reading the next \(at most 64\)"):
        _load(guard="c0 > 3", definitions=chain)


def test_boolean_equality_is_decided_by_the_symbolic_engine() -> None:
    results = {r.prop: r for r in check_all(_load())}  # type: ignore[arg-type]
    assert results["fires:t1"].verdict == "holds" and results["fires:t2"].verdict == "holds"
    assert results["leave-b"].verdict == "holds"
    assert results["reach:C"].detail == "reached in 2 steps"


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["check", "spec/mlca_r.toml", "--depth", "0"], "--depth: must be from 1 to 1000, got 0"),
        (["check", "spec/mlca_r.toml", "--depth", "-1"], "--depth: must be from 1 to 1000, got -1"),
        (["check", "spec/mlca_r.toml", "--depth", "1e23"], "--depth: not a whole number: '1e23'"),
        (["check", "spec/mlca_r.toml", "--depth", "1001"], "--depth: must be from 1 to 1000, got 1001"),
        (["check", "spec/mlca_r.toml", "--timeout-ms", "0"], "--timeout-ms: must be from 1 to 3600000, got 0"),
        (["check", "spec/mlca_r.toml", "--timeout-ms", "-1"], "--timeout-ms: must be from 1 to 3600000, got -1"),
        (["diff", "spec/mlca.toml", "spec/mlca_r.toml", "--timeout-ms", "1e23"], "--timeout-ms: not a whole number"),
        (["tests", "spec/mlca.toml", "--out", "x", "--depth", "0"], "--depth: must be from 1 to 1000, got 0"),
        (["conform", "spec/mlca.toml", "--sequences", "0"], "--sequences: must be from 1 to 100000, got 0"),
    ],
)
def test_every_numeric_argument_is_checked_with_one_line_and_exit_2(
    argv: list[str], message: str, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    from mlca_verify.cli import main

    monkeypatch.chdir(ROOT)
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize("address", ["", " ", "host", "host:port", "a b:1", "h:1;rm"])
def test_a_ray_address_that_is_no_address_is_refused(address: str, capsys: pytest.CaptureFixture[str]) -> None:
    from sim_check.cli import main

    assert main(["sweep", "--ray", address, "--runs", "1"]) == 2
    assert "--ray: not a Ray address" in capsys.readouterr().err
