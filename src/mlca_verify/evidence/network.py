"""The evidence of a network of machines (`mlca-verify evidence NETWORK.toml`): the network's goals, each
vehicle's goals at the params its instances run with, the channel assumptions every verdict rests on, the
generated code of each machine, the closed-loop V2V runs of that code and the SUMO replays of network
counterexamples; as evidence.json and index.html, with an argument in Goal Structuring Notation."""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

from mlca_verify.codegen import generate_frames, machine_ir
from mlca_verify.codegen.frames import frame_files, frames_module
from mlca_verify.conformance import conform, up_to_date
from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.evidence.collect import closed_loop, files_json, how_decided, proof, sha256, tool_versions
from mlca_verify.evidence.page import anchor, render_network_page
from mlca_verify.evidence.runs import ClosedLoopRuns, loop_controllers
from mlca_verify.files import write_atomic
from mlca_verify.layout import FILES, Layout
from mlca_verify.logic import check_all
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Result
from mlca_verify.model import Machine, show_number
from mlca_verify.network import Network
from mlca_verify.network_report import check_network, delivery, network_assumptions
from mlca_verify.spec import LoadedSpec, machine_specs

NETWORK_EVIDENCE_SCHEMA = "mlca-verify.network-evidence/1"
# the conformance checks of each machine's code in a network's bundle; WP, the exhaustive comparison and the
# sanitizers are the machine's own bundle's (`mlca-verify evidence MACHINE.toml`)
NETWORK_CHECKS = ("compile", "sequences", "cppcheck", "cortex-m4")
Node = Callable[..., None]


@dataclass(frozen=True)
class Vehicle:
    """The instances that run one machine with the same params, and that machine's verdicts at those params."""

    instances: tuple[str, ...]
    spec: str  # the machine spec's path, as the network names it
    machine: Machine
    results: list[Result]

    @property
    def params(self) -> dict[str, str]:
        return {p.name: show_number(p.default, p.type == "real") for p in self.machine.params}


@dataclass(frozen=True)
class Code:
    """A machine's generated code, checked: the outcomes of NETWORK_CHECKS (up-to-date first), and its files."""

    spec: LoadedSpec
    outcomes: list[CheckOutcome]
    files: list[dict[str, str]]


@dataclass(frozen=True)
class NetworkEvidence:
    spec: LoadedSpec  # the network's
    results: list[Result]
    vehicles: list[Vehicle]
    code: list[Code]
    generated_at: str
    loop: list[dict[str, Any]] = field(default_factory=list)  # per machine: closed_loop() with its V2V counts
    replays: list[dict[str, Any]] | None = None  # the scenes of `mlca-sim replay --json`, judged

    @property
    def network(self) -> Network:
        assert self.spec.network is not None
        return self.spec.network

    @cached_property
    def data(self) -> dict[str, Any]:
        return document(self)

    @property
    def ok(self) -> bool:
        proofs = all(r.ok for r in self.results) and all(r.ok for v in self.vehicles for r in v.results)
        code = all(o.ok for c in self.code for o in c.outcomes)
        loop = all(section["status"] != "failed" for section in self.loop)
        replays = all(scene["ok"] is not False for scene in self.replays or [])
        return proofs and code and loop and replays


def spec_network(spec: LoadedSpec) -> Network:
    assert spec.network is not None
    return spec.network


def vehicles(net: Network, limits: Limits) -> list[Vehicle]:
    """Each machine at each set of params its instances run with, proved once."""
    groups: dict[tuple[str, tuple[str, ...]], list[str]] = {}
    machines: dict[tuple[str, tuple[str, ...]], Machine] = {}
    for inst in net.instances:
        key = (inst.spec, tuple(show_number(p.default, p.type == "real") for p in inst.machine.params))
        groups.setdefault(key, []).append(inst.name)
        machines.setdefault(key, inst.machine)
    return [
        Vehicle(tuple(names), key[0], machines[key], check_all(machines[key], limits.timeout_ms, False, limits))
        for key, names in groups.items()
    ]


def collect_network(
    spec: LoadedSpec,
    generated: Path,
    runs: Sequence[ClosedLoopRuns] | None,
    generated_at: str,
    *,
    replay: dict[str, Any] | None = None,
    limits: Limits | None = None,
) -> NetworkEvidence:
    """Prove the network and each vehicle, check each machine's code, and assemble the evidence with the
    closed-loop `runs` of each machine's controllers (in `machine_specs` order; None: no database given) and
    the `replay` document, all read beforehand."""
    limits = limits or Limits()
    net = spec_network(spec)
    machines = machine_specs(spec)
    loop = [] if runs is None else [v2v_loop(r, m) for r, m in zip(runs, machines, strict=True)]
    results = check_network(net, spec.machine, limits)
    proved = vehicles(net, limits)
    code = [
        Code(m, conform(m, generated, list(NETWORK_CHECKS), lambda _: None).outcomes, code_files(m, generated))
        for m in machines
    ] + [frames_code(spec, generated)]
    controllers = {c for m in machines for c in loop_controllers(m)}
    holds = all(r.verdict == "holds" for r in results)
    scenes = None if replay is None else judged_scenes(replay, controllers, holds)
    return NetworkEvidence(spec, results, proved, code, generated_at, loop, scenes)


def v2v_loop(runs: ClosedLoopRuns, machine: LoadedSpec) -> dict[str, Any]:
    """A machine's closed-loop section with what its radio carried: failed where two of its AVs began moving into
    one lane within the radius at one step (the network's "not both into the gap", in traffic)."""
    section = closed_loop(runs, machine.machine.name.lower())
    section["controllers"] = ", ".join(loop_controllers(machine))
    if runs.v2v:
        section["v2v"] = dict(runs.v2v)
        conflicts = runs.v2v.get("conflicts", 0)
        section["detail"] += (
            f"; messages {runs.v2v.get('sent', 0)} sent, {runs.v2v.get('lost', 0)} lost, "
            f"{runs.v2v.get('late', 0)} late; {conflicts} time{'' if conflicts == 1 else 's'} two AVs moved into "
            "one lane near each other"
        )
        if conflicts and section["status"] == "ok":
            section["status"] = "failed"
    return section


def judged_scenes(replay: dict[str, Any], controllers: set[str], holds: bool) -> list[dict[str, Any]]:
    """The replay's network scenes driven by this network's machines, each judged: as its own expectation says
    (a violation replayed by its own machines shows a conflict), else, where every property of this network
    holds, no conflict."""
    judged = []
    for scene in replay.get("networks", []):
        if not set(scene["controllers"].values()) <= controllers:
            continue
        wanted = scene["expected"] or ("none" if holds else None)
        judged.append({**scene, "wanted": wanted, "ok": None if wanted is None else scene["outcome"] == wanted})
    return judged


def write_network_bundle(ev: NetworkEvidence, out: Path) -> list[Path]:
    """evidence.json and index.html; the page is made before anything is written."""
    out.mkdir(parents=True, exist_ok=True)
    page = render_network_page(ev.data)
    json_path, html_path = out / "evidence.json", out / "index.html"
    write_atomic(json_path, json.dumps(ev.data, indent=2) + "\n")
    write_atomic(html_path, page)
    return [json_path, html_path]


# --- the JSON document ------------------------------------------------------------------------------------


def document(ev: NetworkEvidence) -> dict[str, Any]:
    net = ev.network
    return {
        "schema": NETWORK_EVIDENCE_SCHEMA,
        "generated_at": ev.generated_at,
        "network": {
            "path": ev.spec.path,
            "sha256": ev.spec.sha256,
            "name": net.name,
            "cite": net.cite,
            "schedule": net.schedule,
            "instances": [
                {"name": i.name, "spec": i.spec, "machine": i.machine.name, "cite": i.cite} for i in net.instances
            ],
            "channels": [channel(net, k) for k in range(len(net.channels))],
        },
        "ok": ev.ok,
        "tools": tool_versions(),
        "inputs": files_json([Path(ev.spec.path), *(Path(c.spec.path) for c in ev.code)]),
        "proofs": [proof(r) for r in ev.results],
        "vehicles": [
            {
                "instances": list(v.instances),
                "spec": v.spec,
                "machine": v.machine.name,
                "params": v.params,
                "proofs": [proof(r) for r in v.results],
            }
            for v in ev.vehicles
        ],
        "code": [code_json(c) for c in ev.code],
        "closed_loop": ev.loop,
        "replays": ev.replays,
        "argument": argument(ev),
    }


def channel(net: Network, k: int) -> dict[str, Any]:
    ch = net.channels[k]
    text = f"{ch.sender}.{ch.output} reaches {ch.receiver}.{ch.port} {delivery(ch)}"
    return {"id": ch.id, "text": text, "delay": ch.delay, "max_delay": ch.latest, "lost": ch.lost, "cite": ch.cite}


def frames_code(spec: LoadedSpec, generated: Path) -> Code:
    """The network's message frames (`gen` writes them): whether they are the network's, and their hashes."""
    files = generate_frames(spec, generated)
    paths = {kind: generated / rel for kind, rel in frame_files(frames_module(spec_network(spec).name)).items()}
    hashed = [{"kind": kind, "path": p.as_posix(), "sha256": sha256(p)} for kind, p in paths.items() if p.is_file()]
    return Code(spec, [up_to_date(spec, files, generated, "network")], hashed)


def code_files(spec: LoadedSpec, generated: Path) -> list[dict[str, str]]:
    """The generated files of `spec` in `generated`, each with its sha256."""
    layout = Layout(generated, machine_ir(spec, generated).module)
    paths = {kind: generated / layout.relative(kind) for kind in FILES}
    return [{"kind": kind, "path": p.as_posix(), "sha256": sha256(p)} for kind, p in paths.items()]


def code_json(c: Code) -> dict[str, Any]:
    return {
        "spec": c.spec.path,
        "machine": c.spec.machine.name,
        "checks": [{"name": o.name, "ok": o.ok, "detail": o.detail} for o in c.outcomes],
        "files": c.files,
    }


# --- the argument -----------------------------------------------------------------------------------------


def argument(ev: NetworkEvidence) -> list[dict[str, Any]]:
    """GSN nodes: the top goal, the channel assumptions, the network's goals, each vehicle's, each machine's
    code, the closed loop and the replays (each undeveloped where nothing was given)."""
    net = ev.network
    nodes: list[dict[str, Any]] = []

    def node(nid: str, kind: str, text: str, parent: str | None, ok: bool | None = None, *, link: str = "") -> None:
        nodes.append({"id": nid, "type": kind, "text": text, "parent": parent, "ok": ok, "link": link or None})

    names = ", ".join(f"{i.name} ({i.machine.name})" for i in net.instances)
    node("G1", "goal", f"The network {net.name} of {names} meets its properties and each vehicle its own", None, ev.ok)
    node("C1", "context", f"Network spec {ev.spec.path}, sha256 {ev.spec.sha256}, source: {net.cite}", "G1")
    how = "in step" if net.schedule == "synchronous" else "one at a time"
    node("S1", "strategy", f"Argue over the proofs of the network (its instances {how}) under its channels", "G1")
    for k, text in enumerate(network_assumptions(net), 1):  # the schedule, the channels, each instance's own
        node(f"A{k}", "assumption", text, "S1", link="#channels")
    _proofs(node, "G2", "Every property of the network has its expected verdict (z3)", ev.results, "network")
    for k, v in enumerate(ev.vehicles, 1):
        params = ", ".join(f"{n} = {value}" for n, value in v.params.items()) or "no params"
        text = f"{', '.join(v.instances)}: {v.machine.name} ({params}) has its expected verdicts"
        _proofs(node, f"G3.{k}", text, v.results, f"vehicle-{k}")
    _code(node, ev.code)
    _loop(node, ev.loop)
    _replays(node, ev.replays)
    return nodes


def _proofs(node: Node, gid: str, text: str, results: list[Result], where: str) -> None:
    node(gid, "goal", text, "S1", all(r.ok for r in results))
    for k, r in enumerate(results, 1):
        solution = f"{r.prop} ({r.kind}): {r.verdict}, expected {r.expected}; {how_decided(r)}"
        node(f"Sn{gid[1:]}.{k}", "solution", solution, gid, r.ok, link=f"#{where}-{anchor(r.prop)}")


def _code(node: Node, code: list[Code]) -> None:
    ok = all(o.ok for c in code for o in c.outcomes)
    checks = ", ".join(NETWORK_CHECKS)
    text = f"Each machine's generated code is its spec's, checked ({checks}), and the message frames the network's"
    node("G4", "goal", text, "S1", ok)
    for k, c in enumerate(code, 1):
        for j, o in enumerate(c.outcomes, 1):
            text = f"{c.spec.machine.name}, {o.name}: {o.detail.splitlines()[0] if o.detail else ''}"
            node(f"Sn4.{k}.{j}", "solution", text, "G4", o.ok, link="#code")


def _loop(node: Node, loop: list[dict[str, Any]]) -> None:
    text = "Closed-loop V2V runs of the generated code show no monitor violation and no two AVs into one lane"
    if not loop:
        node("G5", "undeveloped", f"{text} (no closed-loop results given)", "S1")
        return
    node("G5", "goal", text, "S1", all(s["status"] == "ok" for s in loop))
    for k, s in enumerate(loop, 1):
        node(f"Sn5.{k}", "solution", s["detail"], "G5", s["status"] == "ok", link="#closed-loop")


def _replays(node: Node, scenes: list[dict[str, Any]] | None) -> None:
    text = "Network counterexamples replayed in SUMO by these machines show what the verdicts say"
    if not scenes:
        why = "no replay given" if scenes is None else "no scene of the replay is driven by these machines"
        node("G6", "undeveloped", f"{text} ({why})", "S1")
        return
    node("G6", "goal", text, "S1", all(s["ok"] is not False for s in scenes))
    for k, s in enumerate(scenes, 1):
        wanted = "not judged" if s["wanted"] is None else f"wanted {s['wanted']}"
        driven = ", ".join(f"{av} by {c}" for av, c in s["controllers"].items())
        solution = f"{s['source']}, {driven}: {s['outcome']} ({wanted})"
        node(f"Sn6.{k}", "solution", solution, "G6", s["ok"], link="#replays")
