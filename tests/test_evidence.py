"""The evidence bundle: its schema, byte-for-byte reproducibility, the page in a real browser, the database."""

from __future__ import annotations

import copy
import difflib
import hashlib
import json
import os
import re
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import jsonschema
import pytest
from markupsafe import escape
from playwright.sync_api import sync_playwright

from mlca_verify.cli import main
from mlca_verify.conformance.outcome import CHECKS
from mlca_verify.evidence import ClosedLoopRuns
from mlca_verify.evidence.collect import closed_loop
from mlca_verify.evidence.coverage import GOAL
from mlca_verify.model import show
from mlca_verify.spec import load_spec
from sim_check.cli import main as sim_main
from tests.conftest import ROOT

CHROMIUM_ARGS = ["--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", "--disable-quic"]  # fmt: skip


@pytest.fixture(scope="module")
def bundles(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The same evidence built twice, at two different times."""
    out = tmp_path_factory.mktemp("evidence")
    with pytest.MonkeyPatch.context() as mp:  # undone even when a build fails
        mp.chdir(ROOT)
        for name, epoch in (("a", "1764000000"), ("b", "1764003600")):
            mp.setenv("SOURCE_DATE_EPOCH", epoch)
            # without the generated suite, which the data machine's bundles below carry and compare
            assert main(["evidence", "spec/mlca_r.toml", "--out", str(out / name), "--no-tests"]) == 0
    return out / "a", out / "b"


@pytest.mark.slow
def test_evidence_json_matches_its_schema(bundles: tuple[Path, Path]) -> None:
    doc = json.loads((bundles[0] / "evidence.json").read_text())
    schema = json.loads((ROOT / "src/mlca_verify/schemas/evidence-1.schema.json").read_text())
    jsonschema.validate(doc, schema, format_checker=jsonschema.FormatChecker())
    assert doc["ok"] is True and doc["generated_at"] == "2025-11-24T16:00:00+00:00"
    wp = next(c for c in doc["conformance"] if c["name"] == "frama-c-wp")
    assert len(wp["data"]["goal_list"]) == wp["data"]["goals"] == wp["data"]["proved"]
    paths = {f["path"] for f in doc["inputs"]}
    assert {"spec/mlca_r.toml", "spec/mlca.toml", "spec/paper/figure.toml", "templates/c_fsm.c.j2"} <= paths
    rows = {r["element"]: r for r in doc["traceability"]}
    wait_left = rows["transition wait_left"]
    assert wait_left["cite"].startswith("repair of Alg. 1, l.16-18") and wait_left["verdict"] == "holds"
    for ref in wait_left["code"]:
        line = (ROOT / ref["file"]).read_text().splitlines()[ref["line"] - 1]
        assert "wait_left: " in line
    assert {m["machine"] for m in doc["readings"]["machines"]} == {"MLCA", "MLCA_figure", "MLCA_prose"}


@pytest.mark.slow
def test_two_runs_differ_only_in_the_timestamp(bundles: tuple[Path, Path]) -> None:
    for name in ("evidence.json", "index.html"):
        a = (bundles[0] / name).read_text().splitlines()
        b = (bundles[1] / name).read_text().splitlines()
        changed = [
            line
            for line in difflib.unified_diff(a, b, lineterm="", n=0)
            if line[:1] in "+-" and line[:3] not in ("+++", "---")
        ]
        assert len(changed) == 2, changed
        assert all("2025-11-24T1" in line for line in changed)


@pytest.mark.slow
def test_page_loads_in_chromium_without_errors_and_every_link_resolves(bundles: tuple[Path, Path]) -> None:
    page_url = (bundles[0] / "index.html").as_uri()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        page = browser.new_page()
        problems: list[str] = []
        requests: list[str] = []
        page.on("console", lambda m: problems.append(m.text) if m.type in ("error", "warning") else None)
        page.on("pageerror", lambda e: problems.append(str(e)))
        page.on("request", lambda r: requests.append(r.url))
        page.goto(page_url)
        hrefs = page.evaluate("[...document.querySelectorAll('a[href]')].map(a => a.getAttribute('href'))")
        missing = page.evaluate(
            "[...document.querySelectorAll('a[href^=\"#\"]')].map(a => a.getAttribute('href'))"
            ".filter(h => !document.getElementById(h.slice(1)))"
        )
        svgs = page.evaluate("document.querySelectorAll('.reading svg').length")
        solutions = page.evaluate("document.querySelectorAll('.node.solution a').length")
        browser.close()
    assert problems == []
    assert requests == [page_url], "the page must load nothing else"
    assert hrefs and all(h.startswith("#") for h in hrefs)
    assert missing == []
    assert svgs == 3
    doc = json.loads((bundles[0] / "evidence.json").read_text())
    assert solutions == sum(1 for n in doc["argument"] if n["type"] == "solution") > 30


@pytest.mark.slow
@pytest.mark.usefixtures("at_root")
def test_results_database_develops_the_closed_loop_goal(tmp_path: Path) -> None:
    db = tmp_path / "results.sqlite"
    with sqlite3.connect(db) as conn:  # the least the evidence reads: a runs table with these columns
        conn.execute("CREATE TABLE runs (controller TEXT, seed INTEGER, status TEXT, monitor_violations INTEGER)")
        rows = [
            ("mlca-c", 0, "done", 0),
            ("mlca-py", 1, "done", 0),
            ("mlca-c", 2, "done", 1),
            ("mlca_r-c", 0, "done", 5),
        ]
        conn.executemany("INSERT INTO runs VALUES (?, ?, ?, ?)", rows)
    out = tmp_path / "evidence"
    assert main(["evidence", "spec/mlca.toml", "--db", str(db), "--out", str(out), "--no-tests"]) == 1
    doc = json.loads((out / "evidence.json").read_text())
    assert doc["closed_loop"]["runs"] == 3 and doc["closed_loop"]["monitor_violations"] == 1
    g6 = next(n for n in doc["argument"] if n["id"] == "G6")
    assert g6["type"] == "goal" and g6["ok"] is False and doc["ok"] is False


@pytest.mark.usefixtures("at_root")
def test_bad_database_is_a_usage_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["evidence", "spec/mlca.toml", "--db", str(tmp_path / "none.sqlite"), "--out", str(tmp_path)]) == 2
    assert "results database not found" in capsys.readouterr().err


@pytest.mark.usefixtures("at_root")
def test_a_database_that_is_not_a_results_database_is_refused_before_the_proofs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "notes.sqlite"
    with sqlite3.connect(db) as conn:
        conn.execute("CREATE TABLE notes (text TEXT)")
    conn.close()
    start = time.monotonic()
    assert main(["evidence", "spec/mlca.toml", "--db", str(db), "--out", str(tmp_path / "out")]) == 2
    assert capsys.readouterr().err == f"{db}: error: not a results database of mlca-sim\n"
    assert time.monotonic() - start < 10 and not (tmp_path / "out" / "evidence.json").exists()


@pytest.mark.usefixtures("at_root")
def test_a_database_without_the_simulation_part_is_one_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    db = tmp_path / "results.sqlite"
    db.write_bytes(b"")
    for module in ("sim_check.db", "sim_check.evidence_reader"):  # importing them fails, as without sim_check
        monkeypatch.setitem(sys.modules, module, None)
    assert main(["evidence", "spec/mlca.toml", "--db", str(db), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"{db}: error: --db needs the simulation part of mlca-verify") and err.count("\n") == 1


def test_the_closed_loop_section_is_made_from_the_runs_given(tmp_path: Path) -> None:
    db = tmp_path / "results.sqlite"
    db.write_bytes(b"rows")
    section = closed_loop(ClosedLoopRuns(db, runs=9, failed_runs=1, monitor_violations=0), "mlca")
    assert json.dumps(section) == json.dumps({
        "status": "failed", "db": db.as_posix(), "sha256": hashlib.sha256(b"rows").hexdigest(), "runs": 9,
        "failed_runs": 1, "monitor_violations": 0, "detail": "9 closed-loop runs of mlca, 1 failed, 0 monitor violations",
    })  # fmt: skip
    assert closed_loop(ClosedLoopRuns(db, 2, 0, 0), "mlca")["status"] == "ok"
    covered = closed_loop(ClosedLoopRuns(db, 2, 0, 0, {"reset": 40, "go": 3}), "m", ("reset", "go", "back"))
    assert covered["transitions"] == [
        {"transition": "reset", "fired": 40},
        {"transition": "go", "fired": 3},
        {"transition": "back", "fired": 0},
    ]
    assert covered["coverage"] == "2 of 3 transitions fired in the closed-loop runs (never: back)"
    assert closed_loop(None, "mlca") == {"status": "undeveloped", "detail": "no closed-loop results given (--db)"}


def test_mlca_verify_imports_no_sim_check_and_holds_no_sql() -> None:
    code = (
        "import sys, mlca_verify.cli, mlca_verify.evidence; print(sorted(m for m in sys.modules if 'sim_check' in m))"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert done.stdout == "[]\n"
    sources = (ROOT / "src" / "mlca_verify").rglob("*.py")
    assert [p.name for p in sources if re.search(r"\bsqlite3\b|\bSELECT\b", p.read_text(encoding="utf-8"))] == []


# --- a machine with data (spec/mlca_t.toml): its proofs, params and assumptions, and its generated code -------

MLCA_T = "spec/mlca_t.toml"
HOSTILE = '</td><script>alert("doc")</script><img src=x onerror=alert(1)>&amp; {{ d.ok }}'


def _escaped(text: str) -> str:
    """`text` as the page's templates escape it."""
    return str(escape(text))


def _build_apart(spec: str, out: Path, extra: list[str], epoch: str) -> None:
    """The evidence of `spec` built by a process of its own, as a reproducible build runs it."""
    command = [sys.executable, "-m", "mlca_verify", "evidence", spec, "--out", str(out), *extra]
    env = {**os.environ, "SOURCE_DATE_EPOCH": epoch}
    done = subprocess.run(command, check=False, cwd=ROOT, env=env, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr


@pytest.fixture(scope="module")
def data_bundle(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The evidence of MLCA-T, a machine with data, with the SUMO replays of its lemmas' counterexamples."""
    out = tmp_path_factory.mktemp("evidence-data")
    checked, replayed = out / "check.json", out / "replay.json"
    assert main(["check", MLCA_T, "--quiet", "--json", str(checked)]) == 0
    assert sim_main(["replay", str(checked), "--json", str(replayed)]) == 0
    _build_apart(MLCA_T, out / "a", ["--replay", str(replayed)], "1764000000")
    return out / "a"


@pytest.fixture(scope="module")
def corpus_bundles(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """The evidence of a machine with data (proofs, every conform check, the generated suite and its coverage)
    built twice, at two different times, each by its own process: a real variable and real signals, so the
    binary64 parts of the bundle are in it, and small enough to build in half a minute."""
    out = tmp_path_factory.mktemp("evidence-corpus")
    spec = "tests/fixtures/real_state.toml"
    generated = out / "generated"
    assert main(["gen", "--out", str(generated), spec]) == 0
    for name, epoch in (("a", "1764000000"), ("b", "1764003600")):
        _build_apart(spec, out / name, ["--generated", str(generated)], epoch)
    return out / "a", out / "b"


def test_data_machine_bundle_matches_its_schema_and_shows_its_data(data_bundle: Path) -> None:
    m = load_spec(ROOT / MLCA_T).machine
    doc = json.loads((data_bundle / "evidence.json").read_text())
    schema = json.loads((ROOT / "src/mlca_verify/schemas/evidence-1.schema.json").read_text())
    jsonschema.validate(doc, schema, format_checker=jsonschema.FormatChecker())
    for path, wrong in ((("params", 0, "default"), 1.5), (("signals", 0, "type"), "float")):  # refused: exact text only
        broken = copy.deepcopy(doc)
        broken["data_machine"][path[0]][path[1]][path[2]] = wrong
        assert not jsonschema.Draft202012Validator(schema).is_valid(broken), path
    assert doc["ok"] is True and doc["spec"]["machine"] == m.name
    data = doc["data_machine"]
    assert data["step_s"] == "0.1"
    params = {p["name"]: p for p in data["params"]}
    assert list(params) == [p.name for p in m.params] and len(params) >= 4
    assert params["T_MIN"] == {**params["T_MIN"], "type": "int", "default": "20", "range": ["1", "100"], "unit": "step"}
    assert params["RHO"]["default"] == "1.0" and params["BRAKE_MIN"]["unit"] == "m/s^2"
    assert [(p["doc"], p["cite"]) for p in params.values()] == [(p.doc, p.cite) for p in m.params]
    signals = {s["name"]: s for s in data["signals"]}
    assert signals["v"]["unit"] == "m/s" and signals["v"]["range"] == ["0.0", "70.0"]
    assert list(signals) == [s.name for s in m.signals]
    assert [v["name"] for v in data["variables"]] == [v.name for v in m.variables]
    assert [d["name"] for d in data["definitions"]] == [d.name for d in m.definitions]
    assert [o["name"] for o in data["outputs"]] == [o.name for o in m.outputs] == ["command"]
    assert m.assumptions
    assert [(a["id"], a["expr"], a["doc"], a["cite"]) for a in data["assumptions"]] == [
        (a.id, show(a.expr), a.doc, a.cite) for a in m.assumptions
    ]
    # the proofs: engine, k, parametric, the certificate and whether a separate query confirmed it
    proofs = {p["property"]: p for p in doc["proofs"]}
    declared = [p.id for p in (*m.invariants, *m.liveness) if p.parametric and p.expect == "holds"]
    assert len(declared) >= 10
    relied = {a["id"]: a["relied_on_by"] for a in data["assumptions"]}
    for prop in declared:
        proof = proofs[prop]["proof"]
        assert proof["parametric"] is True and proof["engine"] in ("k-induction", "pdr")
        assert proof["certificate"] and proof["certificate_checked"] is True
        assert all(prop in relied[a] for a in proof["assumptions"])
    assert "proof" not in proofs["determinism"]
    nodes = {n["id"]: n for n in doc["argument"]}
    assert "for every param value in range" in nodes["G1"]["text"]
    g3 = nodes["G3"]
    assert "every param value" in g3["text"] and g3["ok"] is True
    backing = [n for n in doc["argument"] if n["parent"] == "G3"]
    assert [n["text"].split(" ")[0] for n in backing] == declared and {n["type"] for n in backing} == {"solution"}
    assumptions = [n for n in doc["argument"] if n["type"] == "assumption"]
    assert [n["text"].split(":")[0] for n in assumptions] == [a.id for a in m.assumptions]
    assert [n["link"] for n in assumptions] == [f"#assume-{a.id}" for a in m.assumptions]
    html = (data_bundle / "index.html").read_text()
    assert all(f'id="assume-{a.id}"' in html for a in m.assumptions) and 'id="param-T_MIN"' in html
    assert "confirmed by a separate query" in html
    for prop in declared:  # the certificate itself, escaped as all text is
        assert _escaped(proofs[prop]["proof"]["certificate"]) in html
    assert ">pass<" in html and 'id="check-frama-c-wp"' in html and ">FAIL<" not in html


def test_the_data_bundle_holds_every_check_of_mlca_t_passed(data_bundle: Path) -> None:
    """`conform` of MLCA-T with every check, as the evidence runs it: the exhaustive boundary set, WP of the
    mode logic against each mode's behaviours and of the whole step against the spec's relation, and the
    invariants proved on the step with their certificates."""
    doc = json.loads((data_bundle / "evidence.json").read_text())
    by_name = {c["name"]: c for c in doc["conformance"]}
    assert all(c["ok"] for c in by_name.values()), [c["detail"] for c in by_name.values() if not c["ok"]]
    assert by_name["exhaustive"]["data"]["steps"] > 10_000 and by_name["exhaustive"]["data"]["restarts"] > 1_000
    assert by_name["cortex-m4"]["data"]["data"] == 0 and by_name["cortex-m4"]["data"]["bss"] == 0
    wp = by_name["frama-c-wp"]["data"]
    assert wp["proved"] == wp["goals"] > 250
    names = {g["goal"] for g in wp["goal_list"]}
    assert "typed_mlca_t_fired_WAITING_WAITING_4_wait_left_ensures" in names
    assert "typed_mlca_t_fired_WAITING_complete" in " ".join(names)
    assert {"typed_mlca_t_step_ensures_3", "typed_mlca_t_step_ensures_4"} <= names
    assert wp["binary64"] == ["mlca_t_shape2: ensures"]  # the gap rule's one C function over reals
    # the spec's invariants on the step, each with its certificate; the two that compare samples are left out
    certified = wp["certified"]
    assert certified["proved"] == certified["goals"] > 0
    assert set(certified["stated"]) == {
        "A1", "A2", "A3", "A4", "deferral", "urgent-first-safe-step", "command-only-when-moving"
    }  # fmt: skip
    assert [x.split(":")[0] for x in certified["left"]] == ["fail-safe-left", "fail-safe-right"]


def test_data_machine_bundle_packages_its_generated_code(data_bundle: Path) -> None:
    doc = json.loads((data_bundle / "evidence.json").read_text())
    # the generated code: every conformance check of a machine with data, the files, the lines of each element
    assert [c["name"] for c in doc["conformance"]] == ["up-to-date", *CHECKS] and all(
        c["ok"] for c in doc["conformance"]
    )
    wp = next(c for c in doc["conformance"] if c["name"] == "frama-c-wp")["data"]
    assert wp["certified"]["stated"] and wp["binary64"]
    assert {a["kind"] for a in doc["artifacts"]} == {"python", "c-header", "c-source"}
    rows = {r["element"]: r for r in doc["traceability"]}
    assert rows["transition wait_left"]["code"] and "conform: frama-c-wp" in rows["transition wait_left"]["tests"]
    assert {"templates/c_fsm.c.j2", "templates/acsl.j2"} <= {p["path"] for p in doc["inputs"]}
    assert doc["closed_loop"]["status"] == "undeveloped"
    nodes = {n["id"]: n for n in doc["argument"]}
    assert nodes["G4"]["ok"] is True and nodes["G5"]["ok"] is True and nodes["G6"]["ok"] is True
    assert [n["text"].split(":")[0] for n in doc["argument"] if n["parent"] == "S5"] == list(CHECKS)
    assert nodes["G7"]["type"] == "undeveloped" and "no closed-loop results given" in nodes["G7"]["text"]


def test_data_machine_bundle_has_the_physical_safety_section(data_bundle: Path) -> None:
    m = load_spec(ROOT / MLCA_T).machine
    doc = json.loads((data_bundle / "evidence.json").read_text())
    section = doc["physical_safety"]
    lemmas = {x["id"]: x for x in section["lemmas"]}
    assert list(lemmas) == [x.id for x in m.lemmas]
    assert {k: (x["verdict"], x["ok"]) for k, x in lemmas.items()} == {
        "L-is-rss-safe": ("holds", True),
        "R-is-rss-safe": ("holds", True),
        "time-gap-rule-is-rss-safe": ("violated", True),
        "time-gap-rule-is-rss-safe-on-the-highway": ("violated", True),
    }
    for x in lemmas.values():  # each query is in the bundle, as hashed
        query = (data_bundle / x["smt2"]).read_bytes()
        assert hashlib.sha256(query).hexdigest() == x["smt2_sha256"] and b"(check-sat)" in query
    assert lemmas["L-is-rss-safe"]["params"] == ["ACCEL_MAX", "BRAKE_MAX", "BRAKE_MIN", "MIN_GAP", "RHO"]
    check = section["ad_rss_lib"]
    assert check["status"] == "ok"
    assert {(a["name"], a["rear"], a["front"]) for a in check["definitions"]} == {
        ("rss_lead_left", "v", "v_lead_left"),
        ("rss_follow_left", "v_follow_left", "v"),
        ("rss_lead_right", "v", "v_lead_right"),
        ("rss_follow_right", "v_follow_right", "v"),
    }
    assert all(a["max_difference_m"] <= 1e-3 and a["points"] > 100 for a in check["definitions"])
    (replayed,) = lemmas["time-gap-rule-is-rss-safe-on-the-highway"]["replays"]
    assert replayed["outcome"] == replayed["expect"] == "unsafe"
    assert all(p["phases"][0]["unsafe"] for p in section["replay"]["points"])
    nodes = {n["id"]: n for n in doc["argument"]}
    assert nodes["G8"]["text"] == "A move starts only into a gap that is safe by RSS" and nodes["G8"]["ok"] is True
    backing = [n["text"] for n in doc["argument"] if n["parent"] == "S8"]
    assert backing[0].startswith("lemma L-is-rss-safe: holds") and backing[2].startswith("ad-rss-lib: 4 RSS")
    assert any(text.startswith("invariant A3 ") and "ties the states to L" in text for text in backing)
    contexts = [n["text"] for n in doc["argument"] if n["parent"] == "G8" and n["type"] == "context"]
    assert contexts[1].endswith("replayed in SUMO: unsafe (expected unsafe)")
    html = (data_bundle / "index.html").read_text()
    assert 'id="physical-safety"' in html and 'href="smt2/mlca_t_L_is_rss_safe.smt2"' in html


def test_a_replay_of_another_spec_is_not_counted_for_this_one(tmp_path: Path) -> None:
    from mlca_verify.evidence.physics import check_replay, replays_of

    point = {"source": "x", "spec_sha256": "0" * 64, "lemma": "L", "expect": "safe", "outcome": "safe"}
    doc = check_replay({"schema": "mlca-sim.replay/1", "points": [{**point, "point": {}, "phases": []}]}, "f")
    assert replays_of(doc, "1" * 64) == {} and list(replays_of(doc, "0" * 64)) == ["L"]
    # an outcome is what its phases say, whatever the file claims
    crashed = {"name": "leader brakes", "collisions": [["av", "leader"]], "vehicles": []}
    with pytest.raises(ValueError, match="its phases say 'unsafe'"):
        check_replay({"schema": "mlca-sim.replay/1", "points": [{**point, "point": {}, "phases": [crashed]}]}, "f")


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("{", "Expecting property name"),
        ('{"schema": "mlca-sim.replay/1", "points": [{"source": 1}]}', "points[0].source is missing or not a string"),
        ('{"schema": "mlca-sim.replay/1", "points": [NaN]}', "NaN is not a number here"),
        (
            '{"schema": "mlca-sim.replay/1", "points": [{"source": "s", "spec_sha256": "", "lemma": "", "expect": "safe",'
            ' "outcome": "unsafe", "point": {}, "phases": [{"name": "p", "collisions": [5], "vehicles": []}]}]}',
            "collisions must be a list of pairs of vehicle ids",
        ),
        ('{"schema": "other"}', "not a `mlca-sim replay --json` document"),
        ("[" * 50_000, "maximum recursion depth"),
    ],
)
def test_a_bad_replay_file_is_refused_before_the_proofs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], text: str, message: str
) -> None:
    bad = tmp_path / "replay.json"
    bad.write_text(text)
    started = time.perf_counter()
    assert main(["evidence", MLCA_T, "--out", str(tmp_path / "out"), "--replay", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and message in err and time.perf_counter() - started < 10
    assert not (tmp_path / "out" / "evidence.json").exists()


def test_data_machine_bundle_carries_its_tests_and_their_coverage(data_bundle: Path) -> None:
    doc = json.loads((data_bundle / "evidence.json").read_text())
    tc = doc["test_coverage"]
    assert tc["status"] == "ok" and tc["folder"] == "tests/mlca_t" and tc["target"]["agrees"]
    assert {"test_mlca_t_mcdc.py", "mlca_t_mcdc.c", "objectives.json", "cobertura-c.xml"} <= set(tc["files"])
    assert all((data_bundle / tc["folder"] / name).is_file() for name in tc["files"])
    assert not (data_bundle / tc["folder"] / "build").exists()
    c = next(x for x in tc["coverage"] if x["language"] == "c")
    # every C condition paired but L and R in the fail-safe invariants, each gap with its reason
    assert (c["mcdc"]["covered"], c["mcdc"]["total"]) == (83, 85) and all(g["reason"] for g in c["gaps"])
    goal = next(n for n in doc["argument"] if n["text"] == GOAL)
    assert goal["ok"] is True and goal["parent"] == "S1"
    solutions = [n for n in doc["argument"] if n["parent"] == goal["id"].replace("G", "S")]
    assert len(solutions) == 4 and all(n["ok"] for n in solutions)  # the suite, Python, C, the target
    page = (data_bundle / "index.html").read_text()
    assert 'id="coverage"' in page and "every one as on the host" in page


def test_data_machine_bundles_differ_only_in_the_timestamp(corpus_bundles: tuple[Path, Path]) -> None:
    for name in ("evidence.json", "index.html"):
        a = (corpus_bundles[0] / name).read_text().splitlines()
        b = (corpus_bundles[1] / name).read_text().splitlines()
        changed = [
            line
            for line in difflib.unified_diff(a, b, lineterm="", n=0)
            if line[:1] in "+-" and line[:3] not in ("+++", "---")
        ]
        assert len(changed) == 2, changed
        assert all("2025-11-24T1" in line for line in changed)


@pytest.mark.slow
def test_data_machine_page_loads_in_chromium_and_every_link_resolves(data_bundle: Path) -> None:
    page_url = (data_bundle / "index.html").as_uri()
    with sync_playwright() as p:
        browser = p.chromium.launch(executable_path="/usr/bin/chromium", args=CHROMIUM_ARGS)
        page = browser.new_page()
        problems: list[str] = []
        requests: list[str] = []
        page.on("console", lambda m: problems.append(m.text) if m.type in ("error", "warning") else None)
        page.on("pageerror", lambda e: problems.append(str(e)))
        page.on("request", lambda r: requests.append(r.url))
        page.goto(page_url)
        missing = page.evaluate(
            "[...document.querySelectorAll('a[href^=\"#\"]')].map(a => a.getAttribute('href'))"
            ".filter(h => !document.getElementById(h.slice(1)))"
        )
        assumptions = page.evaluate("document.querySelectorAll('.node.assumption').length")
        certificates = page.evaluate("document.querySelectorAll('tr[id^=\"proof-\"] details pre').length")
        browser.close()
    assert problems == [] and requests == [page_url] and missing == []
    m = load_spec(ROOT / MLCA_T).machine
    assert assumptions == len(m.assumptions) and certificates >= len(m.invariants) + len(m.liveness)


def test_hostile_text_in_a_data_machine_reaches_the_page_escaped(tmp_path: Path) -> None:
    hostile = json.dumps(HOSTILE)  # a TOML basic string holding it
    spec = tmp_path / "hostile.toml"
    spec.write_text(
        f"""[machine]
name = "H"
initial = "A"
states = ["A", "B"]
cite = "test"
[inputs]
go = {{ doc = "go", cite = "test" }}
[params]
HOSTILE_P = {{ type = "real", default = 1.5, range = [0.25, 2.0], unit = "m", doc = {hostile}, cite = {hostile} }}
[signals]
d = {{ type = "real", unit = "m", range = [0.0, 10.0], doc = "a distance", cite = "test" }}
[definitions]
near = {{ expr = "d < HOSTILE_P", doc = "near", cite = "test" }}
[[transition]]
id = "t"
from = "A"
to = "B"
when = "go and near"
cite = "test"
[[assume]]
id = "hostile"
expr = "true"
doc = {hostile}
cite = {hostile}
"""
    )
    out, generated = tmp_path / "out", tmp_path / "generated"
    assert main(["gen", str(spec), "--out", str(generated)]) == 0
    assert main(["evidence", str(spec), "--out", str(out), "--generated", str(generated)]) == 0
    doc = json.loads((out / "evidence.json").read_text())
    assert doc["data_machine"]["params"][0] == {
        "name": "HOSTILE_P", "type": "real", "default": "1.5", "range": ["0.25", "2.0"], "unit": "m", "doc": HOSTILE,
        "cite": HOSTILE,
    }  # fmt: skip
    assert doc["data_machine"]["assumptions"][-1]["doc"] == HOSTILE
    html = (out / "index.html").read_text()
    assert "<script" not in html and "<img" not in html and "</td><script" not in html
    assert html.count(_escaped(HOSTILE)) >= 5  # the param's doc and cite, the assumption's (twice) and its node


@pytest.mark.usefixtures("at_root")
def test_a_data_machines_results_database_is_read_before_the_proofs(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    db = tmp_path / "results.sqlite"
    db.write_bytes(b"")
    assert main(["evidence", MLCA_T, "--db", str(db), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err == f"{db}: error: not a results database of mlca-sim\n"
    assert not (tmp_path / "out" / "evidence.json").exists()
