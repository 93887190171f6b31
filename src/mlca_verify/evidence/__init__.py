"""`mlca-verify evidence`: a self-contained safety-case bundle (evidence.json and index.html)."""

from __future__ import annotations

import datetime
import json
import os
from pathlib import Path

from mlca_verify.evidence.collect import Evidence, collect
from mlca_verify.evidence.page import render_page
from mlca_verify.evidence.physics import check_replay
from mlca_verify.evidence.runs import ClosedLoopRuns, loop_controllers, read_closed_loop
from mlca_verify.files import write_atomic

__all__ = [
    "ClosedLoopRuns",
    "Evidence",
    "check_replay",
    "collect",
    "loop_controllers",
    "now",
    "read_closed_loop",
    "write_bundle",
]


def now() -> str:
    """The one timestamp of a bundle: SOURCE_DATE_EPOCH when set (reproducible builds), else the current time."""
    epoch = os.environ.get("SOURCE_DATE_EPOCH")
    moment = datetime.datetime.fromtimestamp(int(epoch), datetime.UTC) if epoch else datetime.datetime.now(datetime.UTC)
    return moment.replace(microsecond=0).isoformat()


def write_bundle(ev: Evidence, out: Path) -> list[Path]:
    """evidence.json, index.html and, for a spec with lemmas, each lemma's SMT-LIB 2 query under smt2/."""
    out.mkdir(parents=True, exist_ok=True)
    json_path, html_path = out / "evidence.json", out / "index.html"
    page = render_page(ev.data)  # before anything is written: a page that cannot be made leaves the old bundle
    written = []
    if ev.physics:
        (out / "smt2").mkdir(exist_ok=True)
        for name, text in ev.smt2.items():
            write_atomic(out / name, text)
            written.append(out / name)
    write_atomic(json_path, json.dumps(ev.data, indent=2) + "\n")
    write_atomic(html_path, page)
    return [json_path, html_path, *written]
