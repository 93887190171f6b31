"""The report's sections on the closed loop itself, beyond the paper's metrics: the transition coverage of the
generated machines in traffic, the shadow mode (what each controller did with the needs SUMO's model raised), and
safety beside collisions (each lane change against RSS's distance, its gaps, SUMO's SSM device, the density).
Pure functions of the rows the results database returns (sim_check.db.LoopRows); cells arrive formatted."""

from __future__ import annotations

import functools
from collections import defaultdict
from typing import Any

from mlca_verify.model import Machine, show
from mlca_verify.spec import load_spec
from sim_check.controllers import SETUPS
from sim_check.db import LoopRows
from sim_check.run_results import SHADOW, SIDES

SIDE_NAMES = {1: "left", -1: "right"}


def label(controller: str) -> str:
    return SETUPS[controller].label if controller in SETUPS else controller


@functools.cache
def _machine(controller: str) -> Machine | None:
    """The spec of a generated controller of this version (None for any other name)."""
    code = SETUPS[controller].generated if controller in SETUPS else None
    return None if code is None else load_spec(code.spec, compare=False).machine


def target_side(machine: Machine, tid: str) -> int:
    """The side transition `tid` moves the AV to (+1, -1), or 0."""
    transition = next(t for t in machine.transitions if t.id == tid)
    return SIDES.get(transition.target, 0)


def coverage(rows: LoopRows, seconds: dict[str, dict[str, float]]) -> list[dict[str, Any]]:
    """Per generated controller: each transition in the spec's order, its guard, how often it fired and in how
    many runs, and for one that never fired, the wish episodes towards its side or the seconds (`seconds`, by
    controller and state) its AVs spent in the states it leaves (why it did not)."""
    wishes: dict[str, dict[tuple[int, bool], int]] = defaultdict(lambda: defaultdict(int))
    for controller, side, urgent, _reason, count in rows.wishes:
        wishes[controller][(side, bool(urgent))] += count
    by_controller: dict[str, dict[str, tuple[int, int]]] = defaultdict(dict)
    for controller, tid, fired, runs in rows.transitions:
        by_controller[controller][tid] = (int(fired), int(runs))
    result = []
    for controller, fired in sorted(by_controller.items()):
        machine = _machine(controller)
        order = [t.id for t in machine.transitions] if machine else sorted(fired)
        guards = {t.id: show(t.guard) for t in machine.transitions} if machine else {}
        entries = [
            {
                "id": tid,
                "guard": guards.get(tid, ""),
                "fired": fired[tid][0],
                "runs": fired[tid][1],
                "why": _why(machine, tid, wishes[controller], seconds.get(controller, {})) if not fired[tid][0] else "",
            }
            for tid in order
            if tid in fired
        ]
        covered = sum(1 for e in entries if e["fired"])
        result.append(
            {"controller": label(controller), "transitions": entries, "covered": f"{covered} of {len(entries)}"}
        )
    return result


def _why(machine: Machine | None, tid: str, wishes: dict[tuple[int, bool], int], seconds: dict[str, float]) -> str:
    """Why transition `tid` never fired: the wish episodes towards its side, or the time the machines spent in
    the states it leaves."""
    if machine is None:
        return "not a transition of this version's spec"
    side = target_side(machine, tid)
    if side == 0:
        sources = next(t.sources for t in machine.transitions if t.id == tid) or machine.states
        spent = "; ".join(f"{s} {seconds.get(s, 0.0):.1f} s" for s in sources)
        return f"its guard was never true in {', '.join(sources)} in these runs (time the AVs spent there: {spent})"
    towards = wishes.get((side, False), 0) + wishes.get((side, True), 0)
    urgent = wishes.get((side, True), 0)
    return f"these runs had {towards} wish episodes to the {SIDE_NAMES[side]}, {urgent} of them urgent"


def shadow(rows: LoopRows) -> list[dict[str, Any]]:
    """Per (controller, AVs): AV runs, wish episodes and their outcomes with shares, the mean delay of those
    followed late, commands and repeats."""
    result = []
    for controller, avs, av_runs, *sums in rows.shadow:
        values = dict(zip(SHADOW, (s or 0 for s in sums), strict=True))
        wishes = int(values["wishes"])
        deferred = int(values["wishes_deferred"])
        result.append(
            {
                "controller": label(controller),
                "avs": avs,
                "av_runs": av_runs,
                "wishes": wishes,
                **{
                    o: f"{int(values[f'wishes_{o}'])} ({share(values[f'wishes_{o}'], wishes)})"
                    for o in ("at_once", "deferred", "refused")
                },
                "delay_s": f"{values['wish_delay_s'] / deferred:.1f}" if deferred else "-",
                "commands": int(values["commands"]),
                "repeats": int(values["repeats"]),
            }
        )
    return result


def wish_reasons(rows: LoopRows) -> list[tuple[str, str, str, str, int]]:
    """controller, side, urgent or not, SUMO's reason, wish episodes."""
    return [
        (label(controller), SIDE_NAMES.get(side, str(side)), "urgent" if urgent else "-", reason, count)
        for controller, side, urgent, reason, count in rows.wishes
    ]


def safety(rows: LoopRows) -> list[tuple[str, ...]]:
    """controller, AVs, lane changes, those into a gap shorter than RSS's (share), the smallest gaps at a change,
    SSM conflicts, smallest TTC, largest DRAC, smallest PET, mean density."""
    result: list[tuple[str, ...]] = []
    for controller, avs, changes, unsafe, lead, follow, conflicts, ttc, drac, pet, density in rows.safety:
        result.append(
            (
                label(controller),
                str(avs),
                str(int(changes or 0)),
                f"{int(unsafe or 0)} ({share(unsafe or 0, changes or 0)})",
                _num(lead, 1),
                _num(follow, 1),
                str(int(conflicts or 0)),
                _num(ttc, 2),
                _num(drac, 2),
                _num(pet, 2),
                _num(density, 2),
            )
        )
    return result


def _num(value: float | None, digits: int) -> str:
    return "-" if value is None else f"{value:.{digits}f}"


def share(part: float, whole: float) -> str:
    """`part` as a percentage of `whole` (of 1 where `whole` is 0)."""
    return f"{part / max(whole, 1):.0%}"
