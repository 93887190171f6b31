"""Replay a counterexample on the machine with the brute-force semantics: it must really happen."""

from __future__ import annotations

from mlca_verify.logic.results import Counterexample, Step
from mlca_verify.model import Liveness, Machine
from tests.bruteforce import Explicit, ev


def replay(machine: Machine, cx: Counterexample) -> None:
    """Every step starts where the previous one ended and takes a transition the semantics allows."""
    ex = Explicit(machine)
    assert cx.steps, "empty trace"
    assert cx.steps[0].state == machine.initial
    for k, step in enumerate(cx.steps):
        if k > 0:
            assert step.state == cx.steps[k - 1].outcome.next
        outs = ex.fired(step.state, step.inputs)
        if step.outcome.transition is None:
            assert k == len(cx.steps) - 1, "a gap can only end a trace"
            if step.outcome.machine in (None, machine.name):
                assert outs == [], f"claimed gap, but {outs} fire"
        elif step.outcome.machine in (None, machine.name):
            assert (step.outcome.transition, step.outcome.next) in outs
        for alt in step.alternatives:
            if alt.machine in (None, machine.name):
                assert (alt.transition is None and outs == []) or (alt.transition, alt.next) in outs


def check_lasso_or_gap(machine: Machine, cx: Counterexample, live: Liveness) -> None:
    """From loop_start (or the restricted part) assume holds and goal never does; the loop closes."""
    replay(machine, cx)
    if cx.loop_start is not None:
        loop = cx.steps[cx.loop_start :]
        assert loop, "empty loop"
        assert loop[-1].outcome.next == loop[0].state
        _restricted(loop, live)
    else:
        last = cx.steps[-1]
        assert last.outcome.transition is None or live.within is not None
        assert ev(live.assume, last.inputs)


def _restricted(steps: tuple[Step, ...], live: Liveness) -> None:
    for step in steps:
        assert ev(live.assume, step.inputs)
        assert not ev(live.goal, step.inputs, step.outcome.next)
