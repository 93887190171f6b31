"""The JSON Schema of the spec format (`mlca-verify schema`, shipped as mlca_verify/spec/spec.schema.json): every
spec in the repository validates against it, and on documents changed at random it refuses exactly what the
loader's shape stage refuses, so an editor that reads it flags the mistakes `load_spec` would report first."""

from __future__ import annotations

import copy
import re
import shlex
import tomllib
from pathlib import Path
from typing import Any

import jsonschema
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mlca_verify.cli import main
from mlca_verify.errors import Loc, SpecError
from mlca_verify.model import Machine
from mlca_verify.spec import load_text
from mlca_verify.spec.locate import Locator
from mlca_verify.spec.names import MAX_ELEMENTS
from mlca_verify.spec.network import MAX_INSTANCES, NetworkLoader, is_network
from mlca_verify.spec.schema import SCHEMA_NAME, schema_text, spec_schema
from mlca_verify.spec.shape import ShapeChecker
from tests.conftest import ROOT

SHIPPED = ROOT / "src" / "mlca_verify" / "spec" / SCHEMA_NAME
SPECS = sorted(
    p
    for folder in ("spec", "tests/machines", "tests/public", "tests/fixtures", "tests/corpus", "docs")
    for p in (ROOT / folder).rglob("*.toml")
)


def _strict_types() -> jsonschema.TypeChecker:
    """TOML tells 3 from 3.0 as the loader does, and so do editors (Taplo): an integer is not a float, however
    round. JSON Schema's own checker would take 3.0 as an integer."""
    base = jsonschema.Draft7Validator.TYPE_CHECKER
    return base.redefine("integer", lambda _, v: isinstance(v, int) and not isinstance(v, bool))


VALIDATOR = jsonschema.validators.extend(jsonschema.Draft7Validator, type_checker=_strict_types())(spec_schema())


def _no_instance(path: str, loc: Loc) -> Machine:
    raise AssertionError("the shape stage loads no instance")


def shape_ok(doc: dict[str, Any]) -> bool:
    """The loader's first stage accepts the document: a network's (spec/network.py) or a machine's (shape.py)."""
    try:
        if is_network(doc):
            NetworkLoader(doc, Locator("x.toml", ""), _no_instance).shape()
        else:
            ShapeChecker(doc, Locator("x.toml", "")).check()
    except SpecError:
        return False
    return True


def test_the_shipped_schema_is_the_one_the_package_builds() -> None:
    assert SHIPPED.read_text(encoding="utf-8") == schema_text(), "run `mlca-verify schema --out " + str(SHIPPED) + "`"
    jsonschema.Draft7Validator.check_schema(spec_schema())


def test_the_command_writes_the_schema(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["schema"]) == 0
    assert capsys.readouterr().out == schema_text()
    assert main(["schema", "--out", str(tmp_path / "s.json")]) == 0
    assert (tmp_path / "s.json").read_text(encoding="utf-8") == schema_text()


def test_every_spec_of_the_repository_is_judged_alike() -> None:
    """The shipped specs (machines and networks), the corpus, the public models, the tutorial's: the schema accepts
    every one the shape stage accepts (all but the fixtures made to be refused), and refuses the others."""
    accepted = networks = 0
    for path in SPECS:
        try:
            doc = tomllib.loads(path.read_text(encoding="utf-8"))
        except (tomllib.TOMLDecodeError, UnicodeDecodeError):
            continue
        assert VALIDATOR.is_valid(doc) == shape_ok(doc), path
        accepted += VALIDATOR.is_valid(doc)
        networks += VALIDATOR.is_valid(doc) and is_network(doc)
    assert accepted >= 50 and networks >= 4


def test_the_editor_completes_keys_with_their_meaning() -> None:
    schema = spec_schema()
    machine = schema["properties"]["machine"]["properties"]  # type: ignore[index]
    assert "first-match" in machine["semantics"]["description"]  # type: ignore[index]
    transition = schema["properties"]["transition"]["items"]  # type: ignore[index]
    assert transition["required"] == ["from", "to", "when"]  # type: ignore[index]
    assert transition["additionalProperties"] is False  # type: ignore[index]


def test_too_many_entries_are_refused_by_both() -> None:
    doc = _documents()[0]
    doc["invariant"] = [{"id": f"i{k}", "expr": "true"} for k in range(MAX_ELEMENTS + 1)]
    assert not shape_ok(doc) and not VALIDATOR.is_valid(doc)
    net = tomllib.loads((ROOT / "spec" / "v2v" / "gap_repaired.toml").read_text(encoding="utf-8"))
    net["instances"] |= {f"X{k}": {"spec": "mlca_t_claim.toml"} for k in range(MAX_INSTANCES)}
    assert not shape_ok(net) and not VALIDATOR.is_valid(net)


def test_a_network_and_a_machine_do_not_mix() -> None:
    """A [network] table makes a network spec, whose tables are its own: a machine's [machine] in it is refused, and
    so are a network's [[channel]] or [instances] in a machine spec."""
    net = tomllib.loads((ROOT / "spec" / "v2v" / "gap_repaired.toml").read_text(encoding="utf-8"))
    machine = tomllib.loads((ROOT / "spec" / "mlca_t.toml").read_text(encoding="utf-8"))
    assert VALIDATOR.is_valid(net) and VALIDATOR.is_valid(machine)
    for mixed in ({**net, "machine": machine["machine"]}, {**machine, "channel": net["channel"]}):
        assert not shape_ok(mixed) and not VALIDATOR.is_valid(mixed)
    assert not shape_ok({k: v for k, v in net.items() if k != "instances"})
    assert not VALIDATOR.is_valid({k: v for k, v in net.items() if k != "instances"})


def _documents() -> list[dict[str, Any]]:
    names = ("spec/mlca_t.toml", "spec/mlca.toml", "tests/machines/acc_modes_50hz.toml", "docs/tutorial/stairwell.toml")
    names += ("spec/v2v/gap_repaired.toml", "spec/v2v/gap_in_turn.toml")
    return [tomllib.loads((ROOT / n).read_text(encoding="utf-8")) for n in names]


DOCUMENTS = _documents()
VALUES: list[object] = [
    True,
    3,
    3.0,
    2.5,
    "s",
    [],
    [1, 2],
    [1.5, 2, 3],
    ["a", "b"],
    [True, 1],
    {},
    {"k": "v"},
    [{"a": 1}],
]


def _paths(value: object, path: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    found = [path]
    if isinstance(value, dict):
        for k, v in value.items():
            found += _paths(v, (*path, k))
    elif isinstance(value, list):
        for k, v in enumerate(value):
            found += _paths(v, (*path, k))
    return found


def _mutate(doc: dict[str, Any], path: tuple[str | int, ...], op: str, value: object) -> None:
    """Change the document at `path`: drop what is there, put another value there, or add an unknown key."""
    if not path:
        doc["unknown"] = value
        return
    parent: Any = doc
    for step in path[:-1]:
        parent = parent[step]
    last = path[-1]
    if op == "drop":
        del parent[last]
    elif op == "add" and isinstance(parent[last], dict):
        parent[last]["unknown_key"] = value
    else:
        parent[last] = value


@settings(max_examples=300, deadline=None)
@given(st.data())
def test_the_schema_refuses_what_the_shape_stage_refuses(data: st.DataObject) -> None:
    doc = copy.deepcopy(data.draw(st.sampled_from(DOCUMENTS)))
    for _ in range(data.draw(st.integers(1, 2))):
        paths = _paths(doc)
        path = data.draw(st.sampled_from(paths))
        op = data.draw(st.sampled_from(["drop", "set", "add"]))
        _mutate(doc, path, op, copy.deepcopy(data.draw(st.sampled_from(VALUES))))
    assert VALIDATOR.is_valid(doc) == shape_ok(doc), doc


PAGE = ROOT / "docs" / "reference" / "spec-schema.md"


def test_the_reference_page_shows_what_works(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    """The page's command writes the schema; its spec with a `#:schema` line loads and validates; its `.taplo.toml`
    names the schema for the project's specs."""
    text = PAGE.read_text(encoding="utf-8")
    (command,) = re.findall(r"```console\n\$ (.*?)\n```", text)
    monkeypatch.chdir(tmp_path)
    assert main(shlex.split(command)[1:]) == 0
    assert (tmp_path / "spec.schema.json").read_text(encoding="utf-8") == schema_text()
    spec, taplo = re.findall(r"```toml\n(.*?)```", text, re.DOTALL)
    assert spec.startswith("#:schema ./spec.schema.json\n")
    assert load_text(spec, "lamp.toml").name == "Lamp" and VALIDATOR.is_valid(tomllib.loads(spec))
    rule = tomllib.loads(taplo)["rule"][0]
    assert rule["schema"]["path"] == "./spec.schema.json" and rule["include"] == ["spec/**/*.toml"]
