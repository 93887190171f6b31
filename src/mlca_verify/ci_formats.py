"""Check results in the formats CI systems read: JUnit XML (one test case per property) and SARIF 2.1.0 (each
finding located at the line of the spec element it is about, so that review tools annotate the spec)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any
from xml.etree import ElementTree as ET

from mlca_verify.check_report import trace_text
from mlca_verify.errors import Loc
from mlca_verify.escape import xml_text
from mlca_verify.logic.results import Result
from mlca_verify.model import Machine
from mlca_verify.version import __version__

SARIF_SCHEMA = "https://json.schemastore.org/sarif-2.1.0.json"
RULES = {
    "determinism": "Two transitions with different targets are enabled at once.",
    "completeness": "Some input enables no transition (a gap).",
    "reachability": "A state is never reached.",
    "dead-transition": "A transition never fires.",
    "invariant": "A declared invariant fails after some step.",
    "liveness": "A declared response property fails on some run.",
    "equivalence": "Two machines behave differently on some input sequence.",
    "range": "A variable leaves its declared range.",
    "division": "A divisor can be zero where its value is used.",
    "overflow": "An int value can leave the generated code's 64 bits.",
    "binary64": "A verdict decided over the reals is not shown to hold for the code's binary64 arithmetic.",
    "binary32": "A verdict decided over the reals is not shown to hold for the code's binary32 arithmetic.",
    "lemma": "A declared lemma over the definitions fails for some values in range.",
    "citation": "A spec element cites no source (check --require-cites).",
}

Checked = tuple[str, Machine, Sequence[Result]]  # spec path, machine, results


def element_loc(machine: Machine, prop: str) -> Loc:
    """Where in the spec the element a property is about stands."""
    kind, _, name = prop.partition(":")
    if kind == "fires":
        return next(t.loc for t in machine.transitions if t.id == name)
    if kind == "equiv":
        return next(c.loc for c in machine.comparisons if c.other.name == name)
    if kind == "range":
        return next(v.loc for v in machine.variables if v.name == name)
    declared = {i.id: i.loc for i in machine.invariants} | {p.id: p.loc for p in machine.liveness}
    declared |= {x.id: x.loc for x in machine.lemmas}
    return declared.get(prop, machine.loc)


def _located(rule: str, level: str, text: str, path: str, loc: Loc) -> dict[str, Any]:
    region = {"startLine": loc.line, "startColumn": loc.col}
    return {
        "ruleId": rule,
        "level": level,
        "message": {"text": text},
        "locations": [{"physicalLocation": {"artifactLocation": {"uri": path}, "region": region}}],
    }


def _message(r: Result) -> str:
    text = f"{r.prop} ({r.kind}): {r.verdict}, expected {r.expected}"
    text = f"{text}. {r.detail}" if r.detail else text
    return f"{text}. Caveat: {r.caveat}" if r.caveat else text


def _xml_safe(root: ET.Element) -> None:
    """Spec text in every attribute and text made characters XML 1.0 can hold (the serializer escapes markup)."""
    for element in root.iter():
        element.attrib.update({key: xml_text(value) for key, value in element.attrib.items()})
        if element.text is not None:
            element.text = xml_text(element.text)


def junit_xml(checked: Sequence[Checked]) -> str:
    """One <testsuite> per spec, one <testcase> per property; a verdict other than expected is a <failure>."""
    root = ET.Element("testsuites", name="mlca-verify check")
    total = failures = 0
    for path, machine, results in checked:
        bad = [r for r in results if not r.ok]
        suite = ET.SubElement(
            root, "testsuite", name=path, tests=str(len(results)), failures=str(len(bad)), errors="0", skipped="0"
        )
        suite.set("time", f"{sum(r.seconds for r in results):.3f}")
        for r in results:
            loc = element_loc(machine, r.prop)
            case = ET.SubElement(
                suite, "testcase", classname=f"mlca-verify.{machine.name}", name=r.prop, time=f"{r.seconds:.3f}"
            )
            case.set("file", path)
            case.set("line", str(loc.line))
            body = f"cite: {r.cite}\n{_message(r)}" if r.cite else _message(r)
            if r.counterexample is not None and r.counterexample.steps:
                body += "\n" + trace_text(r.counterexample, machine.input_names)
            if not r.ok:
                failure = ET.SubElement(case, "failure", message=_message(r), type=r.kind)
                failure.text = body
            else:
                ET.SubElement(case, "system-out").text = body
        total += len(results)
        failures += len(bad)
    root.set("tests", str(total))
    root.set("failures", str(failures))
    root.set("errors", "0")
    _xml_safe(root)
    ET.indent(root)
    return '<?xml version="1.0" encoding="UTF-8"?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def sarif(
    checked: Sequence[Checked],
    uncited_elements: Sequence[tuple[str, Loc, str]] = (),
    related: Mapping[tuple[str, str], Sequence[tuple[Loc, str]]] | None = None,
) -> dict[str, Any]:
    """A SARIF 2.1.0 log: a result for every violated or unknown verdict. A violation the spec expects is
    reported with an in-source suppression (its `expect`), so tools show it as accepted, not new. Each uncited
    element given (spec path, where, what) is a warning at its own line. `related` adds, by (spec path,
    property), the other places a finding involves (a network's channels that lost its messages)."""
    results: list[dict[str, Any]] = []
    for path, machine, checked_results in checked:
        for r in checked_results:
            if r.verdict == "holds" and not r.caveat:
                continue
            loc = element_loc(machine, r.prop)
            entry: dict[str, Any] = {
                "ruleId": r.kind if r.verdict != "holds" else machine.reals,
                "level": "error" if not r.ok else "note",
                "message": {"text": _message(r)},
                "locations": [
                    {
                        "physicalLocation": {
                            "artifactLocation": {"uri": path},
                            "region": {"startLine": loc.line, "startColumn": loc.col},
                        },
                        "logicalLocations": [{"name": r.prop, "fullyQualifiedName": f"{machine.name}.{r.prop}"}],
                    }
                ],
                "properties": {"verdict": r.verdict, "expected": r.expected, "cite": r.cite},
            }
            others = (related or {}).get((path, r.prop), ())
            if others:
                entry["relatedLocations"] = [
                    {
                        "id": k,
                        "physicalLocation": {
                            "artifactLocation": {"uri": path},
                            "region": {"startLine": where.line, "startColumn": where.col},
                        },
                        "message": {"text": text},
                    }
                    for k, (where, text) in enumerate(others)
                ]
            if r.ok and r.verdict != "holds":
                entry["suppressions"] = [{"kind": "inSource", "justification": f'expect = "{r.expected}" in the spec'}]
            results.append(entry)
    for path, where, what in uncited_elements:
        results.append(_located("citation", "warning", f"uncited {what}", path, where))
    rules = [{"id": kind, "shortDescription": {"text": text}} for kind, text in RULES.items()]
    return {
        "$schema": SARIF_SCHEMA,
        "version": "2.1.0",
        "runs": [
            {
                "tool": {"driver": {"name": "mlca-verify", "version": __version__, "rules": rules}},
                "results": results,
            }
        ],
    }
