"""What every conformance check gives back, and the one runner of a pipeline's checks.

A check is a function of the subject (the spec, its IR and its files) that returns an outcome; nothing is written
into the subject. The code `compile` builds and loads is its second value, handed to the checks that run it, so
the order of the other checks does not matter."""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Generic, TypeVar

# every check, in the order they build on each other (`--only` keeps this order)
CHECKS = ("compile", "exhaustive", "sequences", "frama-c-wp", "cppcheck", "cortex-m4", "sanitizers")
COMPILE = "compile"


@dataclass(frozen=True)
class CheckOutcome:
    name: str
    ok: bool
    detail: str
    seconds: float = 0.0
    data: dict[str, Any] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "ok": self.ok,
            "detail": self.detail,
            "seconds": round(self.seconds, 3),
            "data": self.data,
        }


Subject = TypeVar("Subject")
Code = TypeVar("Code")


@dataclass(frozen=True)
class Suite(Generic[Subject, Code]):
    """A pipeline's checks: `build` compiles and loads the code (None when it does not build), `on_code` run
    that code, `on_files` read the generated files only."""

    build: Callable[[Subject], tuple[CheckOutcome, Code | None]]
    on_code: Mapping[str, Callable[[Subject, Code], CheckOutcome]]
    on_files: Mapping[str, Callable[[Subject], CheckOutcome]]

    def __post_init__(self) -> None:
        assert {COMPILE, *self.on_code, *self.on_files} == set(CHECKS), "every check, once"


def not_compiled(name: str) -> CheckOutcome:
    return CheckOutcome(name, False, "not run: the code did not compile")


def run_checks(
    subject: Subject, names: list[str], suite: Suite[Subject, Code], report: Callable[[CheckOutcome], None]
) -> list[CheckOutcome]:
    """Run `names` in order, each timed and reported as it lands; "compile" goes first, and is reported, when a
    check that runs the code is asked for."""
    if any(n in suite.on_code for n in names):
        names = [COMPILE, *(n for n in names if n != COMPILE)]
    code: Code | None = None
    outcomes = []
    for name in names:
        start = time.perf_counter()
        if name == COMPILE:
            outcome, code = suite.build(subject)
        elif name in suite.on_code:
            outcome = not_compiled(name) if code is None else suite.on_code[name](subject, code)
        else:
            outcome = suite.on_files[name](subject)
        outcome = replace(outcome, seconds=time.perf_counter() - start)
        report(outcome)
        outcomes.append(outcome)
    return outcomes
