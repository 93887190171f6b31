"""The physical-safety section of the evidence: each `[[lemma]]` with its params, verdict and SMT-LIB query; the
cross-check of the spec's RSS distances against Intel's ad-rss-lib; and the SUMO replays of lemma
counterexamples (`mlca-sim replay --json`), taken as data.

An RSS distance is a definition named `rss_*` of unit m that reads two signals of unit m/s and the params
`RHO`, `ACCEL_MAX`, `BRAKE_MIN` and `BRAKE_MAX` (docs/lemmas/rss_longitudinal.toml names them so). It is
evaluated by the engine (z3, exactly) on a grid of speeds and param sets within the declared ranges and compared
with ad-rss-lib to 1 mm, with either signal as the vehicle behind; the order that agrees is reported.
"""

from __future__ import annotations

import hashlib
import itertools
import math
from collections.abc import Callable
from dataclasses import dataclass
from fractions import Fraction
from typing import Any

import z3

from mlca_verify.escape import c_form
from mlca_verify.evidence import adrss
from mlca_verify.logic.lemmas import lemma_scripts, named, reads
from mlca_verify.logic.results import Result
from mlca_verify.logic.symbolic import StepInputs, System, Valuation, python_value, value_of
from mlca_verify.model import BinOp, Definition, Expr, Machine, Range, Var, show
from mlca_verify.spec.types import show_unit

RSS_PARAMS = ("RHO", "ACCEL_MAX", "BRAKE_MIN", "BRAKE_MAX")
SPEEDS = (0.0, 2.5, 13.9, 30.0, 41.7, 70.0)  # m/s
PARAM_SETS = ((1.0, 3.5, 4.0, 8.0), (0.5, 2.0, 3.0, 9.0), (2.0, 1.0, 6.0, 10.0), (0.2, 0.0, 8.0, 8.0))
TOLERANCE_M = 1e-3
REPLAY_SCHEMA = "mlca-sim.replay/1"


@dataclass(frozen=True)
class Agreement:
    definition: str
    rear: str  # the signal that is the speed of the vehicle behind
    front: str
    points: int
    max_difference_m: float

    @property
    def ok(self) -> bool:
        return self.max_difference_m <= TOLERANCE_M


def rss_definitions(m: Machine) -> list[Definition]:
    """The spec's RSS distances: `rss_*` definitions of unit m over two speed signals and the four RSS params."""
    speeds = {s.name for s in m.signals if show_unit(s.unit) == "m/s"}
    found = []
    for d in m.definitions:
        rss_like = d.name.startswith("rss_") and show_unit(d.unit) == "m" and set(RSS_PARAMS) <= reads(m, d.expr)
        if rss_like and len(d.signals) == 2 and set(d.signals) <= speeds:
            found.append(d)
    return found


def _in(bounds: Range | None, x: float) -> bool:
    return bounds is None or Fraction(bounds[0]) <= Fraction(x) <= Fraction(bounds[1])


def _grid(m: Machine, pair: tuple[str, str]) -> list[tuple[tuple[float, ...], float, float]]:
    """(params, speed of the first signal, of the second) within the declared ranges."""
    ranges = {p.name: p.range for p in m.params} | {s.name: s.range for s in m.signals}
    sets = [ps for ps in PARAM_SETS if all(_in(ranges[n], x) for n, x in zip(RSS_PARAMS, ps, strict=True))]
    a = [x for x in SPEEDS if _in(ranges[pair[0]], x)]
    b = [x for x in SPEEDS if _in(ranges[pair[1]], x)]
    return [(ps, x, y) for ps, x, y in itertools.product(sets, a, b)]


def _value(m: Machine, system: System, d: Definition, params: tuple[float, ...], speeds: dict[str, float]) -> float:
    """The definition's value by the engine's semantics, at these RSS params (the others at their defaults)."""
    values = {p.name: value_of(p.default, p.type) for p in m.params}
    values |= {n: value_of(Fraction(x), "real") for n, x in zip(RSS_PARAMS, params, strict=True)}
    signals = {s.name: value_of(Fraction(0), s.type) for s in m.signals} | {
        k: value_of(Fraction(x), "real") for k, x in speeds.items()
    }
    inputs = {i.name: z3.BoolVal(False) for i in m.inputs}
    v = Valuation(z3.IntVal(0), {}, StepInputs(inputs, signals, {}), values)
    return float(python_value(z3.simplify(system.ev(Var(d.name), v))))


def agreement(m: Machine, d: Definition) -> Agreement:
    """The definition against ad-rss-lib, in the order of its two speed signals that agrees best."""
    system = System(m)
    pair = d.signals  # the two speed signals it reads (rss_definitions)
    assert len(pair) == 2
    grid = _grid(m, (pair[0], pair[1]))
    best: Agreement | None = None
    for rear, front in ((pair[0], pair[1]), (pair[1], pair[0])):
        worst = 0.0
        for params, x, y in grid:
            ours = _value(m, system, d, params, {pair[0]: x, pair[1]: y})
            speed = {pair[0]: x, pair[1]: y}
            worst = max(worst, abs(ours - adrss.ad_rss_gap(speed[rear], speed[front], params)))
        candidate = Agreement(d.name, rear, front, len(grid), worst)
        if best is None or candidate.max_difference_m < best.max_difference_m:
            best = candidate
    assert best is not None
    return best


def cross_check(m: Machine) -> dict[str, Any]:
    definitions = rss_definitions(m)
    if not definitions:
        return {"status": "none", "detail": "no RSS distance (rss_* definition) in the spec", "definitions": []}
    if not adrss.available():
        return {
            "status": "not run",
            "detail": "ad-rss-lib is not installed (pip install ad-rss)",
            "definitions": [d.name for d in definitions],
        }
    found = [agreement(m, d) for d in definitions]
    ok = all(a.ok for a in found)
    points = sum(a.points for a in found)
    detail = (
        f"{len(found)} RSS distance(s) equal ad-rss-lib's calculateSafeLongitudinalDistanceSameDirection to 1 mm "
        f"at {points} points (speeds and param sets within the declared ranges)"
        if ok
        else "an RSS distance differs from ad-rss-lib's by more than 1 mm: "
        + ", ".join(f"{a.definition} by {a.max_difference_m:.3g} m" for a in found if not a.ok)
    )
    return {
        "status": "ok" if ok else "failed",
        "detail": detail,
        "definitions": [
            {
                "name": a.definition,
                "rear": a.rear,
                "front": a.front,
                "points": a.points,
                "max_difference_m": a.max_difference_m,
                "ok": a.ok,
            }
            for a in found
        ],
    }


def smt2_files(m: Machine) -> dict[str, str]:
    """Evidence-relative path -> SMT-LIB 2 query of each lemma (`unsat` means it holds)."""
    return {f"smt2/{name}": text for name, text in lemma_scripts(m, False, 10_000).items()}


def check_replay(doc: object, where: str) -> dict[str, Any]:
    """A `mlca-sim replay --json` document (data from outside), checked and rebuilt from what it must hold: every
    point's outcome follows from its phases, every phase's from its collisions and its vehicles' braking. Else a
    ValueError with a one-line reason."""
    if not isinstance(doc, dict) or doc.get("schema") != REPLAY_SCHEMA:
        raise ValueError(f"{where}: not a `mlca-sim replay --json` document (schema {REPLAY_SCHEMA})")
    points = doc.get("points")
    if not isinstance(points, list):
        raise ValueError(f"{where}: `points` must be a list")
    scenes = doc.get("networks", [])
    if not isinstance(scenes, list):
        raise ValueError(f"{where}: `networks` must be a list")
    return {
        "points": [_checked_point(point, f"{where}: points[{k}]") for k, point in enumerate(points)],
        "networks": [_checked_scene(scene, f"{where}: networks[{k}]") for k, scene in enumerate(scenes)],
    }


def _names_to(values: object, kind: Callable[[object], bool]) -> bool:
    return isinstance(values, dict) and all(isinstance(k, str) and kind(v) for k, v in values.items())


def _count(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _checked_scene(scene: object, at: str) -> dict[str, Any]:
    """A replayed network scene, rebuilt from what it must hold: its outcome is a conflict where two AVs moved into
    one lane or SUMO saw a collision, and none otherwise, whatever the file says."""
    if not isinstance(scene, dict) or not isinstance(scene.get("source"), str):
        raise ValueError(f"{at} is not a replayed network scene (no source)")
    shapes: dict[str, Callable[[object], bool]] = {
        "controllers": lambda v: _names_to(v, lambda x: isinstance(x, str)),
        "lanes": lambda v: _names_to(v, _count),
        "radio": lambda v: _names_to(v, _count),
        "moved_s": lambda v: _names_to(v, _number),
        "messages": lambda v: _names_to(v, _count),
        "conflicts": _count,
        "collisions": lambda v: (
            isinstance(v, list) and all(isinstance(c, list) and all(isinstance(x, str) for x in c) for c in v)
        ),
    }
    for key, shape in shapes.items():
        if not shape(scene.get(key)):
            raise ValueError(f"{at}.{key} is missing or not of its shape")
    if scene.get("expected") not in (None, "conflict", "none"):
        raise ValueError(f'{at}.expected must be "conflict", "none" or null')
    outcome = "conflict" if scene["conflicts"] or scene["collisions"] else "none"
    if scene.get("outcome") != outcome:
        raise ValueError(f"{at}.outcome is {scene.get('outcome')!r}, but its conflicts and collisions say {outcome!r}")
    return {**{k: scene[k] for k in ("source", *shapes)}, "outcome": outcome, "expected": scene["expected"]}


def _checked_point(point: object, at: str) -> dict[str, Any]:
    if not isinstance(point, dict):
        raise ValueError(f"{at} is not an object")
    for key in ("source", "spec_sha256", "lemma"):
        if not isinstance(point.get(key), str):
            raise ValueError(f"{at}.{key} is missing or not a string")
    values, phases = point.get("point"), point.get("phases")
    if point.get("expect") not in ("safe", "unsafe"):
        raise ValueError(f'{at}.expect must be "safe" or "unsafe"')
    if not isinstance(values, dict) or not all(isinstance(k, str) and _number(x) for k, x in values.items()):
        raise ValueError(f"{at}.point must map names to finite numbers")
    if not isinstance(phases, list):
        raise ValueError(f"{at}.phases must be a list")
    checked = [_checked_phase(ph, f"{at}.phases[{j}]") for j, ph in enumerate(phases)]
    outcome = "unsafe" if any(ph["unsafe"] for ph in checked) else "safe"
    if point.get("outcome") != outcome:
        raise ValueError(f"{at}.outcome is {point.get('outcome')!r}, but its phases say {outcome!r}")
    kept = {k: point[k] for k in ("source", "spec_sha256", "lemma", "expect")}
    return {**kept, "point": values, "outcome": outcome, "phases": checked}


def _checked_phase(ph: object, at: str) -> dict[str, Any]:
    if not isinstance(ph, dict) or not isinstance(ph.get("name"), str):
        raise ValueError(f"{at} is not a replayed phase (no name)")
    collisions, vehicles = ph.get("collisions"), ph.get("vehicles")
    pairs_ok = isinstance(collisions, list) and all(
        isinstance(c, list) and len(c) == 2 and all(isinstance(x, str) for x in c) for c in collisions
    )
    if not pairs_ok:
        raise ValueError(f"{at}.collisions must be a list of pairs of vehicle ids")
    if not isinstance(vehicles, list) or not all(
        isinstance(v, dict) and isinstance(v.get("id"), str) and isinstance(v.get("beyond"), bool) for v in vehicles
    ):
        raise ValueError(f"{at}.vehicles must be a list of vehicles with an id and `beyond`")
    gaps = {k: ph.get(k) for k in ("min_gap_lead_m", "min_gap_follow_m")}
    if not all(g is None or _number(g) for g in gaps.values()):
        raise ValueError(f"{at}: the smallest gaps must be finite numbers")
    beyond = [v["id"] for v in vehicles if v["beyond"]]
    return {
        "name": ph["name"],
        "unsafe": bool(collisions or beyond),
        "collisions": collisions,
        **gaps,
        "beyond": beyond,
    }


def _number(x: object) -> bool:
    return isinstance(x, int | float) and not isinstance(x, bool) and math.isfinite(x)


def replays_of(replay: dict[str, Any] | None, spec_sha256: str) -> dict[str, list[dict[str, Any]]]:
    """Lemma id -> the replayed points of its counterexample, from this very spec (by its sha256)."""
    found: dict[str, list[dict[str, Any]]] = {}
    for point in (replay or {}).get("points", []):
        if point.get("spec_sha256") == spec_sha256 and point.get("lemma"):
            found.setdefault(point["lemma"], []).append(point)
    return found


def premise_definitions(m: Machine, expr: Expr) -> set[str]:
    """For a lemma `a -> b`, the definitions `a` names (the rule the lemma is about); none for another form."""
    if isinstance(expr, BinOp) and expr.op == "->":
        return named(expr.left) & {d.name for d in m.definitions}
    return set()


def section(
    m: Machine, spec_sha256: str, results: list[Result], replay: dict[str, Any] | None, files: dict[str, str]
) -> dict[str, Any]:
    """The section's data; `files` are the lemmas' queries (`smt2_files`) as the bundle holds them: z3 names the
    terms of a query after its own ids, so two renderings of one query in a process differ in those names."""
    by_id = {r.prop: r for r in results if r.kind == "lemma"}
    replayed = replays_of(replay, spec_sha256)
    ours = [p for p in (replay or {}).get("points", []) if p["spec_sha256"] == spec_sha256]
    lemmas = []
    for lemma in m.lemmas:
        r = by_id[lemma.id]
        name = f"smt2/{m.name.lower()}_{c_form(lemma.id)}.smt2"
        used = sorted(reads(m, lemma.expr) & {p.name for p in m.params})
        lemmas.append(
            {
                "id": lemma.id,
                "expr": show(lemma.expr),
                "doc": lemma.doc,
                "cite": lemma.cite,
                "parametric": lemma.parametric,
                "params": used,
                "verdict": r.verdict,
                "expected": r.expected,
                "ok": r.ok,
                "detail": r.detail,
                "smt2": name,
                "smt2_sha256": hashlib.sha256(files[name].encode()).hexdigest(),
                "replays": [_replay_summary(p) for p in replayed.get(lemma.id, [])],
            }
        )
    return {
        "lemmas": lemmas,
        "ad_rss_lib": cross_check(m),
        "replay": {
            "given": replay is not None,
            "points": [_replay_summary(p) for p in ours],
            "other_specs": len((replay or {}).get("points", [])) - len(ours),
        },
    }


def _replay_summary(point: dict[str, Any]) -> dict[str, Any]:
    """A checked point (`check_replay`) as the section shows it."""
    keys = ("source", "point", "expect", "outcome")
    return {
        **{k: point[k] for k in keys},
        "as_expected": point["outcome"] == point["expect"],
        "phases": point["phases"],
    }
