"""`mlca-verify conform`: the generated Python, the generated C and the z3 semantics of the spec, step by step
on a boundary set and on long random sequences, compared bit for bit.

The C runs in a small generated harness (one line of text per step: the context and the inputs in, the context,
the outputs and the monitor out; reals as hexadecimal floats, exact), built once plainly and once under
AddressSanitizer and UBSan with float-divide-by-zero. The z3 side is the engine's own step relation
(`logic.symbolic`), instantiated with the same values: an invalid sample (outside its range, NaN, an infinity)
is given to z3 as a value outside the range, which is what the spec's semantics reads of it.
"""

from __future__ import annotations

import itertools
import math
import random
import re
import struct
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, replace
from fractions import Fraction
from pathlib import Path
from types import ModuleType
from typing import Any

import z3
import z3.z3 as z3_api

from mlca_verify.codegen.acsl import AcslLowering
from mlca_verify.codegen.certified import Proved, as_wp_sees, assumed_text, certify, needs_arithmetic, ranges
from mlca_verify.codegen.ir import MachineIR
from mlca_verify.codegen.lower import REAL_CTYPES
from mlca_verify.codegen.render import CERTIFIED_TEMPLATE, render_template
from mlca_verify.conformance.c_tools import arm_flags, cppcheck_file, external_calls, library_calls, wp_file
from mlca_verify.conformance.outcome import CheckOutcome, Suite
from mlca_verify.floats import BY_CTYPE
from mlca_verify.layout import Layout
from mlca_verify.loading import import_generated
from mlca_verify.logic.datachecks import check_data_machine, check_invariants
from mlca_verify.logic.induction import Limits
from mlca_verify.logic.replay64 import Binary64
from mlca_verify.logic.replay64 import Value as Value64
from mlca_verify.logic.results import Result
from mlca_verify.logic.symbolic import System, python_value, value_of
from mlca_verify.model import Machine, Type, prevs_of, stored_registers
from mlca_verify.tools import C_FLAGS, run

SANITIZE = ("-fsanitize=address,undefined,float-divide-by-zero", "-fno-sanitize-recover=all", "-g", "-O1")
SEQUENCE_STEPS = 10_000

# how far, relative to the larger, a real the code computes in binary64 may lie from the spec's exact value: the
# exhaustive check and the generated test suites compare reals by it (binary64's unit roundoff is 1.1e-16)
REAL_TOLERANCE = 1e-9
# the same for binary32 (unit roundoff 6.0e-8): a few hundred roundings of one step's operations
TOLERANCES = {"binary64": REAL_TOLERANCE, "binary32": 1e-4}


@dataclass(frozen=True)
class Subject:
    """A machine and its generated files."""

    machine: Machine
    ir: MachineIR
    layout: Layout
    build: Path
    sequences: int


@dataclass(frozen=True)
class Code:
    """The code `compile` built and loaded: the generated Python module, and the C harness over the generated C."""

    py: ModuleType
    harness: Path


Row = tuple[Any, ...]  # a context and the inputs of one step, in the harness's order


def _fmt(value: object) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    if isinstance(value, float):
        return value.hex()
    return str(value)


def _parse(token: str, real: bool) -> object:
    return float.fromhex(token.replace("-nan", "nan")) if real else int(token)


def _same(a: object, b: object) -> bool:
    """Bit for bit, but any NaN equals any NaN (the harness prints no payload)."""
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or struct.pack("<d", a) == struct.pack("<d", b)
    return a == b


class Columns:
    """The harness's columns, and how the Python module's objects map onto them."""

    def __init__(self, ir: MachineIR) -> None:
        self.ir = ir
        self.var_real = [v.ctype in REAL_CTYPES for v in ir.every_variable]
        self.reg_real = [r.ctype in REAL_CTYPES for r in ir.kept]
        self.out_real = [o.ctype in REAL_CTYPES for o in ir.outputs]

    def line(self, row: Row) -> str:
        return " ".join(_fmt(v) for v in row)

    def parse(self, line: str) -> Row:
        tokens = line.split()
        reals = [False, *self.var_real, *self.reg_real, *[False] * _flags(self.ir), *self.out_real]
        reals += [False] * len(self.ir.invariants)
        return tuple(_parse(t, r) for t, r in zip(tokens, reals, strict=True))

    def python_step(self, py: ModuleType, row: Row) -> Row:
        ir = self.ir
        ctx, inputs = self.split(py, row)
        seen = self.observers(py, row)
        before = py.Context(**vars(ctx))
        out = py.step(ctx, inputs)
        failing = py.monitor(before, ctx, inputs, py.DEFAULT_PARAMS, out, *seen)
        values: list[object] = [int(ctx.mode)]
        values += [getattr(seen[0] if v.observer else ctx, v.name) for v in ir.every_variable]
        values += [getattr(ctx, f"prev{r.index}") for r in ir.kept]
        if ir.first_flag:
            values.append(1 if ctx.first else 0)
        values += [getattr(out, o.name) for o in ir.outputs]
        values += [1 if inv.id in failing else 0 for inv in ir.invariants]
        return tuple(int(v) if isinstance(v, bool) else v for v in values)

    def split(self, py: ModuleType, row: Row) -> tuple[Any, Any]:
        ir = self.ir
        k = 0
        ctx = py.Context()
        ctx.mode = row[k]
        k += 1
        for v in ir.every_variable:
            if not v.observer:
                setattr(ctx, v.name, row[k])
            k += 1
        for r in ir.kept:
            setattr(ctx, f"prev{r.index}", bool(row[k]) if r.pytype == "bool" else row[k])
            k += 1
        if ir.first_flag:
            ctx.first = bool(row[k])
            k += 1
        values = {f.name: bool(row[k + n]) for n, f in enumerate(ir.inputs)}
        k += len(ir.inputs)
        values.update({f.name: row[k + n] for n, f in enumerate(ir.signals)})
        return ctx, py.Inputs(**values)

    def observers(self, py: ModuleType, row: Row) -> tuple[Any, ...]:
        """The Python module's observers that `row` holds: none where the machine has none (see
        `MachineIR.observers`)."""
        if not self.ir.observers:
            return ()
        g = py.Observers()
        for k, v in enumerate(self.ir.every_variable, 1):
            if v.observer:
                setattr(g, v.name, row[k])
        return (g,)

    def next_row(self, after: Row, inputs: Row) -> Row:
        """The harness row of the next step: the context after this one, then new inputs."""
        keep = context_width(self.ir)
        return after[:keep] + inputs


# --- the boundary set and the sequences ----------------------------------------------------------------


def signal_values(low: float, high: float, ctype: str) -> list[float | int]:
    """Range ends, just outside them, the middle, and for a real ±0, NaN, ±infinity and a subnormal, each a
    value of the field's C type (a float's neighbours and its smallest subnormal for binary32)."""
    if ctype not in REAL_CTYPES:
        return [int(low), int(high), int(low) - 1, int(high) + 1, (int(low) + int(high)) // 2]
    fmt = BY_CTYPE[ctype]
    outside = [fmt.next_after(low, -math.inf), fmt.next_after(high, math.inf)]
    middle = fmt.round((low + high) / 2)
    return [low, high, *outside, middle, 0.0, -0.0, math.nan, math.inf, -math.inf, fmt.smallest]


def _flags(ir: MachineIR) -> int:
    """The columns of the first-step flag: one where the context keeps it (see `MachineIR.first_flag`)."""
    return 1 if ir.first_flag else 0


def context_width(ir: MachineIR) -> int:
    """The columns of a context: the mode, the variables, the registers and the first-step flag if kept."""
    return 1 + len(ir.every_variable) + len(ir.kept) + _flags(ir)


def boundary_rows(ir: MachineIR) -> Iterator[Row]:
    """Every mode and boolean combination, each signal through its boundary values (the others in the middle),
    and each variable at 0, its limits and its initial value (the others initial)."""
    mids: list[float | int] = [_mid(f) for f in ir.signals]
    initial = _initial(ir)
    contexts = [initial]
    for k in range(len(ir.every_variable)):
        contexts += [[*initial[:k], x, *initial[k + 1 :]] for x in variable_values(ir, k)]
    signal_sets = [mids]
    for k, f in enumerate(ir.signals):
        for x in signal_values(_value(f.low.c, f.ctype), _value(f.high.c, f.ctype), f.ctype):  # type: ignore[union-attr]
            signal_sets.append([*mids[:k], x, *mids[k + 1 :]])
    registers = [False if r.pytype == "bool" else 0 for r in ir.kept]
    for mode in range(len(ir.states)):
        for first in ((1,), (0,)) if ir.first_flag else ((),):
            for bits in itertools.product((1, 0), repeat=len(ir.inputs)):
                for ctx in contexts:
                    for signals in signal_sets:
                        yield (mode, *ctx, *registers, *first, *bits, *signals)


def _initial(ir: MachineIR) -> list[float | int]:
    """Each variable's initial value."""
    return [_value(v.default.c, v.ctype) for v in ir.every_variable]  # type: ignore[union-attr]


def variable_values(ir: MachineIR, k: int) -> list[float | int]:
    """0, the limits and, for an int, each int param's default and its neighbours (the thresholds a timer is
    compared with), within the variable's range."""
    v = ir.every_variable[k]
    values: set[float | int] = {0}
    if v.low is not None and v.high is not None:
        low, high = _value(v.low.c, v.ctype), _value(v.high.c, v.ctype)
        values |= {low, high}
        if v.ctype not in REAL_CTYPES:
            defaults = [int(p.default.c) for p in ir.params if p.ctype not in REAL_CTYPES and p.default is not None]
            values |= {d + e for d in defaults for e in (-1, 0, 1) if low <= d + e <= high}
    return sorted(values)


def _value(text: str, ctype: str) -> float | int:
    """A constant of the C code as Python holds it: a real one (a binary32 one with suffix `f`) as C reads it."""
    return BY_CTYPE[ctype].of(Fraction(text.removesuffix("f"))) if ctype in REAL_CTYPES else int(text)


def _mid(f: Any) -> float | int:
    low, high = _value(f.low.c, f.ctype), _value(f.high.c, f.ctype)
    return _held(float(low + high) / 2, f.ctype) if f.ctype in REAL_CTYPES else (low + high) // 2


def _held(x: float | int, ctype: str) -> float | int:
    """A value as a field of the C type holds it: a binary32 field rounds a double (z3, the Python and the C are
    then all given the same value)."""
    return BY_CTYPE[ctype].round(float(x)) if ctype in REAL_CTYPES else x


def random_inputs(ir: MachineIR, rng: random.Random) -> Row:
    """Booleans, and signals mostly in range, now and then at a boundary value."""
    bits = tuple(rng.random() < 0.7 for _ in ir.inputs)
    signals: list[object] = []
    for f in ir.signals:
        low, high = _value(f.low.c, f.ctype), _value(f.high.c, f.ctype)  # type: ignore[union-attr]
        if rng.random() < 0.05:
            signals.append(rng.choice(signal_values(low, high, f.ctype)))
        elif f.ctype in REAL_CTYPES:
            signals.append(_held(rng.uniform(low, high), f.ctype))
        else:
            signals.append(rng.randint(int(low), int(high)))
    return tuple(int(b) for b in bits) + tuple(signals)


# --- the z3 semantics --------------------------------------------------------------------------------------


class Semantics:
    """One step of the spec by z3: the engine's step relation with every constant of the step fixed. Where no
    transition is enabled the mode is kept, as the code keeps it (generation refuses a machine that can reach
    such a step with otherwise = undefined; the boundary set also holds configurations no run reaches)."""

    def __init__(self, machine: Machine) -> None:
        machine = replace(machine, otherwise="stay")
        self.m = machine
        prevs = prevs_of(*(inv.expr for inv in machine.invariants))
        self.system = System(machine, prevs)
        self.stored = stored_registers(machine, prevs)  # the registers the code's context keeps
        self.pre, self.inputs, self.post = self.system.frame("s0"), self.system.inputs("s0"), self.system.frame("s1")
        self.link, self.terms = self.system.step(self.pre, self.inputs, self.post)
        self.solver = z3.Solver()
        self.solver.add(self.link)
        self.after = self._after_terms()

    def _after_terms(self) -> list[z3.ExprRef]:
        """The mode, the variables and the outputs after the step as terms over the state before and the inputs:
        the step relation is a function, each post-state constant equal to its next term."""
        t, post = self.terms, self.post
        next_vars = [t.next_variables[v.name] for v in self.m.variables]
        post_is = [(post.mode, t.next_mode), (post.first, z3.BoolVal(False))]
        post_is += [(post.variables[v.name], x) for v, x in zip(self.m.variables, next_vars, strict=True)]
        outputs = [z3.substitute(o, *post_is) for o in self.system.outputs_at(t.post).values()]
        return [t.next_mode, *next_vars, *outputs]

    def step(self, row: Row) -> tuple[int, list[bool | int | float], list[bool | int | float]]:
        """The mode, the variables and the outputs after the step from `row`: the terms of the step evaluated
        on its values by z3's simplifier, or, where a term does not simplify to a value (a division by zero,
        which z3 leaves uninterpreted), by a model of the step relation."""
        fixed = self._fixed(row)
        values = [z3.simplify(term) for term in _substituted(self.after, fixed)]
        if not all(_is_value(v) for v in values):
            values = self._solved(row, fixed)
        n = len(self.m.variables)
        mode = values[0]
        assert isinstance(mode, z3.IntNumRef)
        return mode.as_long(), [python_value(v) for v in values[1 : 1 + n]], [python_value(v) for v in values[1 + n :]]

    def _fixed(self, row: Row) -> list[tuple[z3.ExprRef, z3.ExprRef]]:
        """Each constant of the state before the step and of the inputs, paired with its value in `row`."""
        m = self.m
        k = 0
        fixed: list[tuple[z3.ExprRef, z3.ExprRef]] = [(self.pre.mode, z3.IntVal(int(row[k])))]
        k += 1
        for v in m.variables:
            fixed.append((self.pre.variables[v.name], _z3_value(row[k], v.type, None)))
            k += 1
        for reg in (r for n, r in self.pre.registers.items() if n in self.stored):
            fixed.append((reg, _register_value(reg, row[k])))
            k += 1
        if self.stored:  # else the code keeps no first-step flag: no kept register reads it
            fixed.append((self.pre.first, z3.BoolVal(bool(row[k]))))
            k += 1
        for i in m.inputs:
            fixed.append((self.inputs.bools[i.name], z3.BoolVal(bool(row[k]))))
            k += 1
        for sig in m.signals:
            fixed.append((self.inputs.signals[sig.name], _z3_value(row[k], sig.type, sig.range)))
            k += 1
        return fixed

    def _solved(self, row: Row, fixed: list[tuple[z3.ExprRef, z3.ExprRef]]) -> list[z3.ExprRef]:
        if self.solver.check(*(const == value for const, value in fixed)) != z3.sat:
            raise AssertionError(f"the spec has no step from {row}")
        model = self.solver.model()
        return [model.eval(z3.substitute(term, *fixed), model_completion=True) for term in self.after]


def _substituted(terms: list[z3.ExprRef], pairs: list[tuple[z3.ExprRef, z3.ExprRef]]) -> list[z3.ExprRef]:
    """`terms` with each constant of `pairs` replaced by its value: z3.substitute without its checks of every
    pair's sorts, which cost more than the substitution (the pairs are built of matching sorts)."""
    n = len(pairs)
    old, new = (z3.Ast * n)(), (z3.Ast * n)()
    for k, (const, value) in enumerate(pairs):
        old[k], new[k] = const.as_ast(), value.as_ast()
    ctx = terms[0].ctx if terms else z3.main_ctx()
    return [z3_api._to_expr_ref(z3.Z3_substitute(ctx.ref(), t.as_ast(), n, old, new), ctx) for t in terms]


def _is_value(term: z3.ExprRef) -> bool:
    return bool(
        z3.is_true(term)
        or z3.is_false(term)
        or z3.is_int_value(term)
        or z3.is_rational_value(term)
        or z3.is_algebraic_value(term)
    )


def _register_value(reg: z3.ExprRef, value: object) -> z3.ExprRef:
    """A kept register's value as z3 reads it, as `reg == value` coerces it."""
    if z3.is_bool(reg):
        return z3.BoolVal(bool(value))
    return z3.IntVal(value) if z3.is_int(reg) else z3.RealVal(value)


def _z3_value(value: object, kind: Type, bounds: tuple[Fraction, Fraction] | None) -> z3.ExprRef:
    """A sample as z3 reads it: NaN and the infinities are values outside the signal's range."""
    if isinstance(value, float) and not math.isfinite(value):
        assert bounds is not None
        outside = bounds[0] - 1 if value == -math.inf else bounds[1] + 1
        return value_of(outside, kind)
    assert isinstance(value, int | float)
    return value_of(Fraction(value), kind)


# --- checks ------------------------------------------------------------------------------------------------


def build_harness(t: Subject, name: str, extra: Sequence[str]) -> tuple[Path | None, str]:
    source = t.build / "harness.c"
    source.write_text(render_template("harness.c.j2", m=t.ir), encoding="utf-8")
    exe = t.build / name
    ran = run(
        [
            "gcc",
            *C_FLAGS,
            *extra,
            "-ffp-contract=off",
            f"-I{t.layout.c_header.parent}",
            "-o",
            str(exe),
            str(source),
            str(t.layout.c_source),
        ],
        timeout=180,
    )
    return (exe if ran.returncode == 0 else None), ran.output.strip()


def compile_and_load(t: Subject) -> tuple[CheckOutcome, Code | None]:
    harness, output = build_harness(t, "harness", ["-O2"])
    if harness is None:
        return CheckOutcome("compile", False, f"gcc failed:\n{output}"), None
    py = import_generated(t.layout.python, f"mlca_generated_{t.ir.module}")
    detail = f"gcc {' '.join(C_FLAGS)} -O2 -ffp-contract=off: no warning; Python imported"
    return CheckOutcome("compile", True, detail), Code(py, harness)


def run_harness(exe: Path, rows: Sequence[Row], columns: Columns) -> list[Row]:
    text = "".join(columns.line(r) + "\n" for r in rows)
    ran = run([str(exe)], stdin=text, timeout=600)
    if ran.returncode != 0:
        raise AssertionError(f"the harness failed (exit {ran.returncode}):\n{ran.output[-3000:]}")
    return [columns.parse(line) for line in ran.output.splitlines()]


def exhaustive(t: Subject, code: Code) -> CheckOutcome:
    """The boundary set: Python and C bit for bit, and both as z3's semantics of the spec says; from a mode that
    names no state, both restart in the fallback mode with the initial values."""
    columns, z3_step = Columns(t.ir), Semantics(t.machine)
    rows = list(boundary_rows(t.ir))
    restarts = restart_rows(t.ir, rows)
    c_rows = run_harness(code.harness, [*rows, *restarts], columns)
    keep = 1 + len(t.ir.every_variable)
    outputs = slice(context_width(t.ir), context_width(t.ir) + len(t.ir.outputs))
    for row, c_after in zip(rows, c_rows[: len(rows)], strict=True):
        differ = _languages_differ(code.py, columns, row, c_after)
        if differ:
            return CheckOutcome("exhaustive", False, differ)
        mode, variables, outs = z3_step.step(row)
        ours = (c_after[0], *c_after[1:keep], *c_after[outputs])
        theirs = (mode, *variables, *outs)
        if not all(_close(a, b, TOLERANCES[t.ir.reals]) for a, b in zip(ours, theirs, strict=True)):
            return CheckOutcome(
                "exhaustive", False, f"the code and the spec (z3) differ from {row}: {ours} vs {theirs}"
            )
    failed = _restart_failure(code.py, columns, restarts, c_rows[len(rows) :])
    if failed:
        return CheckOutcome("exhaustive", False, failed)
    detail = (
        f"{len(rows)} steps ({_boundary_words(t.ir)}): Python and C agree bit for bit, and both agree with z3's "
        f"semantics of the spec; {len(restarts)} steps from a mode that names no state: both restart in "
        f"{t.ir.fallback}{' with the initial values' if t.ir.every_variable or t.ir.kept else ''}"
    )
    return CheckOutcome("exhaustive", True, detail, data={"steps": len(rows), "restarts": len(restarts)})


def _boundary_words(ir: MachineIR) -> str:
    """What the boundary set holds, in the machine's own terms (no signal or variable where it has none)."""
    parts = [
        "every mode, boolean combination and first-step flag" if ir.first_flag else "every mode and boolean combination"
    ]
    if ir.signals:
        parts.append("each signal at its range ends, just outside, the middle, ±0, NaN, ±infinity and a subnormal")
    if ir.every_variable:
        parts.append("each variable at 0, its limits and its initial value")
    return "; ".join(parts)


def restart_rows(ir: MachineIR, rows: Sequence[Row]) -> list[Row]:
    """The boundary rows of the first mode after the first step, each with a mode that names no state instead (a
    context corrupted during a run)."""
    flag = 1 + len(ir.every_variable) + len(ir.kept)
    return [(len(ir.states), *row[1:]) for row in rows if row[0] == 0 and (not ir.first_flag or row[flag] == 0)]


def restarted(ir: MachineIR) -> Row:
    """The mode, variables, registers and first-step flag a corrupted context restarts with, as the spec says."""
    return (ir.states.index(ir.fallback), *_initial(ir), *[0] * len(ir.kept), *[1] * _flags(ir))


def _languages_differ(py: ModuleType, columns: Columns, row: Row, c_after: Row) -> str | None:
    """How the Python step from `row` differs from the C one, bit for bit (None: it does not)."""
    py_after = columns.python_step(py, row)
    if all(_same(a, b) for a, b in zip(py_after, c_after, strict=True)):
        return None
    return f"Python and C differ from {row}: {py_after} vs {c_after}"


def _restart_failure(py: ModuleType, columns: Columns, rows: Sequence[Row], c_rows: Sequence[Row]) -> str | None:
    expected = restarted(columns.ir)
    for row, c_after in zip(rows, c_rows, strict=True):
        differ = _languages_differ(py, columns, row, c_after)
        if differ:
            return differ
        got = c_after[: len(expected)]
        if not all(_close(a, b, TOLERANCES[columns.ir.reals]) for a, b in zip(got, expected, strict=True)):
            return f"from {row} (a mode that names no state) the code restarted as {got}, not as {expected}"
    return None


def _close(a: object, b: object, tolerance: float) -> bool:
    if isinstance(a, float) or isinstance(b, float):
        x, y = float(a), float(b)  # type: ignore[arg-type]
        return (math.isnan(x) and math.isnan(y)) or x == y or abs(x - y) <= tolerance * max(abs(x), abs(y))
    return a == b


def _invariant_standing(machine: Machine) -> tuple[set[str], dict[str, str]]:
    """The invariants the engine proves at the default params with no caveat, and of the others what the
    engine says (a failure of one of those in a run is news, not a fault of the code)."""
    proved: set[str] = set()
    said: dict[str, str] = {}
    for r in check_data_machine(machine, Limits()):
        if r.kind != "invariant":
            continue
        if r.verdict == "holds" and not r.caveat:
            proved.add(r.prop)
        else:
            said[r.prop] = "proved over the reals only" if r.verdict == "holds" else f"not proved ({r.verdict})"
    return proved, said


def sequences(t: Subject, code: Code) -> CheckOutcome:
    """Random runs from the initial context, each step fed to Python and C alike; the invariants the engine
    proves must hold (the first failure of any other is reported, with what the engine says of it)."""
    columns = Columns(t.ir)
    proved, said = _invariant_standing(t.machine)
    assumed = _assumptions(t.machine, t.ir)
    seen: dict[str, str] = {}
    total = outside = 0
    for seed in range(max(1, t.sequences // 100)):
        rng = random.Random(seed)
        ctx = code.py.Context()
        row: Row = (int(ctx.mode), *_initial(t.ir))
        row = (*row, *(False if r.pytype == "bool" else 0 for r in t.ir.kept), *[1] * _flags(t.ir))
        rows: list[Row] = []
        py_rows: list[Row] = []
        inside = True  # every step of the run so far within the environment assumptions
        for _ in range(SEQUENCE_STEPS):
            row = _drawn(row, t.ir, rng, assumed)
            inside = inside and assumed(row)
            outside += not inside
            after = columns.python_step(code.py, row)
            rows.append(row)
            py_rows.append(after)
            failing = [inv.id for inv, bit in zip(t.ir.invariants, after[-len(t.ir.invariants) :], strict=False) if bit]
            failing = failing if inside else []  # the proofs say nothing of a run the environment left
            if proved & set(failing):
                return CheckOutcome("sequences", False, f"a proved invariant failed: {sorted(proved & set(failing))}")
            for inv in failing:
                seen.setdefault(inv, f"{inv} ({said.get(inv, 'not proved')}) fails at seed {seed}, step {len(rows)}")
            row = after[: context_width(t.ir)]
        c_rows = run_harness(code.harness, rows, columns)
        for k, (a, b) in enumerate(zip(py_rows, c_rows, strict=True)):
            if not all(_same(x, y) for x, y in zip(a, b, strict=True)):
                return CheckOutcome("sequences", False, f"seed {seed}, step {k + 1}: Python {a}, C {b}")
        total += len(rows)
    detail = f"{total} steps in runs of {SEQUENCE_STEPS}: Python and C agree bit for bit; no proved invariant fails"
    if outside:
        detail += (
            f" ({total - outside} steps within the environment assumptions; the invariants are not checked on the "
            f"{outside} after a run's first step outside them)"
        )
    if seen:
        detail += "; of the invariants not proved: " + "; ".join(seen[k] for k in sorted(seen))
    return CheckOutcome("sequences", True, detail, data={"steps": total, "unproved_failing": sorted(seen)})


def _drawn(context: Row, ir: MachineIR, rng: random.Random, assumed: Callable[[Row], bool], tries: int = 20) -> Row:
    """The context with random inputs for the next step: the first of `tries` draws the environment assumptions
    allow, else the last one drawn."""
    for _ in range(tries - 1):
        row = context + random_inputs(ir, rng)
        if assumed(row):
            return row
    return context + random_inputs(ir, rng)


def _assumptions(machine: Machine, ir: MachineIR) -> Callable[[Row], bool]:
    """Whether a step (a row: the context before it, then its inputs and signals) satisfies every environment
    assumption, evaluated in the code's arithmetic at the default params."""
    if not machine.assumptions:
        return lambda row: True
    semantics = Binary64(machine)
    params = {p.name: semantics.real(p.default) if p.type == "real" else int(p.default) for p in machine.params}
    names = [v.name for v in ir.every_variable]
    first_input = context_width(ir)
    inputs = [f.name for f in ir.inputs] + [f.name for f in ir.signals]

    def holds(row: Row) -> bool:
        env: dict[str, Value64] = {**params, **dict(zip(names, row[1 : 1 + len(names)], strict=True))}
        for name, value in zip(inputs, row[first_input:], strict=True):
            env[name] = bool(value) if name in machine.input_names else value
        mode = machine.states[int(row[0])]
        return all(bool(semantics.ev(a.expr, env, mode)) for a in machine.assumptions)

    return holds


def sanitizers(t: Subject) -> CheckOutcome:
    exe, output = build_harness(t, "harness-san", list(SANITIZE))
    if exe is None:
        return CheckOutcome("sanitizers", False, f"gcc failed:\n{output}")
    columns = Columns(t.ir)
    rows = list(boundary_rows(t.ir))
    try:
        run_harness(exe, rows, columns)
    except AssertionError as err:
        return CheckOutcome("sanitizers", False, str(err))
    detail = f"{len(rows)} boundary steps under {' '.join(SANITIZE[:1])}: no report"
    missed = _invalid_bools_missed(t, exe, "".join(columns.line(r) + "\n" for r in rows))
    if missed is not None:
        return CheckOutcome("sanitizers", False, missed)
    return CheckOutcome("sanitizers", True, detail + ("; inputs outside 0/1 reported" if t.ir.inputs else ""))


def _invalid_bools_missed(t: Subject, exe: Path, rows: str) -> str | None:
    """The step's precondition (every bool input is 0 or 1) is one an integrator's UBSan build checks: a step on
    0xFF bytes must be reported wherever the code reads a bool input. The boundary steps (`rows`) are taken
    again with their bool inputs 0xFF, at the default params and at their ranges' ends, since a mode's guards may
    read an input only for some signals, variables, params or other inputs. None when one is reported (or when
    the code reads none), else what went wrong."""
    if not t.ir.inputs:
        return None
    ran = run([str(exe), "invalid"], stdin=rows, timeout=600)
    if ran.returncode != 0 and "not a valid value for type" in ran.output:
        return None
    source = t.layout.c_source.read_text(encoding="utf-8")
    if not any(f"i->{f.name}" in source for f in t.ir.inputs):
        return None
    told = f":\n{ran.output.strip()[-500:]}" if ran.output.strip() else ""
    return f"no boundary step on inputs outside 0/1 was reported by -fsanitize=bool{told}"


def cross_build(t: Subject) -> CheckOutcome:
    obj = t.build / "m4.o"
    su = t.build / "m4.su"
    ran = run(
        [
            "arm-none-eabi-gcc",
            *C_FLAGS,
            *arm_flags(t.ir.reals),
            "-ffp-contract=off",
            "-fstack-usage",
            "-c",
            "-o",
            str(obj),
            str(t.layout.c_source),
        ],
        timeout=120,
    )
    if ran.returncode != 0:
        return CheckOutcome("cortex-m4", False, f"arm-none-eabi-gcc failed:\n{ran.output.strip()}")
    size = run(["arm-none-eabi-size", str(obj)]).output.splitlines()[-1].split()
    text, data, bss = (int(x) for x in size[:3])
    stack = obj.with_suffix(".su")
    usage = stack.read_text(encoding="utf-8") if stack.is_file() else su.read_text(encoding="utf-8")
    frames = {m.group(1): int(m.group(2)) for m in re.finditer(r":\d+:\d+:(\w+)\t(\d+)", usage)}
    step = frames.get(f"{t.ir.module}_step", -1)
    calls = external_calls(obj)
    single = t.ir.reals == "binary32"
    outside = calls if single else library_calls(calls)  # binary32 runs on the FPU: not even a helper is called
    where = ", binary32 on the single-precision FPU" if single else ", binary64 in software"
    where = where if t.ir.has_reals else ""
    detail = (
        f"arm-none-eabi-gcc {' '.join(arm_flags(t.ir.reals))}{where}: text {text} B, data {data} B, bss {bss} B; "
        f"stack: {t.ir.module}_step's own frame {step} B, every frame summed {sum(frames.values())} B (a bound on "
        f"any call chain: there is no recursion); {_calls_text(calls, outside)}"
    )
    info = {"text": text, "data": data, "bss": bss, "stack": frames, "calls": calls}
    return CheckOutcome("cortex-m4", not outside, detail, data=info)


def _calls_text(calls: list[str], outside: list[str]) -> str:
    if outside:
        return f"calls out of the object: {', '.join(outside)}"
    if calls:
        return f"no library call (binary64 through the compiler's soft-float helpers {', '.join(calls)})"
    return "no call out of the object"


# WP's flags, beside conform.c_tools.WP, with its budget of steps: MLCA-T's hardest goal
# takes 13.3 million (11 s here), and the budget is 3 times that.
WP_STEPS = 40_000_000
WP_FLAGS = ("-wp-steps", str(WP_STEPS), "-warn-special-float", "none", "-wp-prop=-binary64")


def wp_flags(reals: str) -> tuple[str, ...]:
    """WP's flags for a machine: its format's label left out (`binary64_goals`)."""
    return (*WP_FLAGS[:-1], f"-wp-prop=-{reals}")


def frama_c(t: Subject) -> CheckOutcome:
    """WP: no runtime error (integer overflow included), the step equal to the spec's transition relation (the
    transition that fires, by the ACSL behaviours of each mode, and the context and outputs after it), variables
    kept in range, the mode a state. The IEEE 754 special values are allowed (-warn-special-float none): NaN and
    the infinities are inputs the code handles by design, never read by a decision (the validity gate comes
    first). The ensures clauses labelled `binary64` link a C function that computes on reals to its logic
    symbol, which has no body (see `codegen.ir.binary64`): they are listed, not sent to the prover. Then
    the spec's proved invariants, each with its certificate, on a wrapper of the step (`certified`)."""
    monitor, outputs = f"{t.ir.module}_monitor", f"{t.ir.module}_outputs"
    flags = (*wp_flags(t.ir.reals), "-wp-skip-fct", f"{monitor},{outputs}")
    outcome = _joined(wp_file(t.layout.c_source, t.build, flags), _outputs_proved(t, outputs))
    left = binary64_goals(t.ir)
    note = (
        f"; {monitor} is not proved (WP times out on its memory accesses) and is covered by the exhaustive and "
        "sequence checks instead"
    )
    if left:
        note += (
            f"; {len(left)} {t.ir.reals} goal(s) left to the exhaustive and sequence checks (z3 bit-blasts "
            f"{t.ir.reals} and runs out of memory): {', '.join(left)}"
        )
    data = {**(outcome.data or {}), "binary64": left}
    if outcome.ok:
        certified = certified_invariants(t)
        data["certified"] = certified.data
        note += "; " + certified.detail
        outcome = replace(outcome, ok=certified.ok)
    return replace(outcome, detail=outcome.detail + note, data=data)


def _outputs_proved(t: Subject, outputs: str) -> CheckOutcome:
    """WP on the outputs' function; where a goal is left, again with each goal split at its conditionals. The
    split proves an int output that multiplies two values read from the spec (a nonlinear goal z3 leaves
    unknown whole); it is not the first try, because a split goal that compares binary64 values makes z3
    bit-blast."""
    whole = wp_file(t.layout.c_source, t.build, (*wp_flags(t.ir.reals), "-wp-fct", outputs))
    if whole.ok:
        return whole
    split = wp_file(t.layout.c_source, t.build, (*wp_flags(t.ir.reals), "-wp-split", "-wp-fct", outputs))
    return split if split.ok else whole


def _joined(step: CheckOutcome, outputs: CheckOutcome) -> CheckOutcome:
    """The two WP runs as one: every function but the outputs', and the outputs' (see `_outputs_proved`;
    splitting every function instead did not finish MLCA-T's proof in 10 minutes)."""
    if "proved" not in step.data or "proved" not in outputs.data:
        return step if "proved" not in step.data else outputs
    proved = step.data["proved"] + outputs.data["proved"]
    total = step.data["goals"] + outputs.data["goals"]
    unproved = step.data["unproved"] + outputs.data["unproved"]
    data = {
        "proved": proved,
        "goals": total,
        "unproved": unproved,
        "goal_list": step.data["goal_list"] + outputs.data["goal_list"],
    }
    if not (step.ok and outputs.ok):
        detail = f"{proved} / {total} goals proved; not proved: {', '.join(unproved) or '?'}"
        return CheckOutcome("frama-c-wp", False, detail, data=data)
    detail = step.detail.replace(f"{step.data['proved']} / {step.data['goals']}", f"{proved} / {total}")
    split = ", each goal split at its conditionals" if "-wp-split" in outputs.detail else ""
    detail += f" (the outputs' function on its own{split}: {outputs.data['goals']} goals)"
    return CheckOutcome("frama-c-wp", True, detail, data=data)


def certified_invariants(t: Subject) -> CheckOutcome:
    """The invariants the engine proves for every param in range, as postconditions of a wrapper of the step
    with their certificates as precondition, proved by WP from the step's contract (see `codegen.certified`)."""
    results = check_data_machine(t.machine, Limits(), parametric=True)
    lowering = AcslLowering.of(t.machine, t.ir.module, t.ir.macro)
    seen, opaque = as_wp_sees(t.machine, lowering.n.types)
    proved = _certified(results)
    opened = [p.id for p in proved]
    if opaque:  # as WP sees the machine: those definitions' values free at every step
        proved = _certified(check_invariants(seen, Limits(), opened, parametric=True))
    stated, left = certify(t.machine, lowering, proved)
    kept = {p.id for p in proved}
    left += needs_arithmetic(t.machine, lowering.n.types, [i for i in opened if i not in kept], opaque)
    source = t.build / f"{t.ir.module}_certified.c"
    text = render_template(
        CERTIFIED_TEMPLATE,
        m=t.ir,
        source=str(t.layout.c_source.resolve()),
        certified=stated,
        in_range=ranges(t.machine, "cp", "pp", pointer=True, g="gp"),
        params_in_range=ranges(t.machine, None, "p", pointer=False),
        assumed=assumed_text(t.machine, lowering),
    )
    source.write_text(text, encoding="utf-8")
    fcts = f"{t.ir.module}_step_certified,{t.ir.module}_init_certified"
    ran = wp_file(source, t.build, (*wp_flags(t.ir.reals), "-wp-fct", fcts))
    data = {**(ran.data or {}), "stated": [x.id for x in stated], "left": [f"{i}: {why}" for i, why in left]}
    unproved = [r.prop for r in results if r.kind == "invariant" and r.prop not in data["stated"]]
    detail = (
        f"{len(stated)} invariant(s) proved on the step with their certificates ({ran.detail.split(': ')[-1]})"
        if ran.ok
        else f"the invariants with their certificates: {ran.detail}"
    )
    if unproved:
        detail += f"; not stated: {', '.join(unproved)}" + (f" ({'; '.join(data['left'])})" if left else "")
    reached, unkept = _reached_ranges(t, results)
    data["in_reach"] = reached
    return CheckOutcome("frama-c-wp", ran.ok and not unkept, detail + _unkept_detail(reached, unkept), data=data)


def _certified(results: Sequence[Result]) -> list[Proved]:
    """The invariants proved, each with a certificate a separate query confirmed."""
    return [
        Proved(r.prop, r.proof.certificate)
        for r in results
        if r.kind == "invariant"
        and r.verdict == "holds"
        and r.proof is not None
        and r.proof.certificate is not None
        and r.proof.certificate_checked
    ]


def _reached_ranges(t: Subject, results: Sequence[Result]) -> tuple[list[str], list[str]]:
    """The variables whose range the step's contract requires without ensuring it (one step does not keep it from
    every context in range), and those of them whose range:<name> the engine does not prove for every param."""
    verdicts = {r.prop: r.verdict for r in results}
    reached = [f.name for f in t.ir.variables if not f.kept]
    return reached, [n for n in reached if verdicts.get(f"range:{n}") != "holds"]


def _unkept_detail(reached: Sequence[str], unkept: Sequence[str]) -> str:
    if not reached:
        return ""
    text = (
        f"; the range of {', '.join(reached)} is kept only from the contexts a run reaches, so the step requires "
        "it of the context before it (in_reach), admits it of the one after it and leaves it to the engine's "
        f"{', '.join(f'range:{n}' for n in reached)}"
    )
    if unkept:
        listed = ", ".join(f"range:{n}" for n in unkept)
        text += f", but {listed} does not hold for every param in range (`mlca-verify check --parametric`)"
    return text


def binary64_goals(ir: MachineIR) -> list[str]:
    """The clauses labelled `binary64` (or `binary32`, the machine's format), which WP is not asked to prove: the
    link of each C function that computes on reals to its logic symbol, and what the step, the reset and the
    outputs say of the real variables, registers and outputs (see `codegen.rounded`)."""
    p = ir.module
    names = [f"{p}_shape{sh.index}" for sh in ir.shapes if not sh.exact]
    names += [f"{p}_def_{d.name}" for d in ir.definitions if d.name in ir.used and not d.exact]
    names += [f"{p}_b64_{r.index}" for r in ir.rounded]
    names += [f"{p}_reg{r.index}" for r in ir.registers if r.ctype in REAL_CTYPES]
    clauses = [f"{name}: ensures" for name in names]
    if any(f.ctype in REAL_CTYPES for f in ir.variables) or any(r.ctype in REAL_CTYPES for r in ir.kept):
        clauses += [f"{p}_reset: ensures (reals)", f"{p}_init: ensures (reals)", f"{p}_step: ensures (real variables)"]
    if any(o.ctype in REAL_CTYPES for o in ir.outputs):
        clauses += [f"{p}_outputs: ensures (reals)", f"{p}_step: ensures (real outputs)"]
    return clauses


def cppcheck(t: Subject) -> CheckOutcome:
    return cppcheck_file(t.layout.c_source, t.build)


SUITE: Suite[Subject, Code] = Suite(
    compile_and_load,
    {"exhaustive": exhaustive, "sequences": sequences},
    {"frama-c-wp": frama_c, "cppcheck": cppcheck, "cortex-m4": cross_build, "sanitizers": sanitizers},
)
