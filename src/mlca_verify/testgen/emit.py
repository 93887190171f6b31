"""The suite written out: a pytest module over the generated Python and a C program over the generated C, with
the same runs, monitor calls and params checks and the spec's expected answers.

The C program prints one line per step or call (the context, the outputs and the monitor's answer, reals as the
16 hex digits of their binary64 bits), then `N passed, N failed`; the same source runs on the host and, built
with MLCA_TARGET, on a Cortex-M4, so that the two outputs can be compared line for line."""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from fractions import Fraction
from typing import cast

from mlca_verify.codegen.lower import real_literal
from mlca_verify.codegen.render import Escaped, render_template
from mlca_verify.conformance.generated_code import TOLERANCES
from mlca_verify.floats import FORMATS, Reals
from mlca_verify.model import Machine, observer_variables
from mlca_verify.testgen.search import Pair
from mlca_verify.testgen.suite import Case, MonitorCase, Suite


@dataclass(frozen=True)
class Header:
    spec_path: str
    sha256: str
    module_path: str  # the generated Python, relative to the test file


def py_value(value: object) -> str:
    if isinstance(value, float):
        return real_literal(Fraction(value))
    return repr(value)


def c_value(value: object, real: str) -> str:
    """A value as C writes it into a field: `real` is the field's format ("" for a bool or an int field)."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if real and isinstance(value, float) and not math.isfinite(value):
        return "NAN" if math.isnan(value) else ("INFINITY" if value > 0 else "-INFINITY")
    if real and isinstance(value, float) and value == 0 and math.copysign(1.0, value) < 0:
        return "-0.0"
    if real and isinstance(value, int | float):
        return real_literal(Fraction(value), FORMATS[cast(Reals, real)])
    return str(value)


def _py_dict(values: Mapping[str, object]) -> Escaped:
    return Escaped("{" + ", ".join(f"{k!r}: {py_value(v)}" for k, v in values.items()) + "}")


def _types(m: Machine) -> dict[str, str]:
    """Which names hold reals: the machine's format for those, "" for the others."""
    typed = [(x.name, x.type) for x in m.signals] + [(x.name, x.type) for x in m.variables]
    typed += [(x.name, x.type) for x in m.outputs] + [(x.name, x.type) for x in m.params]
    return {name: m.reals if kind == "real" else "" for name, kind in typed}


def real_comparison(m: Machine) -> dict[str, object]:
    """How both suites compare a real the code computed with the spec's exact value: within the relative
    tolerance of its format (TOLERANCES), plus an absolute slack per real variable and output, that tolerance
    times the magnitude of its declared range (0 without one). Near zero a relative tolerance alone is too
    tight: a cruise control's clamped deceleration is 0.0 in binary64 where the spec's exact value is 1.8e-16."""
    tolerance = TOLERANCES[m.reals]
    ranged = [(o.name, o.range) for o in m.outputs if o.type == "real"]
    ranged += [(v.name, v.range) for v in m.variables if v.type == "real"]
    slack = {
        name: tolerance * float(max(abs(bounds[0]), abs(bounds[1]))) if bounds is not None else 0.0
        for name, bounds in sorted(ranged)
    }
    bounds = {k: Escaped(repr(v)) for k, v in slack.items()}
    return {"tolerance": Escaped(repr(tolerance)), "bounds": bounds, "reals": Escaped(m.reals)}


def _c_struct(values: Mapping[str, object], real: dict[str, str]) -> Escaped:
    fields = ", ".join(f".{k} = {c_value(v, real.get(k, ''))}" for k, v in values.items())
    return Escaped("{" + (fields or "0") + "}")  # C99 has no empty initializer


def python_suite(suite: Suite, header: Header) -> str:
    m = suite.machine
    runs = [_py_run(m, c) for c in suite.cases]
    monitors = [_py_monitor(c) for c in suite.monitor]
    params = [(Escaped(repr(p.name)), _py_dict(dict(p.values)), p.valid) for p in suite.params]
    return render_template(
        "mcdc_test.py.j2",
        h=header,
        m=m,
        **real_comparison(m),
        runs=runs,
        monitors=monitors,
        params=params,
        counts=_counts(suite),
    )


def _py_run(
    m: Machine, case: Case
) -> tuple[Escaped, Escaped, list[tuple[Escaped, Escaped, Escaped, Escaped, Escaped]]]:
    steps = []
    for inputs, e in zip(case.inputs, case.expected, strict=True):
        variables = dict(zip((v.name for v in m.variables), e.variables, strict=True))
        outputs = dict(zip((o.name for o in m.outputs), e.outputs, strict=True))
        steps.append(
            (
                _py_dict(dict(inputs)),
                Escaped(repr(e.state)),
                _py_dict(variables),
                _py_dict(outputs),
                Escaped(repr(list(e.failing))),
            )
        )
    start = Escaped("None") if case.start is None else _py_dict(dict(case.start))
    return Escaped(repr(case.name)), start, steps


def _py_monitor(case: MonitorCase) -> tuple[Escaped, ...]:
    s = case.snapshot
    return (
        Escaped(repr(case.name)),
        _py_dict(dict(s.before)),
        _py_dict(dict(s.after)),
        _py_dict(dict(s.inputs)),
        _py_dict(dict(s.outputs)),
        Escaped(repr(list(s.failing))),
    )


def _counts(suite: Suite) -> dict[str, int]:
    return {
        "runs": len(suite.cases),
        "steps": sum(len(c.inputs) for c in suite.cases),
        "monitor": len(suite.monitor),
        "params": len(suite.params),
        "objectives": len(suite.pairs),
        "uncovered": len(suite.uncovered),
    }


def c_suite(suite: Suite, header: Header, sequence: Sequence[Mapping[str, object]]) -> str:
    """The C program; `sequence` (inputs, step by step) is run after the suite and printed for the back-to-back
    comparison of host and target."""
    m = suite.machine
    real = _types(m)
    invariants = [i.id for i in m.invariants]
    watched = observer_variables(m)
    runs = []
    for c in suite.cases:
        steps = []
        for inputs, e in zip(c.inputs, c.expected, strict=True):
            variables, seen = _apart(dict(zip((v.name for v in m.variables), e.variables, strict=True)), watched)
            outputs = dict(zip((o.name for o in m.outputs), e.outputs, strict=True))
            steps.append(
                (
                    _c_struct(dict(inputs), real),
                    m.states.index(e.state),
                    _c_struct(variables, real) if variables else Escaped("{0}"),
                    _c_struct(outputs, real) if outputs else Escaped("{0}"),
                    _mask(e.failing, invariants),
                    _c_struct(seen, real),
                )
            )
        start, start_seen = _apart(dict(c.start or {}), watched)
        runs.append((c.name, c.start is not None, _c_struct(start, real), steps, _c_struct(start_seen, real)))
    monitors = [_c_monitor(c, real, invariants, watched) for c in suite.monitor]
    params = [(p.name, _c_struct(dict(p.values), real), p.valid) for p in suite.params]
    return render_template(
        "mcdc_runner.c.j2",
        h=header,
        m=m,
        observers=[v.name for v in m.variables if v.name in watched],
        **real_comparison(m),
        module=m.name.lower(),
        macro=m.name.upper(),
        runs=runs,
        monitors=monitors,
        params=params,
        real=real,
        counts=_counts(suite),
        sequence=[_c_struct(s, real) for s in sequence],
    )


def _mask(failing: Sequence[str], invariants: list[str]) -> str:
    bits = 0
    for name in failing:
        if name in invariants:
            bits |= 1 << invariants.index(name)
    return f"0x{bits:x}u"


def _apart(values: Mapping[str, object], watched: frozenset[str]) -> tuple[dict[str, object], dict[str, object]]:
    """A context's values as the code holds them: the context's, and the observers' (see `MachineIR.observers`)."""
    ours = {k: v for k, v in values.items() if k not in watched}
    return ours, {k: v for k, v in values.items() if k in watched}


def _c_monitor(
    case: MonitorCase, real: dict[str, str], invariants: list[str], watched: frozenset[str]
) -> tuple[object, ...]:
    s = case.snapshot
    before, seen = _apart(dict(s.before), watched)
    return (
        case.name,
        _c_struct(before, real),
        _c_struct(_apart(dict(s.after), watched)[0], real),
        _c_struct(dict(s.inputs), real),
        _c_struct(dict(s.outputs), real) if s.outputs else Escaped("{0}"),
        _mask(s.failing, invariants),
        int(s.after["mode"]),
        _c_struct(seen, real),
    )


def objectives_json(suite: Suite, header: Header) -> str:
    """Every objective with the tests that cover it, or the reason none can."""
    rows = [_objective_row(p) for p in suite.pairs]
    doc = {
        "spec": header.spec_path,
        "sha256": header.sha256,
        "depth": suite.depth,
        "counts": _counts(suite),
        "objectives": rows,
        "unvisited_states": suite.unvisited,
    }
    return json.dumps(doc, indent=1, sort_keys=True) + "\n"


def _objective_row(p: Pair) -> dict[str, object]:
    o = p.objective
    return {
        "id": o.id,
        "decision": o.decision.id,
        "kind": o.decision.kind,
        "condition": o.label,
        "form": p.form,
        "reason": p.reason,
        "cite": o.decision.cite,
    }
