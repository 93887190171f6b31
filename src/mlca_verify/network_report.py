"""A network's verdicts in its own words: each instance's state and transitions by name, the channels'
assumptions as sentences, and none of the flattening's own registers (see `network`)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace

from mlca_verify.json_types import JsonObject
from mlca_verify.logic.datachecks import check_declared
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.results import Counterexample, Number, Outcome, Result
from mlca_verify.model import Invariant, Liveness, Machine, show
from mlca_verify.network import (
    NETWORK_STATE,
    Channel,
    Network,
    Renamer,
    flatten,
    instances_read,
    mode_of,
    part,
    qualified,
)


def own_element(name: str) -> bool:
    """A name the flattening made (a mode variable, a transition number, a channel's register), not the spec."""
    return "~" in name or name.endswith(".state")


def modes_text(net: Network, values: Mapping[str, Number]) -> str:
    """Each instance's state, by name: `A:CLAIM B:KEEP`."""
    parts = []
    for inst in net.instances:
        index = values.get(mode_of(inst.name))
        states = inst.machine.states
        name = states[int(index)] if isinstance(index, int | float) and 0 <= index < len(states) else "?"
        parts.append(f"{inst.name}:{name}")
    return " ".join(parts)


def fired_text(net: Network, definitions: Mapping[str, Number]) -> str | None:
    """The transitions that fired in the step, by instance (`A.claim B.yield`); None when none did."""
    fired = []
    for inst in net.instances:
        k = definitions.get(qualified(inst.name, "~fired"), 0)
        if isinstance(k, int | float) and 1 <= k <= len(inst.machine.transitions):
            fired.append(f"{inst.name}.{inst.machine.transitions[int(k) - 1].id}")
    return " ".join(fired) or None


def network_trace(net: Network, cx: Counterexample) -> Counterexample:
    """A counterexample of the flat machine told in the network's words: the state column each instance's
    state, the transition column what each instance fired, the inputs (a message lost: `<channel>~lost`), the
    signals (a message's age: `<channel>~age`; the instance that stepped: `~turn`), the variables and outputs,
    and neither the instances' definitions (derived from those) nor the flattening's own registers."""
    initial = {mode_of(i.name): i.machine.states.index(i.machine.initial) for i in net.instances}
    before: Mapping[str, Number] = initial
    steps = []
    for step in cx.steps:
        after = step.variables
        outcome = Outcome(fired_text(net, step.definitions), None, modes_text(net, after))
        steps.append(
            replace(
                step,
                state=modes_text(net, before),
                outcome=outcome,
                definitions={},  # the instances' own, derived from the rest: a network's trace is its messages
                variables={k: v for k, v in after.items() if not own_element(k)},
            )
        )
        before = after
    return replace(cx, steps=tuple(steps))


def network_json(net: Network) -> JsonObject:
    """What a network is, for `check --json`: its schedule, its instances (their specs and param overrides are in
    their machines) and its channels' semantics."""
    return {
        "schedule": net.schedule,
        "fairness": net.fairness,
        "instances": [
            {"name": i.name, "spec": i.spec, "machine": i.machine.name, "cite": i.cite} for i in net.instances
        ],
        "channels": [
            {
                "id": c.id,
                "from": qualified(c.sender, c.output),
                "to": qualified(c.receiver, c.port),
                "delay": c.delay,
                "max_delay": c.latest,
                "order": c.order,
                "duplicate": c.duplicate,
                "lost": c.lost,
                "cite": c.cite,
            }
            for c in net.channels
        ],
    }


def network_assumptions(net: Network) -> list[str]:
    """What every verdict assumes of the network, in its words: the schedule, each channel's delivery, and each
    instance's own assumptions (over its qualified names)."""
    lines = []
    if net.schedule == "interleaved":
        fair = f", each at least once in every {net.fairness} steps" if net.fairness else ""
        lines.append(f"schedule: one instance steps at a time (signal ~turn: 0 is {net.instances[0].name}){fair}")
    for ch in net.channels:
        lines.append(f"{ch.id}: {ch.sender}.{ch.output} reaches {ch.receiver}.{ch.port} {delivery(ch)}")
    for inst in net.instances:
        lines += [f"{inst.name}.{a.id}: {show(Renamer(inst.name, ()).expr(a.expr))}" for a in inst.machine.assumptions]
    return lines


def delivery(ch: Channel) -> str:
    if ch.latest == ch.delay:
        exact = {0: "in the same step (its sender steps first)", 1: "the next step"}
        when = exact.get(ch.delay, f"{ch.delay} steps later")
    else:
        order = "in order" if ch.order == "fifo" else "in any order"
        order += "" if ch.duplicate or ch.order != "fifo" else ", each read at most once"
        when = f"{ch.delay} to {ch.latest} steps later, {order} (signal {ch.id}~age)"
    lost = f"; at most {ch.lost} lost in a row (input {ch.id}~lost)" if ch.lost else "; none lost"
    return when + lost


def network_results(net: Network, results: Sequence[Result]) -> list[Result]:
    """The verdicts a network report shows: its own properties and the range and overflow checks of the
    instances' elements, without the flat machine's own (its one state, the flattening's registers). The
    instances' determinism, reachability and properties are their own specs' checks."""
    shown = []
    for r in results:
        if r.kind in ("determinism", "completeness", "reachability", "dead-transition"):
            continue
        if r.kind in ("range", "overflow", "division") and own_element(r.prop.partition(":")[2]):
            continue
        cx = r.counterexample
        if cx is None or cx.point:
            shown.append(r)
            continue
        told = network_trace(net, cx)
        loop = told.steps[cx.loop_start].state if cx.loop_start is not None else ""
        shown.append(
            replace(r, counterexample=told, detail=r.detail.replace(f"through {NETWORK_STATE}", f"through {loop}"))
        )
    return shown


def check_network(net: Network, flat: Machine, limits: Limits, parametric: bool = False) -> list[Result]:
    """A network's own properties, decided with the larger of `limits`' budget and the network's, told in its
    words. A property that reads some of the instances only is first decided on the part of the network they
    make (`network.part`): what holds there holds here, for any others; the rest is decided on the whole flat
    machine. The instances' built-in checks are their own specs': a run of the network is a run of each
    instance."""
    budget = replace(limits, timeout_ms=max(limits.timeout_ms, net.timeout_ms))
    proved: dict[str, Result] = {}
    for keep, props in _by_part(net).items():
        piece = replace(part(net, keep), invariants=props.invariants, liveness=props.liveness)
        ids = _ids(props)
        for r in check_declared(flatten(piece), budget, ids, parametric):
            if r.verdict == "holds":
                proved[r.prop] = replace(r, detail=f"{r.detail}; on {_names(keep)} alone, whatever the others send")
    rest = set(_ids(net)) - set(proved)
    decided = {r.prop: r for r in check_declared(flat, budget, rest, parametric)} if rest else {}
    return network_results(net, [proved.get(pid) or decided[pid] for pid in _ids(net)])


def _ids(net: Network) -> list[str]:
    return [p.id for p in net.invariants] + [p.id for p in net.liveness]


def _by_part(net: Network) -> dict[frozenset[str], Network]:
    """The properties that read some of the instances only, grouped by the instances they read (each group a
    network that holds just them)."""
    everyone = frozenset(i.name for i in net.instances)
    groups: dict[frozenset[str], Network] = {}
    props: tuple[Invariant | Liveness, ...] = (*net.invariants, *net.liveness)
    for prop in props:
        keep = _read_by(prop)
        if keep and keep < everyone:
            found = groups.get(keep, replace(net, invariants=(), liveness=()))
            if isinstance(prop, Invariant):
                groups[keep] = replace(found, invariants=(*found.invariants, prop))
            else:
                groups[keep] = replace(found, liveness=(*found.liveness, prop))
    return groups


def _read_by(prop: Invariant | Liveness) -> frozenset[str]:
    if isinstance(prop, Invariant):
        return instances_read(prop.expr)
    return instances_read(prop.assume, prop.goal, *([prop.bound] if prop.bound is not None else []))


def _names(keep: frozenset[str]) -> str:
    ordered = sorted(keep)
    return ordered[0] if len(ordered) == 1 else ", ".join(ordered[:-1]) + " and " + ordered[-1]
