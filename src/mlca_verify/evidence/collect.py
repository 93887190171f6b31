"""Collect the safety-case evidence for one machine: proofs, conformance of the generated code, tool versions,
hashes, traceability, readings of the source side by side, and a GSN-style argument over all of it.

For a machine with data (params, signals, variables) the bundle also holds the proofs' engines and certificates,
the params, signals, variables, definitions and outputs, and the environment assumptions the proofs rely on.

Everything collected is deterministic for the same inputs (no durations, sorted goal lists, fixed seeds); the
one timestamp is `generated_at`, which SOURCE_DATE_EPOCH fixes too.
"""

from __future__ import annotations

import hashlib
import sys
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from pathlib import Path
from typing import Any

import z3

from mlca_verify.check_report import cube_text
from mlca_verify.codegen import machine_ir
from mlca_verify.codegen.render import CERTIFIED_TEMPLATE, SHARED_TEMPLATES, TEMPLATE_DIR, TEMPLATES
from mlca_verify.conformance import CHECKS, conform
from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.diagram import to_dot
from mlca_verify.errors import ToolError
from mlca_verify.evidence import coverage, physics
from mlca_verify.evidence.page import anchor
from mlca_verify.evidence.runs import ClosedLoopRuns
from mlca_verify.layout import FILES, Layout
from mlca_verify.logic import check_all, compare
from mlca_verify.logic.lemmas import named
from mlca_verify.logic.results import Outcome, Result
from mlca_verify.model import BinOp, Machine, Range, StateIn, Type, show, show_number
from mlca_verify.spec import LoadedSpec, load_spec
from mlca_verify.spec.types import show_unit
from mlca_verify.tools import run
from mlca_verify.version import __version__

EVIDENCE_SCHEMA = "mlca-verify.evidence/1"  # the schema string of evidence.json
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
class Evidence:
    """Everything collected for one spec, built once (`collect`) and not changed after: its JSON document
    (`data`) is made from it when first asked for."""

    spec: LoadedSpec
    results: list[Result]
    outcomes: list[CheckOutcome]
    generated: Path
    readings: list[LoadedSpec]
    generated_at: str
    loop: dict[str, Any] = field(default_factory=dict)  # closed_loop() of the runs given, read once
    replay: dict[str, Any] | None = None  # `mlca-sim replay --json` of lemma counterexamples, checked, if given
    physics: dict[str, Any] = field(default_factory=dict)  # physics.section(), for a spec with lemmas
    smt2: dict[str, str] = field(default_factory=dict)  # bundle path -> each lemma's SMT-LIB query, made once
    coverage: dict[str, Any] = field(default_factory=dict)  # coverage.section() of the generated suite, if run

    @cached_property
    def data(self) -> dict[str, Any]:
        """The evidence's JSON document."""
        return document(self)

    @property
    def ok(self) -> bool:
        loop_ok = self.loop.get("status") != "failed"
        results_ok = all(r.ok for r in self.results) and all(o.ok for o in self.outcomes)
        data_ok = parametric_ok(self)
        tests_ok = self.coverage.get("status") != "failed"
        return results_ok and loop_ok and data_ok and tests_ok and (not self.physics or physics_ok(self.physics))


def collect(
    spec: LoadedSpec,
    readings: list[str],
    generated: Path,
    runs: ClosedLoopRuns | None,
    generated_at: str,
    *,
    replay: dict[str, Any] | None = None,
    tests_out: Path | None = None,
) -> Evidence:
    """Prove, check conformance and assemble the evidence for `spec`, with its closed-loop `runs` (None: no
    results database given) and the SUMO `replay` of its lemmas' counterexamples (checked by
    `physics.check_replay`), read beforehand; with `tests_out`, the requirements-based suite is generated there
    and its coverage measured."""
    loaded_readings = [load_spec(p, compare=False) for p in readings]
    transitions = tuple(t.id for t in spec.machine.transitions)
    loop = closed_loop(runs, spec.machine.name.lower(), transitions)  # every input read before the long work
    results = check_all(spec.machine)
    outcomes = conform(spec, generated, list(CHECKS), lambda _: None).outcomes
    smt2 = physics.smt2_files(spec.machine) if spec.machine.lemmas else {}
    physics_part = physics.section(spec.machine, spec.sha256, results, replay, smt2) if spec.machine.lemmas else {}
    tested: dict[str, Any] = {}
    if tests_out is not None:
        tested = coverage.section(coverage.run_suite(spec, generated, tests_out), loop, tests_out.parent)
    return Evidence(
        spec,
        results,
        outcomes,
        generated,
        loaded_readings,
        generated_at,
        loop=loop,
        replay=replay,
        physics=physics_part,
        smt2=smt2,
        coverage=tested,
    )


# --- the JSON document ------------------------------------------------------------------------------------


def document(ev: Evidence) -> dict[str, Any]:
    doc = {
        "schema": EVIDENCE_SCHEMA,
        "generated_at": ev.generated_at,
        "spec": {
            "path": ev.spec.path,
            "sha256": ev.spec.sha256,
            "machine": ev.spec.machine.name,
            "cite": ev.spec.machine.cite,
            "states": list(ev.spec.machine.states),
            "initial": ev.spec.machine.initial,
            "fallback": ev.spec.machine.fallback_state,
            "reals": ev.spec.machine.reals,
            "dot": to_dot(ev.spec.machine),
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
    doc["data_machine"] = data_machine(ev)
    if ev.physics:
        doc["physical_safety"] = ev.physics
    if ev.coverage:
        doc["test_coverage"] = ev.coverage
    return doc


def proof(r: Result) -> dict[str, Any]:
    cx = r.counterexample.to_json() if r.counterexample else None
    found = {
        "property": r.prop,
        "kind": r.kind,
        "verdict": r.verdict,
        "expected": r.expected,
        "ok": r.ok,
        "cite": r.cite,
        "detail": r.detail,
        "counterexample": cx,
    }
    if r.proof is not None:  # a machine with data: how it was decided
        found["proof"] = r.proof.to_json()
    if r.caveat:
        found["caveat"] = r.caveat
    return found


def files_json(paths: list[Path]) -> list[dict[str, str]]:
    return [{"path": p.as_posix(), "sha256": sha256(p)} for p in sorted(set(paths))]


def inputs(ev: Evidence) -> list[dict[str, str]]:
    specs = [Path(ev.spec.path), *(Path(r.path) for r in ev.readings)]
    specs += [Path(c.other.loc.file) for c in ev.spec.machine.comparisons]
    names = [*TEMPLATES.values(), CERTIFIED_TEMPLATE, *SHARED_TEMPLATES]
    templates = [TEMPLATE_DIR / name for name in names]
    return files_json([p for p in specs if p.is_file()]) + [
        {"path": f"templates/{p.name}", "sha256": sha256(p)} for p in sorted(templates)
    ]


def generatedfiles_json(ev: Evidence) -> dict[str, Path]:
    ir = machine_ir(ev.spec, ev.generated)
    layout = Layout(ev.generated, ir.module)
    return {kind: ev.generated / layout.relative(kind) for kind in FILES}


def artifacts(ev: Evidence) -> list[dict[str, str]]:
    return [{"kind": kind, "path": p.as_posix(), "sha256": sha256(p)} for kind, p in generatedfiles_json(ev).items()]


def closed_loop(runs: ClosedLoopRuns | None, module: str, transitions: tuple[str, ...] = ()) -> dict[str, Any]:
    """The closed-loop section: monitor results of this machine's runs, the hash of the database they are from,
    and (where the database records it) how often each of the spec's `transitions` fired in those runs."""
    if runs is None:
        return {"status": "undeveloped", "detail": "no closed-loop results given (--db)"}
    ok = runs.runs and runs.monitor_violations == 0 and runs.failed_runs == 0
    detail = (
        f"{runs.runs} closed-loop runs of {module}, {runs.failed_runs} failed, {runs.monitor_violations} monitor "
        "violations"
    )
    section: dict[str, Any] = {
        "status": "ok" if ok else "failed",
        "db": runs.db.as_posix(),
        "sha256": sha256(runs.db),
        "runs": runs.runs,
        "failed_runs": runs.failed_runs,
        "monitor_violations": runs.monitor_violations,
        "detail": detail,
    }
    if runs.transitions:
        fired = [{"transition": t, "fired": runs.transitions.get(t, 0)} for t in transitions]
        never = [t for t in transitions if not runs.transitions.get(t, 0)]
        section["transitions"] = fired
        section["coverage"] = f"{len(fired) - len(never)} of {len(fired)} transitions fired in the closed-loop runs" + (
            f" (never: {', '.join(never)})" if never else ""
        )
    return section


# --- a machine with data: its params, signals, variables, definitions, outputs and assumptions ---------------


def _number(value: Fraction, kind: Type) -> str:
    """A value exactly, as a spec would write it: a real always with its point, in decimals when it has a
    finite decimal expansion (0.1, not the float nearest it), else as a fraction."""
    if kind != "real" or value.denominator == 1:
        return show_number(value, kind == "real")
    digits = 0
    while (value * 10**digits).denominator != 1 and digits < 40:
        digits += 1
    scaled = value * 10**digits
    if scaled.denominator != 1:
        return show_number(value, True)
    sign, whole = ("-" if scaled < 0 else ""), str(abs(scaled.numerator)).rjust(digits + 1, "0")
    return f"{sign}{whole[:-digits]}.{whole[-digits:]}"


def _range(bounds: Range | None, kind: Type) -> list[str] | None:
    return None if bounds is None else [_number(bounds[0], kind), _number(bounds[1], kind)]


def data_machine(ev: Evidence) -> dict[str, Any]:
    """The data of a machine (none for a boolean one), in the spec's own syntax (numbers as exact text), and for each
    environment assumption the proofs that rely on it."""
    m = ev.spec.machine
    relied: dict[str, list[str]] = {a.id: [] for a in m.assumptions}
    for r in ev.results:
        for aid in r.proof.assumptions if r.proof else ():
            relied.setdefault(aid, []).append(r.prop)
    return {
        "step_s": None if m.step_s is None else _number(m.step_s, "real"),
        "params": [
            {
                "name": p.name,
                "type": p.type,
                "default": _number(p.default, p.type),
                "range": _range(p.range, p.type),
                "unit": show_unit(p.unit),
                "doc": p.doc,
                "cite": p.cite,
            }
            for p in m.params
        ],
        "signals": [
            {
                "name": s.name,
                "type": s.type,
                "unit": show_unit(s.unit),
                "range": _range(s.range, s.type),
                "doc": s.doc,
                "cite": s.cite,
            }
            for s in m.signals
        ],
        "variables": [
            {
                "name": v.name,
                "type": v.type,
                "initial": _number(v.initial, v.type),
                "range": _range(v.range, v.type),
                "unit": show_unit(v.unit),
                "every": None if v.every is None else show(v.every),
                "doc": v.doc,
                "cite": v.cite,
            }
            for v in m.variables
        ],
        "definitions": [
            {
                "name": d.name,
                "type": d.type,
                "expr": show(d.expr),
                "unit": show_unit(d.unit),
                "if_invalid": d.if_invalid if d.signals and d.type == "bool" else None,
                "signals": list(d.signals),
                "doc": d.doc,
                "cite": d.cite,
            }
            for d in m.definitions
        ],
        "outputs": [
            {
                "name": o.name,
                "type": o.type,
                "expr": show(o.expr),
                "unit": show_unit(o.unit),
                "range": _range(o.range, o.type),
                "signals": list(o.signals),
                "doc": o.doc,
                "cite": o.cite,
            }
            for o in m.outputs
        ],
        "assumptions": [
            {"id": a.id, "expr": show(a.expr), "doc": a.doc, "cite": a.cite, "relied_on_by": relied[a.id]}
            for a in m.assumptions
        ],
    }


def declared(ev: Evidence) -> list[Result]:
    """The results of the spec's declared invariants and liveness properties expected to hold, in file order."""
    m = ev.spec.machine
    ids = {p.id for p in m.invariants if p.expect == "holds"} | {p.id for p in m.liveness if p.expect == "holds"}
    return [r for r in ev.results if r.prop in ids and r.kind in ("invariant", "liveness")]


def declared_parametric(ev: Evidence) -> list[Result]:
    """The declared properties expected to hold that the spec claims for every param value in range
    (`parametric = true`); the others are claimed, and proved, at the params' defaults."""
    m = ev.spec.machine
    ids = {p.id for p in m.invariants if p.parametric} | {p.id for p in m.liveness if p.parametric}
    return [r for r in declared(ev) if r.prop in ids]


def parametric_ok(ev: Evidence) -> bool:
    """Every property declared parametric and expected to hold holds for every param value in range."""
    return all(r.ok and r.proof is not None and r.proof.parametric for r in declared_parametric(ev))


# --- traceability -----------------------------------------------------------------------------------------


def _lines(path: Path, needle: str) -> list[int]:
    return [n for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1) if needle in line]


def traceability(ev: Evidence) -> list[dict[str, Any]]:
    m = ev.spec.machine
    verdicts = {r.prop: r for r in ev.results}
    files = generatedfiles_json(ev)
    rows = []
    elements: list[tuple[str, str, str, str, str]] = []  # element, text, cite, property, code needle
    for t in m.transitions:
        source = "*" if t.sources is None else ", ".join(t.sources)
        text = f"{source} -> {t.target} when {show(t.guard)}"
        if t.updates:
            text += "; do " + ", ".join(f"{u.variable} = {show(u.expr)}" for u in t.updates)
        elements.append((f"transition {t.id}", text, t.cite, f"fires:{t.id}", f"{t.id}: "))
    elements += [(f"invariant {i.id}", show(i.expr), i.cite, i.id, f"{i.id}: ") for i in m.invariants]
    for p in m.liveness:
        text = f"assume {show(p.assume)}; goal {show(p.goal)}" + (f" within {p.within}" if p.within else "")
        if p.bound is not None:
            text += f" within {show(p.bound)}"
        elements.append((f"liveness {p.id}", text, p.cite, p.id, ""))
    for element, text, cite, prop, needle in elements:
        r = verdicts[prop]
        code = []
        code_tested = bool(needle)
        if code_tested:
            for kind in ("c-source", "python"):
                code += [{"file": files[kind].as_posix(), "line": n} for n in _lines(files[kind], needle)]
        tests = ["conform: exhaustive", "conform: sequences", "conform: frama-c-wp"] if code_tested else []
        replayed = ("invariant", "range", "liveness")  # what --emit-tests replays
        if r.verdict == "violated" and prop == r.prop and r.kind in replayed:
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


def proofs_goal(node: Callable[..., None], results: list[Result]) -> None:
    """G2: every check of the spec has its expected verdict, a solution per proof with how it was decided."""
    node(
        "G2",
        "goal",
        "Every built-in check and declared property of the spec has its expected verdict (z3 proofs)",
        "S1",
        all(r.ok for r in results),
    )
    for k, r in enumerate(results, 1):
        text = f"{r.prop} ({r.kind}): {r.verdict}, expected {r.expected}; {how_decided(r)}"
        node(f"Sn2.{k}", "solution", text, "G2", r.ok, link=f"#proof-{anchor(r.prop)}")


def code_goals(node: Callable[..., None], outcomes: list[CheckOutcome], checks: Iterable[str], first: int) -> None:
    """Three goals from G<first>: the generated code is the spec's, its C implements the spec (backed by every
    conformance check), its Python implements the spec (the exhaustive and sequence comparisons)."""
    by_name = {o.name: o for o in outcomes}
    g, c, py = (f"G{first + k}" for k in range(3))
    up = by_name["up-to-date"]
    node(g, "goal", "The generated code is the code of this spec and these templates", "S1", up.ok)
    node(f"Sn{first}.1", "solution", up.detail, g, up.ok, link="#artifacts")
    node(c, "goal", "The generated C implements the spec", "S1", all(by_name[n].ok for n in checks))
    node(
        f"S{first + 1}",
        "strategy",
        "Formal proof of the C against contracts stating the spec, backed by exhaustive and sanitized testing",
        c,
    )
    for k, name in enumerate(checks, 1):
        outcome = by_name[name]
        text = f"{name}: {outcome.detail.splitlines()[0]}"
        node(f"Sn{first + 1}.{k}", "solution", text, f"S{first + 1}", outcome.ok, link=f"#check-{name}")
    exhaustive, sequences = by_name["exhaustive"], by_name["sequences"]
    node(py, "goal", "The generated Python implements the spec", "S1", exhaustive.ok and sequences.ok)
    node(f"Sn{first + 2}.1", "solution", exhaustive.detail, py, exhaustive.ok, link="#check-exhaustive")
    node(f"Sn{first + 2}.2", "solution", sequences.detail, py, sequences.ok, link="#check-sequences")


def loop_goal(node: Callable[..., None], loop: dict[str, Any], number: int, reason: str) -> None:
    """G<number>: closed-loop runs show no runtime-monitor violation (undeveloped without runs, for `reason`)."""
    if loop["status"] == "undeveloped":
        node(
            f"G{number}",
            "undeveloped",
            f"Closed-loop runs of the generated code show no runtime-monitor violation ({reason})",
            "S1",
        )
        return
    ok = loop["status"] == "ok"
    node(f"G{number}", "goal", "Closed-loop runs of the generated code show no runtime-monitor violation", "S1", ok)
    node(f"Sn{number}.1", "solution", loop["detail"], f"G{number}", ok, link="#closed-loop")
    if "coverage" in loop:
        node(f"C{number}.1", "context", loop["coverage"], f"G{number}", link="#closed-loop")


def argument(ev: Evidence) -> list[dict[str, Any]]:
    """GSN nodes: goals, strategies, solutions (each linking to its artifact), contexts, undeveloped goals, and an
    assumption per [[assume]]. The goals, numbered in this order, are those the machine has: the proofs; the
    params' whole ranges, backed by the parametric proofs (where it has params or properties declared
    parametric); the generated code's conformance; the closed loop (undeveloped without runs); the physical
    safety of its lemmas; the generated test suite's coverage."""
    m: Machine = ev.spec.machine
    nodes: list[dict[str, Any]] = []

    def node(nid: str, kind: str, text: str, parent: str | None, ok: bool | None = None, *, link: str = "") -> None:
        nodes.append({"id": nid, "type": kind, "text": text, "parent": parent, "ok": ok, "link": link or None})

    node("G1", "goal", _top_claim(ev), None, ev.ok)
    node("C1", "context", f"Spec {ev.spec.path}, sha256 {ev.spec.sha256}, source: {m.cite}", "G1", link="#inputs")
    assumed = ", under the environment assumptions" if m.assumptions else ""
    strategy = f"Argue over the proofs of the spec (z3){assumed}, the generated code, and closed-loop behaviour"
    node("S1", "strategy", strategy, "G1")
    for k, a in enumerate(m.assumptions, 1):
        text = f"{a.id}: {show(a.expr)} at every step ({a.doc})" + (f", source: {a.cite}" if a.cite else "")
        node(f"A{k}", "assumption", text, "S1", link=f"#assume-{anchor(a.id)}")
    proofs_goal(node, ev.results)
    number = 3
    if m.params or declared_parametric(ev):
        _parametric_goal(node, ev)
        number += 1
    code_goals(node, ev.outcomes, CHECKS, number)
    loop_goal(node, ev.loop, number + 3, "no closed-loop results given")
    number += 4
    if ev.physics:
        physics_goal(node, ev, number)
        number += 1
    if ev.coverage:
        coverage.coverage_goal(node, ev.coverage, number)
    return nodes


def how_decided(r: Result) -> str:
    """How a property was decided, in a few words."""
    if r.proof is None:
        return r.detail.splitlines()[0] if r.detail else "decided on the machine's transitions"
    pr = r.proof
    text = pr.engine + (f", k = {pr.k}" if pr.k is not None else "")
    if pr.certificate is not None:
        text += ", certificate " + ("confirmed by a separate query" if pr.certificate_checked else "NOT confirmed")
    text += ", for every param value in range" if pr.parametric else ", at the params' defaults"
    return text + (f"; {r.caveat}" if r.caveat else "")


def _top_claim(ev: Evidence) -> str:
    """G1 in the machine's own terms: its params and its environment assumptions named only where it has them."""
    m = ev.spec.machine
    at = "for every param value in range"
    if len(declared_parametric(ev)) < len(declared(ev)):
        at = "at the params' defaults (and for every param value in range, the properties declared parametric)"
    who = f"The generated controller for {m.name} ({ev.spec.path})"
    claim = f"{who} meets its specified properties"
    claim += f", {at}" if m.params else ""
    return claim + (", under its environment assumptions" if m.assumptions else "")


def _parametric_goal(node: Callable[..., None], ev: Evidence) -> None:
    """G3: the properties declared parametric hold for every param value in range, each by its proof; where
    none is declared so, a context saying what G2's proofs claim instead."""
    m = ev.spec.machine
    props = declared_parametric(ev)
    if m.params and not props:
        text = (
            "No declared property is declared parametric: each is claimed and proved at the params' defaults "
            "(G2); declare it with parametric = true to claim it for every param value in range"
        )
        node("G3", "context", text, "S1")
        return
    what = "every param value in its range" if m.params else "every run (the machine has no params)"
    node(
        "G3", "goal", f"The properties declared parametric hold for {what}: parametric proofs", "S1", parametric_ok(ev)
    )
    for k, r in enumerate(props, 1):
        proved = r.proof is not None and r.proof.parametric
        how = how_decided(r) if proved else "its proof is not parametric (unknown or decided only at the defaults)"
        text = f"{r.prop} ({r.kind}): {r.verdict}, expected {r.expected}; {how}"
        node(f"Sn3.{k}", "solution", text, "G3", r.ok and proved, link=f"#proof-{anchor(r.prop)}")


def physics_ok(section: dict[str, Any]) -> bool:
    """Every lemma has its expected verdict, the RSS cross-check did not fail, and every replay given came out as
    expected."""
    lemmas_ok = all(x["ok"] for x in section["lemmas"])
    replays_ok = all(p["as_expected"] for p in section["replay"]["points"])
    return lemmas_ok and section["ad_rss_lib"]["status"] != "failed" and replays_ok


def physics_goal(node: Callable[..., None], ev: Evidence, number: int) -> None:
    """G<number>: a move starts only into a gap the lemmas prove safe (by RSS when the spec's distances are RSS's):
    backed by the lemmas that hold, the ad-rss-lib cross-check and the invariants that tie the machine's states
    to the rules the lemmas are about; the lemmas expected to fail (and their replays) are context."""
    section = ev.physics
    g, s = f"G{number}", f"S{number}"
    rss = section["ad_rss_lib"]["status"] != "none"  # the spec has RSS distances, cross-checked or not
    text = "A move starts only into a gap that is safe by RSS" if rss else "The rules meet what the lemmas state"
    node(g, "goal", text, "S1", physics_ok(section))
    how = "Lemmas over the reals (z3), a published reference for the distance, and the invariants that tie every move"
    node(s, "strategy", how + " to the rule", g)
    check = section["ad_rss_lib"]
    reference: list[Solution] = []
    if check["status"] != "none":
        ok = None if check["status"] == "not run" else check["status"] == "ok"
        reference.append((f"ad-rss-lib: {check['detail']}", ok, "#ad-rss-lib"))
    solutions = _lemma_solutions(ev) + reference + _rule_invariants(ev)
    for k, (text, ok, link) in enumerate(solutions, 1):
        node(f"Sn{number}.{k}", "solution", text, s, ok, link=link)
    for j, x in enumerate((x for x in section["lemmas"] if x["expected"] != "holds"), 1):
        replays = "; ".join(f"replayed in SUMO: {p['outcome']} (expected {p['expect']})" for p in x["replays"])
        text = f"lemma {x['id']}: {x['verdict']}, expected {x['expected']}" + (f"; {replays}" if replays else "")
        node(f"C{number}.{j}", "context", text, g, link=f"#lemma-{anchor(x['id'])}")


Solution = tuple[str, bool | None, str]  # text, ok, link


def _lemma_solutions(ev: Evidence) -> list[Solution]:
    """Each lemma expected to hold, with its SMT-LIB query."""
    return [
        (
            f"lemma {x['id']}: {x['verdict']}, expected {x['expected']} ({x['smt2']}, sha256 {x['smt2_sha256'][:12]})",
            x["ok"],
            f"#lemma-{anchor(x['id'])}",
        )
        for x in ev.physics["lemmas"]
        if x["expected"] == "holds"
    ]


def _rule_invariants(ev: Evidence) -> list[Solution]:
    """The invariants `<the state> -> ... <rule> ...` over a rule a holding lemma is about: they tie the states (a
    move under way) to the rule."""
    m = ev.spec.machine
    rules = set().union(*(physics.premise_definitions(m, x.expr) for x in m.lemmas if x.expect == "holds"))
    results = {r.prop: r for r in ev.results}
    found: list[Solution] = []
    for inv in m.invariants:
        e = inv.expr
        if not (isinstance(e, BinOp) and e.op == "->" and isinstance(e.left, StateIn)):
            continue
        tied = sorted(named(e.right) & rules)
        if inv.expect == "holds" and tied:
            r = results[inv.id]
            text = f"invariant {inv.id} ({show(e)}): {r.verdict}; it ties the states to {', '.join(tied)}"
            found.append((text, r.ok, f"#proof-{anchor(inv.id)}"))
    return found
