"""Write src/mlca_verify/schemas/<report>-<version>.schema.json, the JSON Schemas of the reports, from
`mlca_verify.report_schemas`: check-3, conform-1, tests-1, evidence-1 and network-evidence-1, shipped with the
package.

tests/test_report_schemas.py fails when a committed file differs from what the module builds; run
`.venv/bin/python scripts/report_schemas.py` to rewrite them after changing a report.
"""

from __future__ import annotations

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
OUT = ROOT / "src" / "mlca_verify" / "schemas"


def files() -> dict[Path, str]:
    """Each shipped file and the text the module builds for it."""
    from mlca_verify.report_schemas import REPORTS, file_name, schema_text

    return {OUT / file_name(report): schema_text(report) for report in REPORTS}


if __name__ == "__main__":
    OUT.mkdir(parents=True, exist_ok=True)
    for path, text in files().items():
        path.write_text(text, encoding="utf-8")
        print(f"wrote {path.relative_to(ROOT)}")
    sys.exit(0)
