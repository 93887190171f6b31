"""The suite's coverage in the formats CI reads: Cobertura XML for the generated C (from llvm-cov's LCOV export;
coverage.py writes the Python's), and SARIF 2.1.0 with one result per condition without an MC/DC pair (at the
spec element it belongs to, with z3's reason) and per gap of the code the suite leaves without a reason."""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any
from xml.etree import ElementTree as ET

from mlca_verify import __version__
from mlca_verify.ci_formats import SARIF_SCHEMA
from mlca_verify.escape import xml_text
from mlca_verify.testgen.search import Pair

if TYPE_CHECKING:
    from mlca_verify.testgen.measure import Coverage

RULES = {
    "mcdc-no-pair": "A condition of the spec has no MC/DC independence pair; z3 says why.",
    "code-gap": "A line, branch or MC/DC condition of the generated code that the suite does not cover.",
}


def cobertura_from_lcov(lcov: str, source: str, timestamp: int = 0) -> str:
    """A Cobertura report of one source file from its LCOV record (DA line hits, BRDA branch hits)."""
    hits: dict[int, int] = {}
    branches: dict[int, list[bool]] = {}
    for line in lcov.splitlines():
        if line.startswith("DA:"):
            fields = line[3:].split(",")
            hits[int(fields[0])] = int(fields[1])
        elif line.startswith("BRDA:"):
            fields = line[5:].split(",")
            branches.setdefault(int(fields[0]), []).append(fields[3] not in ("-", "0"))
    lines_hit = sum(1 for c in hits.values() if c > 0)
    all_branches = [b for bs in branches.values() for b in bs]
    line_rate = lines_hit / len(hits) if hits else 1.0
    branch_rate = sum(all_branches) / len(all_branches) if all_branches else 1.0
    root = ET.Element(
        "coverage",
        {
            "line-rate": f"{line_rate:.4f}",
            "branch-rate": f"{branch_rate:.4f}",
            "lines-covered": str(lines_hit),
            "lines-valid": str(len(hits)),
            "branches-covered": str(sum(all_branches)),
            "branches-valid": str(len(all_branches)),
            "complexity": "0",
            "version": __version__,
            "timestamp": str(timestamp),
        },
    )
    package = ET.SubElement(ET.SubElement(root, "packages"), "package", name="generated", complexity="0")
    package.set("line-rate", f"{line_rate:.4f}")
    package.set("branch-rate", f"{branch_rate:.4f}")
    cls = ET.SubElement(ET.SubElement(package, "classes"), "class", name=xml_text(source), filename=xml_text(source))
    cls.set("line-rate", f"{line_rate:.4f}")
    cls.set("branch-rate", f"{branch_rate:.4f}")
    cls.set("complexity", "0")
    ET.SubElement(cls, "methods")
    lines = ET.SubElement(cls, "lines")
    for number in sorted(hits):
        entry = ET.SubElement(lines, "line", number=str(number), hits=str(hits[number]))
        taken = branches.get(number)
        entry.set("branch", "true" if taken else "false")
        if taken:
            entry.set("condition-coverage", f"{100 * sum(taken) // len(taken)}% ({sum(taken)}/{len(taken)})")
    ET.indent(root)
    return '<?xml version="1.0" ?>\n' + ET.tostring(root, encoding="unicode") + "\n"


def sarif(spec_path: str, pairs: Sequence[Pair], coverage: Sequence[tuple[str, Coverage]]) -> dict[str, Any]:
    """`coverage` pairs each measured file's path (as the log should name it) with its coverage."""
    results: list[dict[str, Any]] = []
    for p in pairs:
        if not p.reason:
            continue
        loc = p.objective.decision.loc
        results.append(
            _result("mcdc-no-pair", "note", f"{p.objective.label}: {p.reason}", (spec_path, loc.line, loc.col))
        )
    for path, c in coverage:
        for g in c.gaps:
            level = "note" if g.reason else "error"
            text = f"{g.what}: {g.reason}" if g.reason else f"{g.what}: no test of the suite covers it"
            results.append(_result("code-gap", level, text, (path, g.line, 1)))
    rules = [{"id": k, "shortDescription": {"text": v}} for k, v in RULES.items()]
    return {
        "$schema": SARIF_SCHEMA,
        "version": "2.1.0",
        "runs": [
            {
                "tool": {"driver": {"name": "mlca-verify tests", "version": __version__, "rules": rules}},
                "results": results,
            }
        ],
    }


def _result(rule: str, level: str, text: str, where: tuple[str, int, int]) -> dict[str, Any]:
    path, line, col = where
    return {
        "ruleId": rule,
        "level": level,
        "message": {"text": text},
        "locations": [
            {
                "physicalLocation": {
                    "artifactLocation": {"uri": path},
                    "region": {"startLine": line, "startColumn": col},
                }
            }
        ],
    }
