"""`mlca-sim replay` of a network's counterexample (`mlca-verify check --json` of a network spec, schema /3): the
scene its instances make, driven in SUMO by their generated controllers, their claims carried by a radio at the
worst the network's channels allow.

The scene: a straight three-lane road, empty but for the instances whose claims the network carries; each AV whose
`claims_left` a channel carries starts in lane 0 (the gap, lane 1, on its left), each whose `claims_right` one
carries in lane 2, all side by side at one speed. Each AV needs the gap (and is urgent) where the counterexample
says it does at some step, from the start until it has changed lane. Each is driven by its own instance of the
generated code of its machine (or of `--controller`, another protocol on the same scene), on the gaps and speeds
SUMO senses; the radio loses as many messages in a row as the channels allow, every time, and delivers the others
as late as they allow. The replay reports what the network's "not both into the gap" forbids, seen in traffic:
two AVs moving into one lane within the radio's radius at the same step, and SUMO's collisions.

The pure part (reading the scenes, the verdict) is free of SUMO; `run_scene` drives libsumo.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from fractions import Fraction
from pathlib import Path
from typing import Any

from mlca_verify.errors import UsageError
from mlca_verify.spec import load_spec
from mlca_verify.words import count
from sim_check.controllers import V2V_CONTROLLERS, load_controller
from sim_check.radio import V2V, Claim, Moves, Radio, Traffic, heard
from sim_check.reads import Reads
from sim_check.replay import LENGTH_M, STEP_S, straight_road
from sim_check.scenario import sumo_command
from sim_check.signals import signals

ROAD_M = 2000.0
START_M = 300.0
CRUISE_MS = 20.0  # the AVs' speed when the scene begins (72 km/h)
SCENE_STEPS = 300  # 30 s
AFTER_S = 3.0  # driven on after the last AV has changed lane
GAP_LANE = 1
MAX_SCENES = 50
SIDE_LANES = {"claims_left": GAP_LANE - 1, "claims_right": GAP_LANE + 1}


@dataclass(frozen=True)
class Scene:
    """One network counterexample as a scene: where each AV starts, what it needs, what drives it, the radio."""

    source: str  # the spec and the property
    lanes: dict[str, int]  # instance -> its lane (GAP_LANE - 1 or GAP_LANE + 1)
    needs: dict[str, tuple[bool, bool]]  # instance -> (N, U)
    controllers: dict[str, str]  # instance -> the controller that drives it
    radio: V2V
    expect: str | None = "conflict"  # driven by its own machines, a violation shows; by another protocol: no guess
    params: dict[str, dict[str, float | int]] = field(default_factory=dict)  # instance -> its params


@dataclass
class SceneRun:
    moved_s: dict[str, float] = field(default_factory=dict)  # instance -> when it changed lane
    collisions: list[list[str]] = field(default_factory=list)
    traffic: Traffic = field(default_factory=Traffic)
    seconds: float = 0.0

    @property
    def conflict(self) -> bool:
        return bool(self.traffic.conflicts or self.collisions)


# ---- reading the scenes ---------------------------------------------------------------------------------------


Drivers = dict[str, tuple[str, dict[str, float | int]]]  # instance -> the controller and the params it runs with


def network_drivers(network: Path) -> Drivers:
    """Each instance of a network spec as a driver: its machine's V2V controller and the params it sets."""
    loaded = load_spec(network, compare=False, network=True)
    if loaded.network is None:
        raise UsageError.at(network, "not a network spec: --network names one whose instances drive the scene")
    drivers: Drivers = {}
    for inst in loaded.network.instances:
        own = {p.name: p.default for p in load_spec(network.parent / inst.spec, compare=False).machine.params}
        overrides = {p.name: _number(p.default, p.type) for p in inst.machine.params if p.default != own.get(p.name)}
        drivers[inst.name] = (_own_controller(network, str(network), inst.name, inst.machine.name), overrides)
    return drivers


def _number(value: Fraction, kind: str) -> float | int:
    return int(value) if kind == "int" else float(value)


def load_scenes(path: Path, text: str, controller: str | None, drivers: Drivers | None = None) -> list[Scene]:
    """The scenes of every violated invariant of a network in a `mlca-verify check --json` document (none for a
    document without networks); `controller` drives every AV instead of each instance's own machine, and
    `drivers` (another network's instances, by name) drive them with their params."""
    try:
        doc = json.loads(text)
    except (ValueError, RecursionError):
        return []  # not JSON: a point file, read by sim_check.replay
    scenes = [
        _scene(path, spec, result, controller, drivers)
        for spec in _items(doc.get("specs") if isinstance(doc, dict) else None)
        if isinstance(spec, dict) and isinstance(spec.get("network"), dict)
        for result in _items(spec.get("results"))
        if isinstance(result, dict) and result.get("kind") == "invariant" and result.get("verdict") == "violated"
    ]
    if len(scenes) > MAX_SCENES:
        raise UsageError.at(
            path, f"{len(scenes)} network counterexamples, more than the {MAX_SCENES} one file may hold"
        )
    return scenes


def _scene(
    path: Path, spec: dict[str, Any], result: dict[str, Any], controller: str | None, drivers: Drivers | None
) -> Scene:
    network = spec["network"]
    source = f"{_text(spec.get('path'))}: {_text(result.get('property'))}"
    lanes = _lanes(path, source, network.get("channels"))
    cex = result.get("counterexample")
    steps = cex.get("steps") if isinstance(cex, dict) else None
    if not isinstance(steps, list) or not steps or not isinstance(steps[-1], dict):
        raise UsageError.at(path, f"{source}: a violated invariant without its counterexample's steps")
    inputs = [s["inputs"] for s in steps if isinstance(s, dict) and isinstance(s.get("inputs"), dict)]
    needs = {name: (_ever(inputs, f"{name}.N"), _ever(inputs, f"{name}.U")) for name in lanes}
    machines = {i.get("name"): i.get("machine") for i in _items(network.get("instances")) if isinstance(i, dict)}
    radio = _worst(network.get("channels"))
    if drivers is not None:
        if missing := sorted(set(lanes) - set(drivers)):
            raise UsageError.at(path, f"{source}: --network has no instance {missing[0]} to drive it")
        chosen = {name: drivers[name][0] for name in lanes}
        return Scene(source, lanes, needs, chosen, radio, None, {name: drivers[name][1] for name in lanes})
    chosen = {name: controller or _own_controller(path, source, name, machines.get(name)) for name in lanes}
    return Scene(source, lanes, needs, chosen, radio, None if controller else "conflict")


def _ever(inputs: list[dict[str, Any]], name: str) -> bool:
    """Whether an input of the counterexample holds at some step (the AV needs the gap, or is urgent)."""
    return any(step.get(name) is True for step in inputs)


def _lanes(path: Path, source: str, channels: object) -> dict[str, int]:
    """Each AV whose claims a channel carries, and the lane its claims say it starts in."""
    lanes: dict[str, int] = {}
    for ch in _items(channels):
        sender, _, port = _text(ch.get("from") if isinstance(ch, dict) else None).partition(".")
        if port not in SIDE_LANES:
            raise UsageError.at(
                path,
                f"{source}: channel from {sender}.{port}: a replay places AVs by their claims_left or claims_right",
            )
        if lanes.setdefault(sender, SIDE_LANES[port]) != SIDE_LANES[port]:
            raise UsageError.at(path, f"{source}: {sender} claims both sides: no one lane to start it in")
    if len(lanes) < 2:
        raise UsageError.at(path, f"{source}: fewer than two AVs send claims: no scene to replay")
    return dict(sorted(lanes.items()))


def _own_controller(path: Path, source: str, instance: str, machine: object) -> str:
    name = f"{_text(machine).lower()}-c"
    if name not in V2V_CONTROLLERS:
        raise UsageError.at(
            path,
            f"{source}: instance {instance}'s machine {_text(machine)!r} has no V2V controller in the closed loop; "
            "give --controller",
        )
    return name


def _worst(channels: object) -> V2V:
    """The radio at the worst the channels allow: as many lost in a row as any allows, every time, and the rest
    as late as any allows."""
    chs = [c for c in _items(channels) if isinstance(c, dict)]
    lost = max((_count(c.get("lost"), 0) for c in chs), default=0)
    late = max((_count(c.get("max_delay"), 1) for c in chs), default=1)
    return V2V(loss=1.0 if lost else 0.0, lost_in_row=lost, delay=late, max_delay=late)


def _count(value: object, least: int) -> int:
    """A channel's count as the report gives it, within what a channel may say (sim_check.scenario's limits)."""
    return min(max(value, least), 100) if isinstance(value, int) and not isinstance(value, bool) else least


def _items(value: object) -> list[Any]:
    return value if isinstance(value, list) else []


def _text(value: object) -> str:
    return value[:200] if isinstance(value, str) else "?"


# ---- driving a scene ------------------------------------------------------------------------------------------


def run_scene(scene: Scene, work: Path) -> SceneRun:
    """One scene in SUMO, until every AV has changed lane and AFTER_S has passed, or SCENE_STEPS."""
    import libsumo

    work.mkdir(parents=True, exist_ok=True)
    net = straight_road(work, 3, ROAD_M)
    routes = _routes(scene, work)
    loop = SceneLoop(libsumo, scene)
    libsumo.start(sumo_command(net, routes, "--step-length", str(STEP_S)))
    try:
        libsumo.simulationStep()
        for name in scene.lanes:
            libsumo.vehicle.setLaneChangeMode(name, 0)
        for k in range(SCENE_STEPS):
            if loop.step(k):
                break
    finally:
        libsumo.close()
    loop.run.traffic = loop.radio.traffic
    return loop.run


class SceneLoop:
    """A scene between two SUMO steps: each AV's controller and context, the radio, what happened."""

    def __init__(self, sumo: Any, scene: Scene) -> None:
        self.sumo, self.scene, self.read = sumo, scene, Reads(sumo)
        self.ctrls = {name: load_controller(c) for name, c in scene.controllers.items()}
        self.contexts = {name: ctrl.context(scene.params.get(name)) for name, ctrl in self.ctrls.items()}
        self.run, self.radio, self.moves = SceneRun(), Radio.seeded(scene.radio, 0), Moves(scene.radio.radius_m)

    def step(self, k: int) -> bool:
        """Step `k` of every AV, then of SUMO; True when the scene is over."""
        for name in self.scene.lanes:
            self.decide(k, name)
        self.moves.end_step(self.radio.traffic)
        self.sumo.simulationStep()
        run = self.run
        run.seconds = (k + 1) * STEP_S
        for c in self.sumo.simulation.getCollisions():
            if (pair := sorted((c.collider, c.victim))) not in run.collisions:
                run.collisions.append(pair)
        return len(run.moved_s) == len(self.scene.lanes) and run.seconds > max(run.moved_s.values()) + AFTER_S

    def decide(self, k: int, name: str) -> None:
        """One step of one AV's controller, on what it senses and hears: its claims sent, its move commanded."""
        sumo, scene, ctrl = self.sumo, self.scene, self.ctrls[name]
        lane, pos = sumo.vehicle.getLaneIndex(name), sumo.vehicle.getLanePosition(name)
        need, urgent = scene.needs[name]
        need = need and name not in self.run.moved_s
        side = 1 if scene.lanes[name] < GAP_LANE else -1
        left, right = heard(self.radio.read(k, name), "road", lane, pos, scene.radio.radius_m)
        speed = sumo.vehicle.getSpeed(name)
        sensed = signals(self.read, name, lane, lanes=3, speed=speed, side=side if need else 0)
        _, *outputs = ctrl.advance(self.contexts[name], need, left, right, urgent and need, *sensed)
        claims = [outputs[at] for at in ctrl.claims_at]
        self.radio.send_claims(k, name, ("road", lane, pos), claims, list(scene.lanes))
        command = outputs[ctrl.command_at] if ctrl.command_at is not None else 0
        if command and name not in self.run.moved_s:
            self.moves.moving(Claim(name, "road", lane + command, pos))
            sumo.vehicle.changeLane(name, lane + command, 3.0)
            self.run.moved_s[name] = k * STEP_S


def _routes(scene: Scene, work: Path) -> Path:
    lines = [
        "<routes>",
        f'  <vType id="av" length="{LENGTH_M}" maxSpeed="40" sigma="0" speedDev="0"/>',
        '  <route id="r" edges="road"/>',
    ]
    for name, lane in scene.lanes.items():
        lines.append(
            f'  <vehicle id="{name}" type="av" route="r" depart="0" departLane="{lane}" departPos="{START_M}" '
            f'departSpeed="{CRUISE_MS}" insertionChecks="none"/>'
        )
    path = work / "scene.rou.xml"
    path.write_text("\n".join([*lines, "</routes>"]) + "\n", encoding="utf-8")
    return path


# ---- the report -----------------------------------------------------------------------------------------------


def describe(scene: Scene, run: SceneRun) -> str:
    where = ", ".join(f"{n} in lane {lane}" for n, lane in scene.lanes.items())
    drivers = ", ".join(sorted(set(scene.controllers.values())))
    if scene.params:
        drivers += " (" + "; ".join(f"{n}: {_params_words(p)}" for n, p in scene.params.items()) + ")"
    moved = ", ".join(f"{n} at {s:.1f} s" for n, s in sorted(run.moved_s.items())) or "none"
    said = [
        f"{scene.source}: {where}, side by side at {CRUISE_MS:g} m/s, the gap in lane {GAP_LANE}; driven by {drivers}",
        f"  radio: {_radio_words(scene.radio)}; {count(run.traffic.sent, 'message')} sent, {run.traffic.lost} lost",
        f"  changed lane: {moved}; {run.seconds:.1f} s simulated",
    ]
    if run.conflict:
        pairs = "; ".join("/".join(p) for p in run.collisions)
        said.append(
            f"  conflict: {count(run.traffic.conflicts, 'time')} two AVs moved into one lane within "
            f"{scene.radio.radius_m:g} m of each other; SUMO collisions: {pairs or 'none'}"
        )
    else:
        said.append("  no conflict: no two AVs moved into one lane near each other, and SUMO saw no collision")
    return "\n".join(said)


def _params_words(params: dict[str, float | int]) -> str:
    return ", ".join(f"{k} = {v:g}" for k, v in params.items()) or "its machine's params"


def _radio_words(v: V2V) -> str:
    lost = f"{v.lost_in_row} lost in a row every time" if v.lost_in_row else "nothing lost"
    return f"{lost}, the rest {count(v.max_delay, 'step')} late"


def as_json(scene: Scene, run: SceneRun) -> dict[str, Any]:
    return {
        "source": scene.source,
        "lanes": scene.lanes,
        "controllers": scene.controllers,
        "radio": {"lost_in_row": scene.radio.lost_in_row, "delay": scene.radio.max_delay},
        "moved_s": run.moved_s,
        "conflicts": run.traffic.conflicts,
        "collisions": run.collisions,
        "messages": {"sent": run.traffic.sent, "lost": run.traffic.lost},
        "outcome": outcome(run),
        "expected": scene.expect,
    }


def outcome(run: SceneRun) -> str:
    return "conflict" if run.conflict else "none"
