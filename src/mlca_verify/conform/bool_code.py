"""The conformance checks of generated code against its spec, one function per check.

(a) compile strictly and load, (b) exhaustive comparison of Python, C and z3, (c) random input sequences
through Python and C with the monitor on, (d) Frama-C WP, (e) cppcheck and its MISRA addon, (f) a Cortex-M4
cross build, (g) the exhaustive comparison again under AddressSanitizer and UndefinedBehaviorSanitizer.
"""

from __future__ import annotations

import itertools
import os
import re
import shutil
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path

from mlca_verify.codegen.ir import MachineIR
from mlca_verify.codegen.render import render_template
from mlca_verify.conform.outcome import CheckOutcome, Suite
from mlca_verify.conform.reference import Reference
from mlca_verify.errors import ToolError
from mlca_verify.layout import Layout
from mlca_verify.loading import CMachine, PythonMachine, build_c, load_python
from mlca_verify.spec import LoadedSpec
from mlca_verify.tools import C_FLAGS, run

OUT_OF_RANGE = 3  # values past the last state tried as out-of-range states
SEQUENCE_SEED = 20261125  # fixed: the same sequences on every run and every machine


@dataclass(frozen=True)
class Subject:
    """One spec without data and the generated files that claim to implement it."""

    spec: LoadedSpec
    ir: MachineIR
    layout: Layout  # absolute paths
    build: Path
    sequences: int = 200

    @property
    def state_values(self) -> list[int]:
        n = len(self.ir.states)
        return list(range(n + OUT_OF_RANGE))

    def state_name(self, value: int) -> str | None:
        return self.ir.states[value] if 0 <= value < len(self.ir.states) else None

    @property
    def c_file(self) -> Path:
        return self.layout.c_source

    @cached_property
    def expected(self) -> dict[tuple[int, tuple[bool, ...]], tuple[int, bool, list[str]]]:
        """(state value, inputs) -> (next state value, invariants hold, failing invariant ids), by z3."""
        ref = Reference(self.spec.machine)
        table = {}
        for value in self.state_values:
            name = self.state_name(value)
            for inputs in valuations(ref.machine.input_names):
                nxt = self.ir.states.index(ref.next_state(name, inputs))
                failing = ["state-range"] if name is None else ref.failing_invariants(name, inputs)
                table[(value, tuple(inputs.values()))] = (nxt, not failing, failing)
        return table


@dataclass(frozen=True)
class Code:
    """The code `compile` built and loaded: the generated Python, and the C as an extension module."""

    py: PythonMachine
    c: CMachine


def valuations(names: tuple[str, ...]) -> list[dict[str, bool]]:
    return [dict(zip(names, bits, strict=True)) for bits in itertools.product([False, True], repeat=len(names))]


def compile_and_load(t: Subject) -> tuple[CheckOutcome, Code | None]:
    obj = t.build / f"{t.ir.module}_fsm.o"
    ran = run(["gcc", *C_FLAGS, "-O2", "-c", "-o", str(obj), str(t.c_file)], timeout=120)
    if ran.returncode != 0:
        return CheckOutcome("compile", False, f"gcc {' '.join(C_FLAGS)} failed:\n{ran.output.strip()}"), None
    c = build_c(t.layout, t.ir, t.build, f"_conform_{t.ir.module}_c")
    py = load_python(t.layout, t.spec.machine.input_names, f"_conform_{t.ir.module}_fsm")
    warnings = ran.output.strip()
    detail = f"gcc {' '.join(C_FLAGS)}: no diagnostics{warnings and ': ' + warnings}"
    return CheckOutcome("compile", True, detail), Code(py, c)


def exhaustive(t: Subject, code: Code) -> CheckOutcome:
    names = t.spec.machine.input_names
    mismatches = []
    table = t.expected
    py, c = code.py, code.c
    for (value, bits), (nxt, hold, failing) in table.items():
        inputs = dict(zip(names, bits, strict=True))
        got = (py.step(value, bits), c.step(value, bits), py.failing(value, bits), c.holds(value, bits))
        if got != (nxt, nxt, failing, hold):
            mismatches.append(
                f"state {value}, inputs {inputs}: z3 {nxt} {failing}, Python {got[0]} {got[2]}, C {got[1]} {got[3]}"
            )
    cases = len(table)
    if mismatches:
        return CheckOutcome(
            "exhaustive",
            False,
            f"{len(mismatches)} of {cases} cases differ; first: {mismatches[0]}",
            data={"cases": cases},
        )
    detail = f"Python, C and z3 agree on all {cases} (state, inputs) cases, {OUT_OF_RANGE} out-of-range states included"
    return CheckOutcome("exhaustive", True, detail, data={"cases": cases})


def sequences(t: Subject, code: Code) -> CheckOutcome:
    from hypothesis import HealthCheck, given, seed, settings  # only here: keeps every other command's start fast
    from hypothesis import strategies as st

    py, c = code.py, code.c
    names = t.spec.machine.input_names
    proved = {i.id for i in t.ir.invariants if i.proved}
    steps = {"count": 0}

    @seed(SEQUENCE_SEED)
    @settings(
        max_examples=t.sequences,
        deadline=None,
        database=None,
        suppress_health_check=list(HealthCheck),
    )
    @given(st.lists(st.tuples(*[st.booleans() for _ in names]), max_size=60))
    def run_sequence(seq: list[tuple[bool, ...]]) -> None:
        sp = sc = t.ir.states.index(t.ir.initial)
        for bits in seq:
            sp, sc = py.step(sp, bits), c.step(sc, bits)
            assert sp == sc, f"Python went to {sp}, C to {sc}"
            failing = py.failing(sp, bits)
            assert (not failing) == c.holds(sc, bits), f"monitors disagree: Python {failing}"
            assert not proved & set(failing), f"monitor fired: {sorted(proved & set(failing))}"
            steps["count"] += 1

    try:
        run_sequence()
    except AssertionError as err:
        return CheckOutcome("sequences", False, f"a random input sequence broke it: {str(err).splitlines()[0]}")
    detail = f"{t.sequences} random sequences ({steps['count']} steps) through Python and C: same states, monitor quiet"
    return CheckOutcome("sequences", True, detail, data={"sequences": t.sequences, "steps": steps["count"]})


_WP_SUMMARY = re.compile(r"Proved goals:\s+(\d+)\s*/\s*(\d+)")
_WP_BAD = re.compile(r"\[wp\] \[[^\]]+\] Goal (\S+) : (Timeout|Unknown|Failed|Stepout)")
_WP_GOAL = re.compile(r"^\[wp\] \[([^\]]+)\] Goal (\S+) : (\w+)", re.MULTILINE)


def frama_c(t: Subject) -> CheckOutcome:
    return wp_file(t.c_file, t.build)


# A goal is decided by the prover's budget, not by the clock: z3's resource limit (rlimit, through Why3's steps)
# gives the same answer on an idle machine and on a loaded one. The hardest goal of a shipped boolean machine
# takes 57,000 steps; the budget is 35 times that (a machine with data has its own, `data.WP_FLAGS`). A goal
# that cannot be proved spends its whole budget, so the budget is also what a failing proof costs. The clock is
# only a guard against a prover that hangs (z3 does not count steps in every tactic: on a broken step of a
# boolean machine it ran until the guard): 60 s, five times what the hardest proved goal takes here.
WP_STEPS = 2_000_000
WP_GUARD_S = 60
WP = ("frama-c", "-wp", "-wp-prover", "z3", "-wp-rte", "-wp-steps", str(WP_STEPS), "-wp-timeout", str(WP_GUARD_S))
WP_RUN_GUARD_S = 3600
# What each status of an unproved goal means, in the check's detail.
WP_STATUS = {
    "Unknown": "not proved within its budget of steps",
    "Stepout": "not proved within its budget of steps",
    "Timeout": f"no answer within the {WP_GUARD_S} s guard against a hung prover",
    "Failed": "the prover failed (an error, or out of memory)",
}


def wp_file(c_file: Path, build: Path, extra: tuple[str, ...] = ()) -> CheckOutcome:
    """Frama-C WP with RTE on one generated C file: every goal proved, or the ones that are not, listed."""
    ran = run([*WP, "-wp-par", "2", *extra, str(c_file)], timeout=WP_RUN_GUARD_S, cwd=build)
    summary = _WP_SUMMARY.search(ran.output)
    if summary is None:
        tail = "\n".join(ran.output.strip().splitlines()[-5:])
        if "prover" in ran.output.lower():
            raise ToolError(f"error: Frama-C WP found no prover; run `why3 config detect` ({tail})")
        return CheckOutcome("frama-c-wp", False, f"Frama-C did not report a proof:\n{tail}")
    proved, total = int(summary.group(1)), int(summary.group(2))
    unproved = [f"{g} ({WP_STATUS[why]})" for g, why in _WP_BAD.findall(ran.output)]
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


def cppcheck(t: Subject) -> CheckOutcome:
    return cppcheck_file(t.c_file, t.build)


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


def cross_build(t: Subject) -> CheckOutcome:
    obj = t.build / f"{t.ir.module}_fsm.arm.o"
    ran = run(["arm-none-eabi-gcc", *C_FLAGS, *ARM_FLAGS, "-c", "-o", str(obj), str(t.c_file)], timeout=120)
    if ran.returncode != 0:
        return CheckOutcome("cortex-m4", False, f"arm-none-eabi-gcc failed:\n{ran.output.strip()}")
    size = run(["arm-none-eabi-size", str(obj)]).output.splitlines()[-1].split()
    text, data, bss = (int(x) for x in size[:3])
    symbols = run(["arm-none-eabi-nm", "-S", str(obj)]).output
    step = re.search(rf"^[0-9a-f]+ ([0-9a-f]+) T {t.ir.module}_step$", symbols, re.MULTILINE)
    step_bytes = int(step.group(1), 16) if step else -1
    calls = external_calls(obj)
    info = {"text": text, "data": data, "bss": bss, "step_text": step_bytes, "calls": calls}
    detail = (
        f"arm-none-eabi-gcc {' '.join(ARM_FLAGS)}: text {text} B (step {step_bytes} B), data {data} B, bss {bss} B, "
        + (f"calls {', '.join(calls)}" if calls else "no call out of the object")
    )
    return CheckOutcome("cortex-m4", data == 0 and bss == 0 and not calls, detail, data=info)


def sanitizers(t: Subject) -> CheckOutcome:
    harness = t.build / f"{t.ir.module}_harness.c"
    harness.write_text(render_template("c_harness.c.j2", m=t.ir, extra=OUT_OF_RANGE), encoding="utf-8")
    exe = t.build / f"{t.ir.module}_harness"
    flags = ("-g", "-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer")
    ran = run(
        ["gcc", *C_FLAGS, *flags, f"-I{t.c_file.parent}", "-o", str(exe), str(harness), str(t.c_file)], timeout=120
    )
    if ran.returncode != 0:
        return CheckOutcome("sanitizers", False, f"build failed:\n{ran.output.strip()}")
    env = dict(os.environ, ASAN_OPTIONS="detect_leaks=1:abort_on_error=0", UBSAN_OPTIONS="print_stacktrace=1")
    done = run([str(exe)], timeout=120, env=env)
    if done.returncode != 0:
        return CheckOutcome("sanitizers", False, f"the harness failed under ASan/UBSan:\n{done.output.strip()[-2000:]}")
    table = t.expected
    got = {}
    for line in done.output.splitlines():
        value, bits, nxt, hold = (int(x) for x in line.split())
        key = tuple(bool(bits >> k & 1) for k in range(len(t.ir.inputs)))
        got[(value, key)] = (nxt, bool(hold))
    want = {k: (v[0], v[1]) for k, v in table.items()}
    if got != want:
        bad = sorted(k for k in want if got.get(k) != want[k])
        return CheckOutcome(
            "sanitizers", False, f"{len(bad)} of {len(want)} cases differ under sanitizers; first: {bad[:1]}"
        )
    caught = _invalid_bool_caught(exe, env, t.ir.step_reads_inputs)
    if caught is not None:
        return CheckOutcome("sanitizers", False, caught)
    return CheckOutcome(
        "sanitizers",
        True,
        f"-fsanitize=address,undefined: all {len(want)} cases agree, no reports; inputs outside 0/1 reported",
        data={"cases": len(want)},
    )


def _invalid_bool_caught(exe: Path, env: dict[str, str], reads_inputs: bool) -> str | None:
    """The step's precondition (every bool input is 0 or 1) is one an integrator's UBSan build checks: a step on
    0xFF bytes must be reported. None when it is (or when the step reads no input), else what went wrong."""
    ran = run([str(exe), "invalid"], timeout=120, env=env)
    reported = ran.returncode != 0 and "not a valid value for type" in ran.output
    if reported or not reads_inputs:
        return None
    return f"a step on inputs outside 0/1 was not reported by -fsanitize=bool:\n{ran.output.strip()[-500:]}"


SUITE: Suite[Subject, Code] = Suite(
    compile_and_load,
    {"exhaustive": exhaustive, "sequences": sequences},
    {"frama-c-wp": frama_c, "cppcheck": cppcheck, "cortex-m4": cross_build, "sanitizers": sanitizers},
)
