"""The house has no circles: every import of the library goes down its layers, no module imports itself back
through another, the library never imports the simulator, the benchmarks or the tests, and the engine never
imports the loader. Imports are read from the source (including those inside functions and under
TYPE_CHECKING), so a lazy import cannot hide a cycle."""

from __future__ import annotations

import ast
from collections.abc import Iterator
from pathlib import Path

from tests.conftest import ROOT

# Each unit of the library (a top-level module or subpackage of mlca_verify) and its layer: a unit may import
# only units of lower layers. A new unit must be placed here.
LAYERS: tuple[frozenset[str], ...] = tuple(
    frozenset(names.split())
    for names in (
        "escape version words json_types floats lazy",
        "errors",
        "files tools model layout",
        "network",
        "intervals cli_base",
        "spec logic statechart",  # the loader and the engine: neither imports the other
        "diagram spec_diff",
        "check_report network_report waves codegen",
        "ci_formats loading network_chart network_diff",
        "conformance regression_tests",
        "testgen",
        "evidence",
        "report_schemas",  # the reports' JSON Schemas, from the names their writers use
        "cli",
        "__main__",
    )
)
TIER = {unit: k for k, names in enumerate(LAYERS) for unit in names}
TREES = {"mlca_verify": ROOT / "src" / "mlca_verify", "sim_check": ROOT / "sim_check", "bench": ROOT / "bench"}


def _modules() -> dict[str, Path]:
    found: dict[str, Path] = {}
    for top, folder in TREES.items():
        for path in folder.rglob("*.py"):
            if "shipped" in path.relative_to(folder).parts:  # links to the generated code, not modules
                continue
            parts = (top, *path.relative_to(folder).with_suffix("").parts)
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            found[name] = path
    return found


def _imports(path: Path, name: str, known: dict[str, Path]) -> Iterator[str]:
    """Every module `path` imports, resolved as Python would: `from a import b` is `a.b` when that is a module."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            yield from (a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                anchor = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                base = f"{anchor}.{base}" if base else anchor
            for a in node.names:
                yield f"{base}.{a.name}" if f"{base}.{a.name}" in known else base


def _graph() -> dict[str, set[str]]:
    known = _modules()
    tops = ("mlca_verify", "sim_check", "bench", "tests", "scripts")
    return {
        name: {t for t in _imports(path, name, known) if t.split(".")[0] in tops and t != name}
        for name, path in known.items()
    }


def _unit(module: str) -> str:
    parts = module.split(".")
    return parts[1] if parts[0] == "mlca_verify" and len(parts) > 1 else parts[0]


def _cycle(graph: dict[str, set[str]]) -> list[str]:
    """One import cycle among the modules, or [] (an iterative depth-first search)."""
    state: dict[str, int] = {}  # 1: on the current path, 2: done
    for root in sorted(graph):
        if root in state:
            continue
        path, todo = [root], [iter(sorted(graph[root]))]
        state[root] = 1
        while todo:
            step = next(todo[-1], None)
            if step is None:
                state[path.pop()] = 2
                todo.pop()
            elif state.get(step) == 1:
                return [*path[path.index(step) :], step]
            elif step not in state and step in graph:
                state[step] = 1
                path.append(step)
                todo.append(iter(sorted(graph[step])))
    return []


def test_no_module_imports_itself_back() -> None:
    assert _cycle(_graph()) == []


def test_the_cycle_finder_finds_a_cycle() -> None:
    assert _cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": set()}) == ["a", "b", "c", "a"]
    assert _cycle({"a": {"b"}, "b": set()}) == []


def test_every_import_of_the_library_goes_down_its_layers() -> None:
    wrong = []
    for module, targets in _graph().items():
        if not module.startswith("mlca_verify."):
            continue
        unit = _unit(module)
        assert unit in TIER, f"{module}: place the unit {unit!r} in LAYERS"
        for target in targets:
            if target == "mlca_verify":
                wrong.append(f"{module} imports the package's face (import the module that defines the name)")
            elif not target.startswith("mlca_verify."):
                wrong.append(f"{module} imports {target}: the library imports none of its consumers")
            elif _unit(target) != unit and TIER.get(_unit(target), 99) >= TIER[unit]:
                wrong.append(
                    f"{module} ({unit}, layer {TIER[unit]}) imports {target} (layer {TIER.get(_unit(target))})"
                )
    assert wrong == []


def test_the_consumers_keep_to_their_side() -> None:
    graph = _graph()
    wrong = [
        f"{module} imports {target}"
        for module, targets in graph.items()
        for target in targets
        if (module.startswith(("sim_check", "bench")) and target == "mlca_verify")
        or (module.startswith("sim_check") and target.startswith(("bench", "tests", "scripts")))
        or (module.startswith("bench") and target.startswith("tests"))
    ]
    assert wrong == []
    assert any(t.startswith("mlca_verify.") for t in graph["sim_check.runner"])  # the walk sees real imports


def test_one_place_writes_an_errors_location() -> None:
    """`errors.located` writes `where: error: message`; every error of a file, a spec element, a folder or a
    database is made through it (`SomeError.at(where, message)`), so each location is made one line alike."""
    written = [
        f"{path.relative_to(ROOT)}:{number}"
        for folder in (TREES["mlca_verify"], TREES["sim_check"])
        for path in folder.rglob("*.py")
        if path.name != "errors.py" and "shipped" not in path.parts
        for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1)
        if "}: error: " in line or ': error: "' in line
    ]
    assert written == []
