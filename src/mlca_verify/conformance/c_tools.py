"""The C tools `conform` runs on a generated file: Frama-C WP, cppcheck with its MISRA addon, and what an ARM
object calls. Each takes a file and a build folder and answers a `CheckOutcome`."""

from __future__ import annotations

import re
import shutil
from itertools import pairwise
from pathlib import Path

from mlca_verify.conformance.outcome import CheckOutcome
from mlca_verify.errors import ToolError
from mlca_verify.tools import run

_WP_SUMMARY = re.compile(r"Proved goals:\s+(\d+)\s*/\s*(\d+)")
_WP_BAD = re.compile(r"\[wp\] \[[^\]]+\] Goal (\S+) : (Timeout|Unknown|Failed|Stepout)")
_WP_GOAL = re.compile(r"^\[wp\] \[([^\]]+)\] Goal (\S+) : (\w+)", re.MULTILINE)


# A goal is decided by the prover's budget, not by the clock: z3's resource limit (rlimit, through Why3's steps)
# gives the same answer on an idle machine and on a loaded one. The hardest goal of a shipped boolean machine
# takes 57,000 steps; the budget is 35 times that (`generated_code.WP_FLAGS` raises it). A goal
# that cannot be proved spends its whole budget, so the budget is also what a failing proof costs. The clock is
# only a guard against a prover that hangs (z3 does not count steps in every tactic: on a broken step of a
# boolean machine it ran until the guard). It grows with the budget, so that a load that slows z3 down cannot
# turn a goal that the budget decides into a timeout: 10 times what the whole budget takes here (MLCA-T's
# hardest goal, 13.3 million steps, takes 11 s), and at least 60 s. At 40 million steps a guard of 60 s did not
# hold: with three other jobs on this 2-core machine, three goals of a V2V machine's step ran into it.
WP_STEPS = 2_000_000
WP_GUARD_S = 60
SECONDS_PER_MILLION_STEPS = 11 / 13.3
WP = ("frama-c", "-wp", "-wp-prover", "z3", "-wp-rte", "-wp-steps", str(WP_STEPS))
WP_RUN_GUARD_S = 3600
# What each status of an unproved goal means, in the check's detail.
WP_STATUS = {
    "Unknown": "not proved within its budget of steps",
    "Stepout": "not proved within its budget of steps",
    "Timeout": "no answer within the {guard} s guard against a hung prover",
    "Failed": "the prover failed (an error, or out of memory)",
}


def wp_guard_s(extra: tuple[str, ...]) -> int:
    """The clock's guard for one goal, from the budget of steps WP runs with (the last one given wins)."""
    given = [int(value) for flag, value in pairwise(extra) if flag == "-wp-steps"]
    steps = given[-1] if given else WP_STEPS
    return max(WP_GUARD_S, round(10 * SECONDS_PER_MILLION_STEPS * steps / 1_000_000))


def wp_file(c_file: Path, build: Path, extra: tuple[str, ...] = ()) -> CheckOutcome:
    """Frama-C WP with RTE on one generated C file: every goal proved, or the ones that are not, listed."""
    guard = wp_guard_s(extra)
    command = [*WP, "-wp-timeout", str(guard), "-wp-par", "2", *extra, str(c_file)]
    ran = run(command, timeout=max(WP_RUN_GUARD_S, 4 * guard), cwd=build)
    summary = _WP_SUMMARY.search(ran.output)
    if summary is None:
        tail = "\n".join(ran.output.strip().splitlines()[-5:])
        if "prover" in ran.output.lower():
            raise ToolError(f"error: Frama-C WP found no prover; run `why3 config detect` ({tail})")
        return CheckOutcome("frama-c-wp", False, f"Frama-C did not report a proof:\n{tail}")
    proved, total = int(summary.group(1)), int(summary.group(2))
    unproved = [f"{g} ({WP_STATUS[why].format(guard=guard)})" for g, why in _WP_BAD.findall(ran.output)]
    listed = sorted({(goal, prover, status) for prover, goal, status in _WP_GOAL.findall(ran.output)})
    goal_list = [{"goal": g, "prover": p, "status": s} for g, p, s in listed]
    data = {"proved": proved, "goals": total, "unproved": unproved, "goal_list": goal_list}
    if proved != total or ran.returncode != 0:
        return CheckOutcome(
            "frama-c-wp", False, f"{proved} / {total} goals proved; not proved: {', '.join(unproved) or '?'}", data=data
        )
    flags = " ".join(("-wp", "-wp-prover z3", "-wp-rte", *_with_steps(extra)))
    return CheckOutcome("frama-c-wp", True, f"frama-c {flags}: {proved} / {total} goals proved", data=data)


def _with_steps(extra: tuple[str, ...]) -> tuple[str, ...]:
    """`extra` as the detail shows it: with the budget of steps WP ran with (the last one given wins)."""
    if "-wp-steps" in extra:
        return extra
    return ("-wp-steps", str(WP_STEPS), *extra)


CPPCHECK = (
    "cppcheck",
    "--std=c99",
    "--enable=all",
    "--inconclusive",
    "--error-exitcode=1",
    "--quiet",
    "--suppress=missingIncludeSystem",
    "--suppress=unusedFunction",
    "--suppress=misra-c2012-2.5:*.h",  # the header's macros are the library's API (INITIAL: for the caller)
    "--suppress=unmatchedSuppression",  # where every macro of the header is used
    "--addon=misra",
)


def cppcheck_file(c_file: Path, build: Path) -> CheckOutcome:
    # cppcheck's addons write dump files beside the source: check a private copy, so that runs in parallel on
    # the same generated file cannot trip over each other and nothing is written into generated/
    private = build / "cppcheck"
    private.mkdir(exist_ok=True)
    for source in (c_file, *c_file.parent.glob("*.h")):
        shutil.copy2(source, private / source.name)
    ran = run([*CPPCHECK, c_file.name], timeout=300, cwd=private)
    findings = [line for line in ran.output.splitlines() if re.search(r":\d+:\d+: ", line)]
    if ran.returncode != 0 or findings:
        first = findings[0] if findings else ran.output.strip()
        return CheckOutcome("cppcheck", False, f"{len(findings)} findings; first: {first}", data={"findings": findings})
    detail = (
        "cppcheck --enable=all --inconclusive --addon=misra: no findings (a library: unusedFunction suppressed, and "
        "MISRA 2.5, unused macros, in the header, whose macros are the API)"
    )
    return CheckOutcome("cppcheck", True, detail, data={"findings": []})


ARM_FLAGS = ("-mcpu=cortex-m4", "-mthumb", "-Os")
# a Cortex-M4F's FPU: single precision only, so a machine whose reals are binary32 is built for it
FPU_FLAGS = ("-mfpu=fpv4-sp-d16", "-mfloat-abi=hard")


def arm_flags(reals: str) -> tuple[str, ...]:
    """The Cortex-M4 build of a machine: binary64 in software, binary32 on the FPU."""
    return (*ARM_FLAGS, *FPU_FLAGS) if reals == "binary32" else ARM_FLAGS


# the ARM run-time ABI's helpers (libgcc): on a core without a double-precision FPU, binary64 arithmetic and
# compares are calls to these, the only calls generated code may make
RUNTIME_HELPER = re.compile(r"__aeabi_\w+")


def external_calls(obj: Path) -> list[str]:
    """The functions an object file calls but does not define (its undefined symbols), sorted."""
    listed = run(["arm-none-eabi-nm", "-u", str(obj)]).output.split()
    return sorted(name for name in listed if name != "U")


def library_calls(calls: list[str]) -> list[str]:
    """Of `calls`, those that are not the compiler's run-time helpers: calls into a library."""
    return [name for name in calls if not RUNTIME_HELPER.fullmatch(name)]
