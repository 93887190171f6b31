"""`mlca-verify evidence`: a self-contained safety-case bundle (evidence.json and index.html)."""

from __future__ import annotations

import datetime
import json
import os
from pathlib import Path

from mlca_verify.evidence.collect import Evidence, collect
from mlca_verify.evidence.page import render_page

__all__ = ["Evidence", "collect", "now", "write_bundle"]


def now() -> str:
    """The one timestamp of a bundle: SOURCE_DATE_EPOCH when set (reproducible builds), else the current time."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    moment = datetime.datetime.fromtimestamp(int(epoch), datetime.UTC) if epoch else datetime.datetime.now(datetime.UTC)
    return moment.replace(microsecond=0).isoformat()


def write_bundle(ev: Evidence, out: Path) -> list[Path]:
    out.mkdir(parents=True, exist_ok=True)
    json_path, html_path = out / "evidence.json", out / "index.html"
    json_path.write_text(json.dumps(ev.data, indent=2) + "\n", encoding="utf-8")
    html_path.write_text(render_page(ev.data), encoding="utf-8")
    return [json_path, html_path]
