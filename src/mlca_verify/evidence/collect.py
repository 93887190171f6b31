"""Collect the safety-case evidence for one machine: proofs, conformance of the generated code, tool versions,
hashes, traceability, readings of the source side by side, and a GSN-style argument over all of it.

Everything collected is deterministic for the same inputs (no durations, sorted goal lists, fixed seeds); the
one timestamp is `generated_at`, which SOURCE_DATE_EPOCH fixes too.
"""

from __future__ import annotations

import hashlib
import sys
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import z3

from mlca_verify import __version__
from mlca_verify.codegen import machine_ir
from mlca_verify.codegen.render import TEMPLATE_DIR, TEMPLATES
from mlca_verify.conform import CHECKS, conform
from mlca_verify.conform.checks import CheckOutcome
from mlca_verify.diagram import to_dot
from mlca_verify.errors import ToolError
from mlca_verify.evidence.page import anchor
from mlca_verify.logic import check_all, compare
from mlca_verify.logic.results import Outcome, Result
from mlca_verify.model import Machine, show
from mlca_verify.report import cube_text
from mlca_verify.spec import LoadedSpec, load_spec
from mlca_verify.targets import FILES, Layout
from mlca_verify.tools import run

TOOL_VERSIONS = {
    "gcc": ["gcc", "--version"],
    "frama-c": ["frama-c", "-version"],
    "why3": ["why3", "--version"],
    "z3 (prover for Frama-C WP)": ["z3", "--version"],
    "cppcheck": ["cppcheck", "--version"],
    "arm-none-eabi-gcc": ["arm-none-eabi-gcc", "--version"],
    "graphviz": ["dot", "-V"],
}


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def tool_versions() -> dict[str, str]:
    versions = {
        "mlca-verify": __version__,
        "python": sys.version.split()[0],
        "z3 (Python, proofs of the spec)": z3.get_version_string(),
    }
    for name, command in TOOL_VERSIONS.items():
        try:
            versions[name] = run(command, timeout=60).output.strip().splitlines()[0]
        except ToolError:
            versions[name] = "not installed"
    return versions


@dataclass(frozen=True)
class ClosedLoopRuns:
    """The closed-loop runs of one machine's generated controllers (see `loop_controllers`) in a results
    database written by `mlca-sim`, as its API counts them: the evidence takes them as data."""

    db: Path
    runs: int
    failed_runs: int
    monitor_violations: int


def loop_controllers(spec: LoadedSpec) -> tuple[str, str]:
    """The mlca-sim controllers that drive with the code generated from `spec`: its Python and its C."""
    module = spec.machine.name.lower()
    return f"{module}-py", f"{module}-c"


@dataclass
class Evidence:
    spec: LoadedSpec
    results: list[Result]
    outcomes: list[CheckOutcome]
    generated: Path
    readings: list[LoadedSpec]
    generated_at: str
    loop: dict[str, Any] = field(default_factory=dict)  # closed_loop() of the runs given, read once
    data: dict[str, Any] = field(default_factory=dict)

    @property
    def ok(self) -> bool:
        loop_ok = self.loop.get("status") != "failed"
        return all(r.ok for r in self.results) and all(o.ok for o in self.outcomes) and loop_ok


def collect(
    spec: LoadedSpec, readings: list[str], generated: Path, runs: ClosedLoopRuns | None, generated_at: str
) -> Evidence:
    """Prove, check conformance and assemble the evidence for `spec`, with its closed-loop `runs` (None: no
    results database given) read beforehand."""
    loaded_readings = [load_spec(p, compare=False) for p in readings]
    loop = closed_loop(runs, spec.machine.name.lower())  # every input read before the long work starts
    results = check_all(spec.machine)
    outcomes = conform(spec, generated, list(CHECKS), lambda _: None).outcomes
    ev = Evidence(spec, results, outcomes, generated, loaded_readings, generated_at)
    ev.loop = loop
    ev.data = document(ev)
    return ev


# --- the JSON document ------------------------------------------------------------------------------------


def document(ev: Evidence) -> dict[str, Any]:
    return {
        "schema": "mlca-verify.evidence/1",
        "generated_at": ev.generated_at,
        "spec": {
            "path": ev.spec.path,
            "sha256": ev.spec.sha256,
            "machine": ev.spec.machine.name,
            "cite": ev.spec.machine.cite,
        },
        "ok": ev.ok,
        "tools": tool_versions(),
        "inputs": inputs(ev),
        "artifacts": artifacts(ev),
        "proofs": [proof(r) for r in ev.results],
        "conformance": [{"name": o.name, "ok": o.ok, "detail": o.detail, "data": o.data} for o in ev.outcomes],
        "closed_loop": ev.loop,
        "traceability": traceability(ev),
        "readings": readings(ev),
        "argument": argument(ev),
    }


def proof(r: Result) -> dict[str, Any]:
    cx = r.counterexample.to_json() if r.counterexample else None
    return {
        "property": r.prop,
        "kind": r.kind,
        "verdict": r.verdict,
        "expected": r.expected,
        "ok": r.ok,
        "cite": r.cite,
        "detail": r.detail,
        "counterexample": cx,
    }


def _files(paths: list[Path]) -> list[dict[str, str]]:
    return [{"path": p.as_posix(), "sha256": sha256(p)} for p in sorted(set(paths))]


def inputs(ev: Evidence) -> list[dict[str, str]]:
    specs = [Path(ev.spec.path), *(Path(r.path) for r in ev.readings)]
    specs += [Path(c.other.loc.file) for c in ev.spec.machine.comparisons]
    templates = [TEMPLATE_DIR / name for name in TEMPLATES.values()]
    return _files([p for p in specs if p.is_file()]) + [
        {"path": f"templates/{p.name}", "sha256": sha256(p)} for p in sorted(templates)
    ]


def generated_files(ev: Evidence) -> dict[str, Path]:
    layout = Layout(ev.generated, machine_ir(ev.spec, ev.generated).module)
    return {kind: ev.generated / layout.relative(kind) for kind in FILES}


def artifacts(ev: Evidence) -> list[dict[str, str]]:
    return [{"kind": kind, "path": p.as_posix(), "sha256": sha256(p)} for kind, p in generated_files(ev).items()]


def closed_loop(runs: ClosedLoopRuns | None, module: str) -> dict[str, Any]:
    """The closed-loop section: monitor results of this machine's runs, and the hash of the database they are
    from."""
    if runs is None:
        return {"status": "undeveloped", "detail": "no results database given (--db)"}
    ok = runs.runs and runs.monitor_violations == 0 and runs.failed_runs == 0
    detail = (
        f"{runs.runs} closed-loop runs of {module}, {runs.failed_runs} failed, {runs.monitor_violations} monitor "
        "violations"
    )
    return {
        "status": "ok" if ok else "failed",
        "db": runs.db.as_posix(),
        "sha256": sha256(runs.db),
        "runs": runs.runs,
        "failed_runs": runs.failed_runs,
        "monitor_violations": runs.monitor_violations,
        "detail": detail,
    }


# --- traceability -----------------------------------------------------------------------------------------


def _lines(path: Path, needle: str) -> list[int]:
    return [n for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if needle in line]


def traceability(ev: Evidence) -> list[dict[str, Any]]:
    m = ev.spec.machine
    verdicts = {r.prop: r for r in ev.results}
    files = generated_files(ev)
    rows = []
    elements: list[tuple[str, str, str, str, str]] = []  # element, text, cite, property, code needle
    for t in m.transitions:
        source = "*" if t.sources is None else ", ".join(t.sources)
        text = f"{source} -> {t.target} when {show(t.guard)}"
        elements.append((f"transition {t.id}", text, t.cite, f"fires:{t.id}", f"{t.id}: "))
    elements += [(f"invariant {i.id}", show(i.expr), i.cite, i.id, f"{i.id}: ") for i in m.invariants]
    for p in m.liveness:
        text = f"assume {show(p.assume)}; goal {show(p.goal)}" + (f" within {p.within}" if p.within else "")
        elements.append((f"liveness {p.id}", text, p.cite, p.id, ""))
    for element, text, cite, prop, needle in elements:
        r = verdicts[prop]
        code = []
        if needle:
            for kind in ("c-source", "python"):
                code += [{"file": files[kind].as_posix(), "line": n} for n in _lines(files[kind], needle)]
        tests = ["conform: exhaustive", "conform: sequences", "conform: frama-c-wp"] if needle else []
        if r.verdict == "violated" and prop == r.prop and r.kind in ("invariant", "liveness"):
            tests.append("check --emit-tests: replays the counterexample")
        rows.append(
            {
                "cite": cite,
                "element": element,
                "text": text,
                "property": prop,
                "verdict": r.verdict,
                "expected": r.expected,
                "ok": r.ok,
                "code": code,
                "tests": tests,
            }
        )
    return rows


# --- the paper's readings, side by side -------------------------------------------------------------------


def readings(ev: Evidence) -> dict[str, Any]:
    if not ev.readings:
        return {"canonical": None, "machines": []}
    canonical = ev.readings[0].machine
    machines = []
    for reading in ev.readings:
        m = reading.machine
        regions = compare(canonical, m, all_regions=True).regions if m is not canonical else []
        marked = frozenset((r.state, o.transition) for r in regions for o in (*r.left, *r.right) if o.transition)
        ours = frozenset((s, t) for s, t in marked if any(x.id == t for x in m.transitions))
        machines.append(
            {
                "path": reading.path,
                "machine": m.name,
                "cite": m.cite,
                "semantics": m.semantics,
                "otherwise": m.otherwise,
                "dot": to_dot(m, ours),
                "differences": [
                    {
                        "state": r.state,
                        "when": cube_text(r.cube),
                        "canonical": [_outcome(o) for o in r.left],
                        "this": [_outcome(o) for o in r.right],
                    }
                    for r in regions
                ],
            }
        )
    return {"canonical": canonical.name, "machines": machines}


def _outcome(o: Outcome) -> str:
    return "no transition" if o.transition is None else f"{o.transition} -> {o.next}"


# --- the argument -----------------------------------------------------------------------------------------


def argument(ev: Evidence) -> list[dict[str, Any]]:
    """GSN nodes: goals, strategies, solutions (each linking to its artifact), contexts, undeveloped goals."""
    m: Machine = ev.spec.machine
    by_name = {o.name: o for o in ev.outcomes}
    nodes: list[dict[str, Any]] = []

    def node(nid: str, kind: str, text: str, parent: str | None, ok: bool | None = None, *, link: str = "") -> None:
        nodes.append({"id": nid, "type": kind, "text": text, "parent": parent, "ok": ok, "link": link or None})

    node(
        "G1",
        "goal",
        f"The generated controller for {m.name} ({ev.spec.path}) meets its specified properties",
        None,
        ev.ok,
    )
    node("C1", "context", f"Spec {ev.spec.path}, sha256 {ev.spec.sha256}, source: {m.cite}", "G1", link="#inputs")
    node("S1", "strategy", "Argue over the specification, the generated code, and closed-loop behaviour", "G1")
    node(
        "G2",
        "goal",
        "Every built-in check and declared property of the spec has its expected verdict (z3 proofs)",
        "S1",
        all(r.ok for r in ev.results),
    )
    for k, r in enumerate(ev.results, 1):
        node(
            f"Sn2.{k}",
            "solution",
            f"{r.prop} ({r.kind}): {r.verdict}, expected {r.expected}",
            "G2",
            r.ok,
            link=f"#proof-{anchor(r.prop)}",
        )
    node(
        "G3", "goal", "The generated code is the code of this spec and these templates", "S1", by_name["up-to-date"].ok
    )
    node("Sn3.1", "solution", by_name["up-to-date"].detail, "G3", by_name["up-to-date"].ok, link="#artifacts")
    node("G4", "goal", "The generated C implements the spec", "S1", all(by_name[n].ok for n in CHECKS))
    node(
        "S4",
        "strategy",
        "Formal proof of the C against contracts stating the spec, backed by exhaustive and sanitized testing",
        "G4",
    )
    for k, name in enumerate(CHECKS, 1):
        node(
            f"Sn4.{k}",
            "solution",
            f"{name}: {by_name[name].detail.splitlines()[0]}",
            "S4",
            by_name[name].ok,
            link=f"#check-{name}",
        )
    node(
        "G5",
        "goal",
        "The generated Python implements the spec",
        "S1",
        by_name["exhaustive"].ok and by_name["sequences"].ok,
    )
    node("Sn5.1", "solution", by_name["exhaustive"].detail, "G5", by_name["exhaustive"].ok, link="#check-exhaustive")
    node("Sn5.2", "solution", by_name["sequences"].detail, "G5", by_name["sequences"].ok, link="#check-sequences")
    loop = ev.loop
    if loop["status"] == "undeveloped":
        node(
            "G6",
            "undeveloped",
            "Closed-loop runs in traffic show no runtime-monitor violation (no results database given)",
            "S1",
        )
    else:
        node(
            "G6", "goal", "Closed-loop runs in traffic show no runtime-monitor violation", "S1", loop["status"] == "ok"
        )
        node("Sn6.1", "solution", loop["detail"], "G6", loop["status"] == "ok", link="#closed-loop")
    return nodes
