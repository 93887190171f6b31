"""`mlca-sim replay`: a lemma's point (the speeds and gaps of the AV, its new leader and its new follower) as
traffic in SUMO. On a straight two-lane road the AV drives beside the gap and changes into it at once; then
Responsibility-Sensitive Safety's worst case (Definition 1) is driven twice, once per vehicle in front:

- `leader brakes`: the new leader brakes at BRAKE_MAX to a stop; the AV and the new follower, each behind
  another vehicle, accelerate at ACCEL_MAX for the response time RHO and then brake at BRAKE_MIN;
- `AV brakes`: the AV brakes at BRAKE_MAX to a stop; the new follower accelerates for RHO and then brakes at
  BRAKE_MIN; the leader keeps its speed.

A vehicle that brakes at BRAKE_MIN is also under SUMO's own car-following model (Krauss's safe speed, with no
reaction time of its own: the response time is driven explicitly): where the model needs harder braking to
avoid a collision it brakes harder, which is what a rule that accepts an unsafe gap forces. The replay reports
SUMO's collisions, the smallest gaps and each vehicle's hardest braking against its declared limit (BRAKE_MAX for
a vehicle braking in front, BRAKE_MIN for one braking behind). SUMO integrates ballistically (constant
acceleration within a step), the motion RSS's distance is derived for.

The pure part (reading and checking the point, the worst-case profiles, the verdict) is free of SUMO; `replay`
drives libsumo.

A `mlca-verify check --json` report is replayed one point per distinct (spec, lemma, counterexample point): copies
of one result are replayed once. One file may ask for at most MAX_REPLAY_POINTS (50) distinct points, each two SUMO
runs; a file with more is refused before SUMO starts, as is a lemma whose name no spec could give.
"""

from __future__ import annotations

import json
import math
import subprocess
import tomllib
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

from mlca_verify.errors import ToolError, UsageError
from mlca_verify.escape import terminal
from mlca_verify.files import read_regular
from mlca_verify.spec.names import NAME_LIMIT, PROPERTY_ID
from sim_check.scenario import sumo_bin, sumo_command

MAX_REPLAY_BYTES = 1 << 20
MAX_REPLAY_POINTS = 50  # distinct points one file may ask to replay: each is two SUMO runs
STEP_S = 0.1
LENGTH_M = 5.0  # every vehicle's length
SPEED_RANGE = (0.0, 70.0)  # m/s, MLCA-T's signal range
GAP_RANGE = (0.0, 1000.0)  # m
PARAM_RANGES = {  # RSS's params, as docs/lemmas/rss_longitudinal.toml bounds them
    "RHO": (0.1, 3.0),
    "ACCEL_MAX": (0.0, 10.0),
    "BRAKE_MIN": (1.0, 8.0),  # RSS's distance is collision-free only when BRAKE_MIN <= BRAKE_MAX
    "BRAKE_MAX": (8.0, 12.0),
}
AD_RSS_DEFAULTS = {"RHO": 1.0, "ACCEL_MAX": 3.5, "BRAKE_MIN": 4.0, "BRAKE_MAX": 8.0}
POINT_KEYS = ("v", "gap_lead", "v_lead", "gap_follow", "v_follow")
SIDES = ("left", "right")
EMERGENCY_DECEL = 9.0  # m/s^2: SUMO's default for passenger cars, about what tyres give on a dry road
TOLERANCE = 1e-6  # m/s^2: braking counted beyond a limit (SUMO's speeds are binary64)
PHASES = ("leader brakes", "AV brakes")


@dataclass(frozen=True)
class Point:
    """One situation at the moment the AV enters its new lane; `source` says where it comes from."""

    v: float
    gap_lead: float
    v_lead: float
    gap_follow: float
    v_follow: float
    params: dict[str, float]
    source: str
    expect: str = "safe"  # "safe" or "unsafe": a violated lemma's counterexample is expected to be unsafe
    spec: str = ""  # where the point comes from: the spec (path and sha256) and lemma of a counterexample
    spec_sha256: str = ""
    lemma: str = ""


@dataclass
class Vehicle:
    """What one vehicle did in a phase."""

    id: str
    role: str  # "front" (brakes at BRAKE_MAX), "rear" (responds, then brakes at BRAKE_MIN) or "steady"
    limit: float | None  # the hardest braking declared for its role (m/s^2)
    hardest: float = 0.0  # the hardest braking it did (m/s^2)

    @property
    def beyond(self) -> bool:
        return self.limit is not None and self.hardest > self.limit + TOLERANCE


@dataclass
class Phase:
    name: str
    collisions: list[list[str]] = field(default_factory=list)
    min_gap_lead: float = math.inf  # between the AV and its new leader (m)
    min_gap_follow: float = math.inf  # between the new follower and the AV (m)
    start_gaps: tuple[float, float] = (math.nan, math.nan)  # the gaps SUMO had when the worst case began
    vehicles: list[Vehicle] = field(default_factory=list)
    seconds: float = 0.0  # simulated

    @property
    def unsafe(self) -> bool:
        return bool(self.collisions) or any(v.beyond for v in self.vehicles)


# ---- reading a point -------------------------------------------------------------------------------------------


def read_replay_file(path: Path) -> str:
    """The text of a replay file: a report or a point file, within MAX_REPLAY_BYTES."""
    if path.is_dir():
        raise UsageError.at(path, "is a directory, not a report or point file")
    data = read_regular(path, MAX_REPLAY_BYTES, "replay file")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError:
        raise UsageError.at(path, "not UTF-8") from None


def load_points(path: Path, lemma: str | None, side: str) -> list[Point]:
    """The points in FILE: a `mlca-verify check --json` document (each violated lemma's counterexample, or the
    one of `lemma`, read through the side's signals) or a TOML file with a `[point]` table (and `[params]`). A
    `.json` file is read as JSON; a file of another name as JSON when it starts with `{`, else as TOML."""
    if lemma is not None:
        _lemma_name("mlca-sim replay", "--lemma", lemma)
    text = read_replay_file(path)
    if path.suffix.lower() == ".json" or text.lstrip().startswith("{"):
        return _from_check_json(path, text, lemma, side)
    if lemma is not None:
        raise UsageError.at(path, "--lemma needs a `mlca-verify check --json` file")
    return [_from_toml(path, text)]


def _from_toml(path: Path, text: str) -> Point:
    try:
        doc = tomllib.loads(text)
    except (tomllib.TOMLDecodeError, ValueError, RecursionError) as err:
        raise UsageError.at(path, f"invalid TOML: {str(err) or type(err).__name__}") from None
    unknown = sorted(set(doc) - {"point", "params"})
    if unknown or not isinstance(doc.get("point"), dict):
        raise UsageError.at(path, "a replay file holds a [point] table and an optional [params] table")
    params = doc.get("params", {})
    if not isinstance(params, dict):
        raise UsageError.at(path, "[params] must be a table")
    values = dict(doc["point"])
    expect = values.pop("expect", "safe")
    if expect not in ("safe", "unsafe"):
        raise UsageError.at(path, f'expect must be "safe" or "unsafe", not {expect!r}')
    return replace(_point(path, values, params, str(path)), expect=expect)


def _from_check_json(path: Path, text: str, lemma: str | None, side: str) -> list[Point]:
    try:
        doc = json.loads(text)
    except RecursionError:
        raise UsageError.at(path, "invalid JSON: nested too deeply") from None
    except ValueError as err:
        raise UsageError.at(path, f"invalid JSON: {str(err).splitlines()[0] or type(err).__name__}") from None
    if not isinstance(doc, dict) or doc.get("schema") not in ("mlca-verify.check/2", "mlca-verify.check/3"):
        raise UsageError.at(path, "not a `mlca-verify check --json` document (schema mlca-verify.check/3 or /2)")
    pairs = [
        (spec, result)
        for spec in _list(doc.get("specs"))
        for result in _list(spec.get("results") if isinstance(spec, dict) else None)
        if isinstance(result, dict) and result.get("kind") == "lemma"
    ]
    for _, result in pairs:  # every name checked before any is compared or read further
        _lemma_name(path, "lemma", result.get("property"))
    points: dict[tuple[Any, ...], Point] = {}
    for spec, result in pairs:
        if _wanted(result, lemma) and (lemma is not None or _about(_first_step(result), side)):
            point = _counterexample(path, spec, result, side)
            points.setdefault(_identity(point), point)
    if not points:
        what = f"lemma {lemma}" if lemma else f"a violated lemma about the {side} side"
        raise UsageError.at(path, f"no counterexample of {what} in this file")
    if len(points) > MAX_REPLAY_POINTS:
        raise UsageError.at(
            path,
            f"{len(points)} distinct counterexample points to replay, more than the "
            f"{MAX_REPLAY_POINTS} one file may hold; choose one lemma with --lemma",
        )
    return list(points.values())


def _lemma_name(where: object, what: str, name: object) -> None:
    """Refuse a lemma name no spec could give (PROPERTY_ID, at most NAME_LIMIT characters): an error of `where`
    about `what` (the option or key that gave it)."""
    if not isinstance(name, str):
        raise UsageError.at(where, f"{what} name must be a string, not {type(name).__name__}")
    if len(name) > NAME_LIMIT:
        raise UsageError.at(where, f"{what} name of {len(name):,} characters: a spec allows at most {NAME_LIMIT}")
    if not PROPERTY_ID.fullmatch(name):
        raise UsageError.at(
            where, f"{what} name {name!r} is not a property name: a letter, then letters, digits, '_', '-' or '.'"
        )


def _identity(point: Point) -> tuple[Any, ...]:
    """What makes two points one replay: the spec, the lemma, the values and params, and the expected outcome."""
    values = tuple(getattr(point, k) for k in POINT_KEYS)
    return (
        point.spec,
        point.spec_sha256,
        point.lemma,
        point.source,
        values,
        tuple(sorted(point.params.items())),
        point.expect,
    )


def _counterexample(path: Path, spec: dict[str, Any], result: dict[str, Any], side: str) -> Point:
    """A lemma's counterexample, read through the side's signals (and RSS's params, where it has them)."""
    name = result.get("property")
    cx = result.get("counterexample")
    steps = _list(cx.get("steps")) if isinstance(cx, dict) else []
    signals = steps[0].get("signals") if steps and isinstance(steps[0], dict) else None
    if not isinstance(cx, dict) or not isinstance(signals, dict):
        raise UsageError.at(path, f"lemma {name} has no counterexample to replay")
    if not _about(steps[0], side):
        raise UsageError.at(
            path,
            f"lemma {name} reads no definition of the {side} side (none named *_{side}): its "
            f"counterexample's {side} signals are whatever the solver chose; give the lemma's side with --side",
        )
    names = {"v": "v", **{k: f"{k}_{side}" for k in POINT_KEYS[1:]}}
    missing = [n for n in names.values() if n not in signals]
    if missing:
        raise UsageError.at(
            path,
            f"lemma {name}'s counterexample has no signal {missing[0]}: "
            f"replay reads v, gap_lead_{side}, v_lead_{side}, gap_follow_{side}, v_follow_{side}",
        )
    params = cx.get("params")
    rss = {k: v for k, v in params.items() if k in PARAM_RANGES} if isinstance(params, dict) else {}
    point = _point(path, {k: signals[n] for k, n in names.items()}, rss, f"{spec.get('path')}: {name} ({side})")
    expect = "unsafe" if result.get("expected") == "violated" else "safe"
    sha = str(spec.get("sha256", ""))
    return replace(point, expect=expect, spec=str(spec.get("path")), spec_sha256=sha, lemma=str(name))


def _first_step(result: dict[str, Any]) -> dict[str, Any]:
    cx = result.get("counterexample")
    steps = _list(cx.get("steps")) if isinstance(cx, dict) else []
    return steps[0] if steps and isinstance(steps[0], dict) else {}


def _about(step: dict[str, Any], side: str) -> bool:
    """Whether a counterexample's lemma reads a definition of that side (named `*_left` or `*_right`)."""
    read = step.get("definitions")
    return isinstance(read, dict) and any(str(k).endswith(f"_{side}") for k in read)


def _list(value: object) -> list[Any]:
    return value if isinstance(value, list) else []


def _wanted(result: object, lemma: str | None) -> bool:
    if not isinstance(result, dict) or result.get("kind") != "lemma":
        return False
    if lemma is not None:
        return result.get("property") == lemma
    return result.get("verdict") == "violated"


def _point(path: Path, values: dict[str, Any], params: dict[str, Any], source: str) -> Point:
    unknown = sorted(set(values) - set(POINT_KEYS)) + sorted(set(params) - set(PARAM_RANGES))
    if unknown:
        raise UsageError.at(
            path, f"unknown key {unknown[0]!r} (point: {', '.join(POINT_KEYS)}; params: {', '.join(PARAM_RANGES)})"
        )
    got = [_number(path, k, values.get(k), GAP_RANGE if k.startswith("gap") else SPEED_RANGE) for k in POINT_KEYS]
    rss = {k: _number(path, k, params.get(k, AD_RSS_DEFAULTS[k]), PARAM_RANGES[k]) for k in PARAM_RANGES}
    v, gap_lead, v_lead, gap_follow, v_follow = got
    return Point(v, gap_lead, v_lead, gap_follow, v_follow, params=rss, source=source)


def _number(path: Path, key: str, value: object, bounds: tuple[float, float]) -> float:
    if value is None:
        raise UsageError.at(path, f"{key} is missing")
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise UsageError.at(path, f"{key} must be a number, not {type(value).__name__}")
    if not bounds[0] <= value <= bounds[1]:  # compared as given (an int of any size), NaN fails too
        shown = value if isinstance(value, float) or abs(value) < 10**15 else "a number that large"
        raise UsageError.at(path, f"{key} = {shown} is outside [{bounds[0]:g}, {bounds[1]:g}]")
    return float(value)


# ---- the worst case as speeds -----------------------------------------------------------------------------------


def front_speed(v0: float, t: float, p: dict[str, float]) -> float:
    """A vehicle in front braking at BRAKE_MAX from v0, at time t."""
    return max(0.0, v0 - p["BRAKE_MAX"] * t)


def rear_speed(v0: float, t: float, p: dict[str, float]) -> float:
    """A vehicle behind: accelerating at ACCEL_MAX for RHO, then braking at BRAKE_MIN to a stop."""
    if t <= p["RHO"] + 1e-9:
        return v0 + p["ACCEL_MAX"] * min(t, p["RHO"])
    return max(0.0, v0 + p["ACCEL_MAX"] * p["RHO"] - p["BRAKE_MIN"] * (t - p["RHO"]))


def fastest(point: Point) -> float:
    """The highest speed any vehicle reaches in the worst case (one behind, at the end of its response time)."""
    p = point.params
    return max(point.v, point.v_lead, point.v_follow) + p["ACCEL_MAX"] * p["RHO"]


def horizon(point: Point) -> float:
    """Simulated seconds until every vehicle of the worst case stands, and a margin."""
    p = point.params
    return p["RHO"] + fastest(point) / p["BRAKE_MIN"] + 2.0


# ---- SUMO ---------------------------------------------------------------------------------------------------------


def _network(point: Point, work: Path) -> tuple[Path, float]:
    """A straight two-lane road long enough for the whole worst case; returns the net and the follower's start."""
    reach = fastest(point) * horizon(point)
    length = 100.0 + point.gap_follow + point.gap_lead + 3 * LENGTH_M + reach + 100.0
    return straight_road(work, 2, length), 100.0


def straight_road(work: Path, lanes: int, length: float) -> Path:
    """A straight road of `lanes` lanes (edge `road`), built by netconvert into `work`."""
    (work / "road.nod.xml").write_text(
        f'<nodes>\n  <node id="a" x="0" y="0"/>\n  <node id="b" x="{length:.1f}" y="0"/>\n</nodes>\n'
    )
    (work / "road.edg.xml").write_text(
        f'<edges>\n  <edge id="road" from="a" to="b" numLanes="{lanes}" speed="100"/>\n</edges>\n'
    )
    net = work / "road.net.xml"
    done = subprocess.run(
        [
            sumo_bin("netconvert"),
            "--node-files",
            str(work / "road.nod.xml"),
            "--edge-files",
            str(work / "road.edg.xml"),
            "--no-warnings",
            "true",
            "-o",
            str(net),
        ],
        capture_output=True,
        text=True,
        check=False,
    )
    if done.returncode != 0:
        raise ToolError(f"error: netconvert failed: {done.stderr.strip()}")
    return net


def _routes(point: Point, work: Path, start: float) -> Path:
    """The three vehicles, placed so that the gaps are the point's when the AV has entered its new lane: SUMO
    inserts them in the first step and moves them, at constant speeds, in the second, when the AV changes lane."""
    before = STEP_S
    fol = start
    av = fol + point.gap_follow + LENGTH_M
    lead = av + point.gap_lead + LENGTH_M
    p = point.params
    kinds = (
        ("leader", lead - point.v_lead * before, point.v_lead, 1),
        ("av", av - point.v * before, point.v, 0),
        ("follower", fol - point.v_follow * before, point.v_follow, 1),
    )
    lines = [
        "<routes>",
        f'  <vType id="replay" length="{LENGTH_M}" minGap="0" maxSpeed="100" accel="{max(p["ACCEL_MAX"], 0.1)}" '
        f'decel="{p["BRAKE_MIN"]}" emergencyDecel="{max(EMERGENCY_DECEL, p["BRAKE_MAX"], p["BRAKE_MIN"])}" '
        f'apparentDecel="{p["BRAKE_MAX"]}" tau="{STEP_S}" sigma="0" speedDev="0"/>',
        '  <route id="r" edges="road"/>',
    ]
    for vid, pos, speed, lane in kinds:
        lines.append(
            f'  <vehicle id="{vid}" type="replay" route="r" depart="0" departLane="{lane}" departPos="{pos:.6f}" '
            f'departSpeed="{speed:.6f}" insertionChecks="none"/>'
        )
    lines.append("</routes>")
    path = work / "replay.rou.xml"
    path.write_text("\n".join(lines) + "\n")
    return path


def _sumo_args(net: Path, routes: Path) -> list[str]:
    return sumo_command(net, routes, "--step-length", str(STEP_S), "--step-method.ballistic", "true")


ROLES = {  # phase -> role of leader, av, follower
    "leader brakes": ("front", "rear", "rear"),
    "AV brakes": ("steady", "front", "rear"),
}


def _phase(sumo: Any, point: Point, name: str, net: Path, routes: Path) -> Phase:
    p = point.params
    roles = dict(zip(("leader", "av", "follower"), ROLES[name], strict=True))
    start_speed = {"leader": point.v_lead, "av": point.v, "follower": point.v_follow}
    phase = Phase(name)
    phase.vehicles = [
        Vehicle(vid, role, {"front": p["BRAKE_MAX"], "rear": p["BRAKE_MIN"]}.get(role)) for vid, role in roles.items()
    ]
    sumo.start(_sumo_args(net, routes))
    try:
        for vid, speed in start_speed.items():  # driven by the replay, at constant speed until the change is made
            sumo.vehicle.setSpeedMode(vid, 0)
            sumo.vehicle.setLaneChangeMode(vid, 0)
            sumo.vehicle.setSpeed(vid, speed)
        sumo.simulationStep()
        sumo.vehicle.changeLane("av", 1, 10.0)
        sumo.simulationStep()
        if sumo.vehicle.getLaneIndex("av") != 1:
            raise ToolError("error: SUMO did not make the AV's lane change")
        phase.start_gaps = _gaps(sumo)
        if abs(phase.start_gaps[0] - point.gap_lead) > 1e-6 or abs(phase.start_gaps[1] - point.gap_follow) > 1e-6:
            raise ToolError(f"error: SUMO placed the vehicles {phase.start_gaps} apart, not at the point's gaps")
        _drive(sumo, point, phase, roles, start_speed)
    finally:
        sumo.close()
    return phase


def _drive(sumo: Any, point: Point, phase: Phase, roles: dict[str, str], v0: dict[str, float]) -> None:
    p = point.params
    last = {vid: sumo.vehicle.getSpeed(vid) for vid in roles}
    steps = math.ceil(horizon(point) / STEP_S)
    responding = p["RHO"] + 1e-9  # a step ends within the response time when k * STEP_S <= RHO (binary64 aside)
    for k in range(1, steps + 1):
        t = k * STEP_S
        for vid, role in roles.items():
            if role == "front":
                sumo.vehicle.setSpeed(vid, front_speed(v0[vid], t, p))
            elif role == "steady":
                sumo.vehicle.setSpeed(vid, v0[vid])
            else:  # behind: the response time ignores safety; then brake at BRAKE_MIN, SUMO's safe speed permitting
                sumo.vehicle.setSpeedMode(vid, 0 if t <= responding else 1)
                sumo.vehicle.setSpeed(vid, rear_speed(v0[vid], t, p))
        sumo.simulationStep()
        for c in sumo.simulation.getCollisions():
            pair = sorted((c.collider, c.victim))
            if pair not in phase.collisions:
                phase.collisions.append(pair)
        lead, follow = _gaps(sumo)
        phase.min_gap_lead, phase.min_gap_follow = min(phase.min_gap_lead, lead), min(phase.min_gap_follow, follow)
        for vehicle in phase.vehicles:
            speed = sumo.vehicle.getSpeed(vehicle.id)
            vehicle.hardest = max(vehicle.hardest, (last[vehicle.id] - speed) / STEP_S)
            last[vehicle.id] = speed
        phase.seconds = t
        if all(s == 0.0 for vid, s in last.items() if roles[vid] != "steady") and t > p["RHO"]:
            break


def _gaps(sumo: Any) -> tuple[float, float]:
    """Bumper to bumper: AV to its new leader, new follower to the AV (negative when they overlap)."""
    x = {vid: sumo.vehicle.getLanePosition(vid) for vid in ("leader", "av", "follower")}
    return x["leader"] - LENGTH_M - x["av"], x["av"] - LENGTH_M - x["follower"]


def replay(point: Point, work: Path) -> list[Phase]:
    """Both phases of one point, each in a SUMO run of its own."""
    import libsumo

    work.mkdir(parents=True, exist_ok=True)
    net, start = _network(point, work)
    routes = _routes(point, work, start)
    return [_phase(libsumo, point, name, net, routes) for name in PHASES]


# ---- the report -----------------------------------------------------------------------------------------------------


def outcome(phases: list[Phase]) -> str:
    """ "unsafe" when a phase ended in a collision or with braking beyond a declared limit, else "safe"."""
    return "unsafe" if any(ph.unsafe for ph in phases) else "safe"


def describe(point: Point, phases: list[Phase]) -> str:
    """The replay of a point as lines for a terminal: the file's text in them (the source) escaped."""
    p = point.params
    lines = [
        f"{terminal(point.source)}: AV at {point.v:g} m/s; new leader {point.gap_lead:g} m ahead at "
        f"{point.v_lead:g} m/s; new follower {point.gap_follow:g} m behind at {point.v_follow:g} m/s",
        f"  RSS params: RHO {p['RHO']:g} s, ACCEL_MAX {p['ACCEL_MAX']:g} m/s^2, BRAKE_MIN {p['BRAKE_MIN']:g} m/s^2, "
        f"BRAKE_MAX {p['BRAKE_MAX']:g} m/s^2",
    ]
    got = outcome(phases)
    lines[0] += f" (expected {point.expect}: {'as expected' if got == point.expect else 'NOT AS EXPECTED'})"
    for ph in phases:
        verdict = "UNSAFE" if ph.unsafe else "safe"
        collided = ", ".join("-".join(pair) for pair in ph.collisions) or "none"
        braked = "; ".join(
            f"{v.id} {v.hardest:.2f} m/s^2 (limit {v.limit:g}{', BEYOND' if v.beyond else ''})"
            for v in ph.vehicles
            if v.role != "steady"
        )
        lines.append(
            f"  {ph.name:13} {verdict:6}  collisions: {collided}; smallest gap to the leader {ph.min_gap_lead:.2f} m, "
            f"from the follower {ph.min_gap_follow:.2f} m; hardest braking: {braked}"
        )
    return "\n".join(lines)


def _finite(x: float) -> float | None:
    """JSON has no NaN or infinity: a gap never measured is null."""
    return x if math.isfinite(x) else None


def as_json(point: Point, phases: list[Phase]) -> dict[str, Any]:
    return {
        "point": {k: getattr(point, k) for k in POINT_KEYS},
        "params": point.params,
        "source": point.source,
        "spec": point.spec,
        "spec_sha256": point.spec_sha256,
        "lemma": point.lemma,
        "expect": point.expect,
        "outcome": outcome(phases),
        "phases": [
            {
                "name": ph.name,
                "unsafe": ph.unsafe,
                "collisions": ph.collisions,
                "min_gap_lead_m": _finite(ph.min_gap_lead),
                "min_gap_follow_m": _finite(ph.min_gap_follow),
                "start_gaps_m": [_finite(g) for g in ph.start_gaps],
                "simulated_s": round(ph.seconds, 6),
                "vehicles": [{**asdict(v), "beyond": v.beyond} for v in ph.vehicles],
            }
            for ph in phases
        ],
    }
