"""The suite's coverage as SARIF 2.1.0, which CI reads: one result per condition without an MC/DC pair (at the
spec element it belongs to, with z3's reason) and per gap of the code the suite leaves without a reason. The
Cobertura XML of the generated C is `cobertura`'s."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

from mlca_verify.ci_formats import SARIF_SCHEMA
from mlca_verify.testgen.measure import Coverage
from mlca_verify.testgen.search import Pair
from mlca_verify.version import __version__

RULES = {
    "mcdc-no-pair": "A condition of the spec has no MC/DC independence pair; z3 says why.",
    "code-gap": "A line, branch or MC/DC condition of the generated code that the suite does not cover.",
}


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
