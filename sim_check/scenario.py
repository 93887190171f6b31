"""The scenario: a scenario file (TOML, defaults from the paper) turned into a SUMO network and seeded traffic.

The network is plain XML (nodes, edges, connections) built by SUMO's netconvert: an approach of the highway, an
on-ramp joining it as an acceleration lane (lane 0 of the `acc` edge, which ends), and the highway. The traffic
is drawn from the seed by this module, written into the route file with every vehicle's departure, lane and
speed factor, so that runs with one and with three AVs share the same background traffic.
"""

from __future__ import annotations

import math
import random
import re
import subprocess
import tomllib
from dataclasses import dataclass, field, fields, replace
from pathlib import Path
from typing import Any

from mlca_verify.errors import Loc, SpecError, ToolError
from mlca_verify.files import read_regular
from mlca_verify.spec.locate import Locator
from sim_check.need import NEED_SOURCES
from sim_check.radio import V2V

PAPER = Path(__file__).with_name("paper.toml")
MAX_SCENARIO_BYTES = 1_000_000
MAX_SEED = 2**31 - 1  # SUMO's --seed is a 32-bit signed integer
_TOML_AT = re.compile(r" \(at line (\d+), column (\d+)\)$")


@dataclass(frozen=True)
class Road:
    lanes: int = 5
    length_m: float = 20500
    highway_speed_kmh: float = 80
    ramp_speed_kmh: float = 45
    ramp_length_m: float = 300
    merge_length_m: float = 250
    approach_m: float = 500
    osm: str = ""  # an OpenStreetMap file to import instead of the built-in highway (relative to the scenario)
    route: str = ""  # with `osm`: the edge ids every vehicle drives, space-separated


@dataclass(frozen=True)
class Traffic:
    cars: int = 100
    avs: int = 1
    depart_window_s: float = 300
    av_depart_s: float = 30
    step_s: float = 0.1
    target_lane: str = "middle"
    need: str = "sumo"  # where the sensed controllers' need comes from (sim_check.need): sumo or middle
    av_arrival_lane: str = ""  # the lane the AVs leave the road from (SUMO's arrivalLane), "" for any


LIMITS: dict[str, tuple[float, float]] = {  # beyond these a value is a mistake, or a run no machine finishes
    "lanes": (1, 10),
    "length_m": (1, 200_000),
    "highway_speed_kmh": (1, 300),
    "ramp_speed_kmh": (1, 300),
    "ramp_length_m": (1, 10_000),
    "merge_length_m": (1, 10_000),
    "approach_m": (1, 10_000),
    "cars": (1, 10_000),
    "avs": (1, 100),
    "depart_window_s": (0, 3600),
    "av_depart_s": (0, 3600),
    "step_s": (0.001, 10),
    "loss": (0, 1),
    "lost_in_row": (0, 100),
    "delay": (1, 100),
    "max_delay": (1, 100),
    "duplicate": (0, 1),
    "radius_m": (0.1, 1000),
}
MAY_BE_ZERO = {"loss", "lost_in_row", "duplicate"}  # a channel that loses or repeats nothing


@dataclass(frozen=True)
class Scenario:
    """A scenario of the closed loop: the road, the traffic on it and the AVs, and the radio between the AVs (the
    defaults are the paper's, `sim_check/paper.toml`)."""

    road: Road = Road()
    traffic: Traffic = Traffic()
    v2v: V2V = field(default_factory=V2V)  # the radio of the controllers that talk to the other AVs (sim_check.radio)

    def with_avs(self, avs: int) -> Scenario:
        """The same scenario with `avs` AVs."""
        return replace(self, traffic=replace(self.traffic, avs=avs))

    @property
    def target_lane(self) -> int:
        """Highway lane index (0 = rightmost) the AVs settle in."""
        return self._lane(self.traffic.target_lane)

    @property
    def arrival_lane(self) -> int | None:
        """Highway lane index the AVs leave the road from, or None where they may leave from any."""
        return self._lane(self.traffic.av_arrival_lane) if self.traffic.av_arrival_lane else None

    def _lane(self, name: str) -> int:
        return self.road.lanes // 2 if name == "middle" else int(name)


def load_scenario(path: Path | None = None) -> Scenario:
    """Read a scenario file; every key is optional and defaults to the paper's value. Errors name file:line:col."""
    path = path or PAPER
    text = _read(path)
    doc = _parse(path, text)
    where = Locator(str(path), text)
    sections: dict[str, Any] = {"road": Road(), "traffic": Traffic(), "v2v": V2V()}
    for key, table in doc.items():
        if key not in sections:
            raise SpecError(where.loc((key,)), f"unknown section [{key}] (known: {', '.join(sections)})")
        if not isinstance(table, dict):
            raise SpecError(where.loc((key,)), f"'{key}' must be a table ([{key}]), got {_show(table)}")
        sections[key] = _section(sections[key], table, where, key)
    scenario = Scenario(**sections)
    _check_lane(scenario, where)
    if scenario.v2v.max_delay < scenario.v2v.delay:
        raise SpecError(
            where.loc(("v2v", "max_delay")),
            f"'max_delay' in [v2v] is {scenario.v2v.max_delay}, less than 'delay' ({scenario.v2v.delay})",
        )
    return _with_osm(scenario, path, where)


def _read(path: Path) -> str:
    data = read_regular(path, MAX_SCENARIO_BYTES, "scenario")
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as err:
        line, col = data.count(b"\n", 0, err.start) + 1, err.start - data.rfind(b"\n", 0, err.start)
        raise SpecError(Loc(str(path), line, col), f"not UTF-8: byte 0x{data[err.start]:02x}") from None


def _parse(path: Path, text: str) -> dict[str, Any]:
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as err:
        message, line, col = _toml_position(str(err), text)
        raise SpecError(Loc(str(path), line, col), f"invalid TOML: {message}") from None
    except (ValueError, RecursionError) as err:  # an integer of thousands of digits, arrays nested thousands deep
        raise SpecError(Loc(str(path), 1, 1), f"invalid TOML: {str(err) or type(err).__name__}") from None


def _toml_position(message: str, text: str) -> tuple[str, int, int]:
    """tomllib's message without its position, and the position: line and column, or the end of the text."""
    if found := _TOML_AT.search(message):
        return message[: found.start()], int(found[1]), int(found[2])
    lines = text.split("\n")
    return message.removesuffix(" (at end of document)"), len(lines), len(lines[-1]) + 1


def _section(default: Any, table: dict[str, Any], where: Locator, name: str) -> Any:
    known = {f.name: str(f.type) for f in fields(default)}
    values: dict[str, Any] = {}
    for key, given in table.items():
        if key not in known:
            raise SpecError(where.loc((name, key)), f"unknown key '{key}' in [{name}] (known: {', '.join(known)})")
        at, what = where.loc((name, key)), f"'{key}' in [{name}]"
        if key == "target_lane" or (key == "av_arrival_lane" and given != ""):
            values[key] = _lane_name(given, at, what)
        elif known[key] == "str":
            values[key] = _text(key, given, at, what)
        elif known[key] == "bool":
            if not isinstance(given, bool):
                raise SpecError(at, f"{what} must be true or false, got {_show(given)}")
            values[key] = given
        else:
            values[key] = _number(
                given,
                LIMITS[key],
                at,
                what,
                continuous=known[key] == "float",
                as_float=isinstance(getattr(default, key), float),
                positive=key not in MAY_BE_ZERO,
            )
    return replace(default, **values)


def _number(
    given: object,
    limits: tuple[float, float],
    at: Loc,
    what: str,
    *,
    continuous: bool,
    as_float: bool,
    positive: bool = True,
) -> int | float:
    """A count (int) or a continuous quantity (int or float), finite, within `limits` and (where `positive`) more
    than 0; a float where the default is one (so that the files written for a scenario stay what they were)."""
    if isinstance(given, bool) or not isinstance(given, int | float) or (not continuous and isinstance(given, float)):
        raise SpecError(at, f"{what} must be {'a number' if continuous else 'a whole number'}, got {_show(given)}")
    low, high = limits
    if not math.isfinite(given):
        raise SpecError(at, f"{what} must be a finite number, got {_show(given)}")
    if given <= 0 and (positive or given < 0):
        raise SpecError(at, f"{what} must be {'positive' if positive else 'at least 0'}, got {_show(given)}")
    if not low <= given <= high:
        raise SpecError(
            at, f"{what} must be {f'at least {low:g}' if given < low else f'at most {high:g}'}, got {_show(given)}"
        )
    return float(given) if as_float else given


def _text(key: str, given: object, at: Loc, what: str) -> str:
    if not isinstance(given, str):
        raise SpecError(at, f"{what} must be a string, got {_show(given)}")
    if key == "need" and given not in NEED_SOURCES:
        raise SpecError(at, f"{what} must be one of {', '.join(NEED_SOURCES)}, got {_show(given)}")
    if key == "route" and (bad := re.search(r"[<>&\"'\x00-\x1f]", given.replace("\t", " "))):
        raise SpecError(at, f"{what}: edge ids cannot hold {bad[0]!r}")
    return given


def _lane_name(given: object, at: Loc, what: str) -> str:
    """`middle` or a lane index (an integer, or its digits as a string), checked against the lanes later."""
    lane = given if isinstance(given, str) else str(given) if type(given) is int and 0 <= given < 100 else None
    if lane is None or not re.fullmatch(r"middle|[0-9]{1,2}", lane):
        raise SpecError(at, f'{what} must be "middle" or a lane index (0 = rightmost), got {_show(given)}')
    return lane


def _check_lane(scenario: Scenario, where: Locator) -> None:
    lanes = scenario.road.lanes
    for key in ("target_lane", "av_arrival_lane"):
        lane = getattr(scenario.traffic, key)
        if lane not in ("", "middle") and int(lane) >= lanes:
            raise SpecError(
                where.loc(("traffic", key)),
                f"'{key}' in [traffic] is lane {lane}, but the road has {lanes} lanes (0 = rightmost to {lanes - 1})",
            )


def _with_osm(scenario: Scenario, path: Path, where: Locator) -> Scenario:
    road = scenario.road
    if not road.osm:
        return scenario
    osm = (path.parent / road.osm).resolve()
    if not osm.is_file():
        raise SpecError(where.loc(("road", "osm")), f"OpenStreetMap file '{road.osm}' not found (looked for {osm})")
    if not road.route.split():
        raise SpecError(where.loc(("road", "osm")), "an OpenStreetMap road needs 'route', the edge ids to drive")
    if scenario.traffic.av_arrival_lane:
        raise SpecError(
            where.loc(("traffic", "av_arrival_lane")), "'av_arrival_lane' is for the built-in highway, not an OSM road"
        )
    return replace(scenario, road=replace(road, osm=str(osm)))


def _show(value: object) -> str:
    """A value as an error shows it: at most 40 characters (an integer of thousands of digits included)."""
    if isinstance(value, int) and abs(value) >= 10**40:
        return "an integer of more than 40 digits"
    text = repr(value)
    return text if len(text) <= 40 else f"{text[:37]}..."


@dataclass(frozen=True)
class Built:
    net: Path
    routes: Path
    av_ids: tuple[str, ...]


# SUMO's options every run shares: collisions are physical contact, reported and driven on (SUMO's own files and
# libsumo's getCollisions list them); and nothing printed into the Python process (sumo-facts.md).
COLLISION_OPTIONS = (
    "--collision.action",
    "warn",
    "--collision.check-junctions",
    "true",
    "--collision.mingap-factor",
    "0",
)
QUIET_OPTIONS = ("--no-step-log", "true", "--duration-log.disable", "true", "--no-warnings", "true")


def sumo_command(net: Path, routes: Path, *options: str) -> list[str]:
    """SUMO on a network and its routes, with the options every run shares and then `options`."""
    return [sumo_bin("sumo"), "-n", str(net), "-r", str(routes), *COLLISION_OPTIONS, *QUIET_OPTIONS, *options]


def sumo_bin(tool: str) -> str:
    import sumo

    return str(Path(sumo.SUMO_HOME) / "bin" / tool)


def build(scenario: Scenario, seed: int, work: Path, av_type: str = "") -> Built:
    """Write the network (by netconvert) and the seeded routes for one run into `work`; `av_type` holds extra
    vType attributes of the AVs (a controller's car-following or lane-change model)."""
    work.mkdir(parents=True, exist_ok=True)
    net = work / ("osm.net.xml" if scenario.road.osm else "highway.net.xml")
    if not net.exists():
        if scenario.road.osm:
            sources = ["--osm-files", scenario.road.osm]
        else:
            _write_plain(scenario.road, work)
            sources = [
                "--node-files",
                str(work / "highway.nod.xml"),
                "--edge-files",
                str(work / "highway.edg.xml"),
                "--connection-files",
                str(work / "highway.con.xml"),
            ]
        done = subprocess.run(
            [sumo_bin("netconvert"), *sources, "--no-turnarounds", "true", "--no-warnings", "true", "-o", str(net)],
            capture_output=True,
            text=True,
            check=False,
        )
        if done.returncode != 0:
            raise ToolError(f"error: netconvert failed: {done.stderr.strip()}")
    routes = work / f"seed{seed}_avs{scenario.traffic.avs}.rou.xml"
    av_ids = _write_routes(scenario, seed, routes, av_type)
    return Built(net, routes, av_ids)


def _write_plain(road: Road, work: Path) -> None:
    a, m = road.approach_m, road.merge_length_m
    end = a + m + road.length_m
    hw, ramp = road.highway_speed_kmh / 3.6, road.ramp_speed_kmh / 3.6
    (work / "highway.nod.xml").write_text(
        "<nodes>\n"
        f'  <node id="hw_start" x="0" y="0"/>\n  <node id="merge_start" x="{a}" y="0"/>\n'
        f'  <node id="merge_end" x="{a + m}" y="0"/>\n  <node id="hw_end" x="{end}" y="0"/>\n'
        f'  <node id="ramp_start" x="{a - road.ramp_length_m}" y="-150"/>\n'
        "</nodes>\n"
    )
    (work / "highway.edg.xml").write_text(
        "<edges>\n"
        f'  <edge id="hw_in" from="hw_start" to="merge_start" numLanes="{road.lanes}" speed="{hw:.3f}"/>\n'
        f'  <edge id="ramp" from="ramp_start" to="merge_start" numLanes="1" speed="{ramp:.3f}"/>\n'
        f'  <edge id="acc" from="merge_start" to="merge_end" numLanes="{road.lanes + 1}" speed="{hw:.3f}"/>\n'
        f'  <edge id="hw" from="merge_end" to="hw_end" numLanes="{road.lanes}" speed="{hw:.3f}"/>\n'
        "</edges>\n"
    )
    connections = ['  <connection from="ramp" to="acc" fromLane="0" toLane="0"/>']
    for lane in range(road.lanes):
        connections.append(f'  <connection from="hw_in" to="acc" fromLane="{lane}" toLane="{lane + 1}"/>')
        connections.append(f'  <connection from="acc" to="hw" fromLane="{lane + 1}" toLane="{lane}"/>')
    (work / "highway.con.xml").write_text("<connections>\n" + "\n".join(connections) + "\n</connections>\n")


def _write_routes(scenario: Scenario, seed: int, path: Path, av_type: str) -> tuple[str, ...]:
    rng = random.Random(seed)
    t = scenario.traffic
    cars = []
    osm = bool(scenario.road.osm)
    lanes = scenario.road.lanes
    for k in range(t.cars):
        depart = rng.uniform(0, t.depart_window_s)
        on_ramp = rng.random() < 0.1 and not osm
        lane = 0 if on_ramp else rng.randrange(lanes)
        factor = max(0.7, min(1.3, rng.gauss(1.0, 0.1)))
        cars.append((depart, f"car{k}", "ramp_route" if on_ramp else "main_route", lane, factor))
    av_route = "main_route" if osm else "ramp_route"
    avs = [(t.av_depart_s + 10.0 * k, f"av{k}", av_route, 0, 1.0) for k in range(t.avs)]
    main = scenario.road.route if osm else "hw_in acc hw"
    lines = [
        "<routes>",
        '  <vType id="car" vClass="passenger" speedDev="0.1"/>',
        f'  <vType id="av" vClass="passenger" speedDev="0" color="0,200,0"{" " + av_type if av_type else ""}/>',
        f'  <route id="main_route" edges="{main}"/>',
        *([] if osm else ['  <route id="ramp_route" edges="ramp acc hw"/>']),
    ]
    if osm:  # departure lanes must exist on the first edge of the route; the OSM road decides how many
        cars = [(d, v, r, 0, f) for d, v, r, _, f in cars]
    arrival = "" if scenario.arrival_lane is None else f' arrivalLane="{scenario.arrival_lane}"'
    for depart, vid, route, lane, factor in sorted(cars + avs):
        av = vid.startswith("av")
        lines.append(
            f'  <vehicle id="{vid}" type="{"av" if av else "car"}" route="{route}" depart="{depart:.1f}" '
            f'departLane="{lane}" departSpeed="desired" speedFactor="{factor:.3f}"{arrival if av else ""}/>'
        )
    lines.append("</routes>")
    path.write_text("\n".join(lines) + "\n")
    return tuple(vid for _, vid, *_ in avs)
