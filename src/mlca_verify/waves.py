"""A trace as a table (CSV) and as a waveform (VCD, IEEE 1364 value change dump, for GTKWave and other viewers).

Pure: strings from a Counterexample, no I/O. Both speak of step k as one sample: the state the step starts in,
its inputs, signals and definitions (as its guards saw them), the transition that fired, and the variables and
outputs after it. The VCD puts step k at time k times the machine's step (`step_s`), or k time units where the
spec has none; the state is a wire per state (in scope `state`), the transition a wire per transition (in
scope `fired`), high for the step it fires in; `loop` is high from the step a lasso's loop starts at.
"""

from __future__ import annotations

import csv
import io
import re
from collections.abc import Iterator, Mapping, Sequence
from fractions import Fraction

from mlca_verify.logic.results import Counterexample, Number, Step
from mlca_verify.model import Machine

NAME = re.compile(r"[^A-Za-z0-9_.-]")
FILE_LIMIT = 120  # characters of a trace file's stem
_CODES = [chr(c) for c in range(33, 127) if chr(c) != "$"]  # identifier codes; no `$`, which starts keywords
_UNITS = (("s", 1), ("ms", 10**3), ("us", 10**6), ("ns", 10**9))


def file_stem(machine: str, prop: str, taken: set[str]) -> str:
    """A file name stem for the trace of `prop` that no shell, path or viewer misreads, unique within `taken`
    (which it joins): characters other than letters, digits, `_`, `.` and `-` become `_`."""
    stem = NAME.sub("_", f"{machine}.{prop}")[:FILE_LIMIT].lstrip(".-") or "trace"
    unique, n = stem, 2
    while unique.lower() in taken:
        unique, n = f"{stem}.{n}", n + 1
    taken.add(unique.lower())
    return unique


_GROUPS = (("in", "inputs"), ("signal", "signals"), ("def", "definitions"), ("var", "variables"), ("out", "outputs"))
_FIELD = dict(_GROUPS)  # a group's Step attribute


def _groups(cx: Counterexample) -> list[tuple[str, list[str]]]:
    return [(group, list(getattr(cx.steps[0], field))) for group, field in _GROUPS]


def _value(step: Step, group: str, name: str) -> Number:
    table: Mapping[str, Number] = getattr(step, _FIELD[group])
    return table[name]


def _cell(value: Number) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    return str(value) if isinstance(value, int) else repr(float(value))


def trace_csv(cx: Counterexample) -> str:
    """One row per step: step, state, each input, signal and definition, the transition and the next state,
    each variable and output after the step, and whether the step is in a lasso's loop; params as columns."""
    groups = _groups(cx) if cx.steps else []
    columns = [f"{g}.{n}" for g, names in groups[:3] for n in names] + ["transition", "next"]
    columns += [f"{g}.{n}" for g, names in groups[3:] for n in names]
    columns += [f"param.{p}" for p in cx.params] + ["loop"]
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(["step", "state", *columns])
    for k, step in enumerate(cx.steps):
        before = [_cell(_value(step, g, n)) for g, names in groups[:3] for n in names]
        after = [_cell(_value(step, g, n)) for g, names in groups[3:] for n in names]
        fired = [step.outcome.transition or "", step.outcome.next or ""]
        params = [_cell(v) for v in cx.params.values()]
        looped = "1" if cx.loop_start is not None and k >= cx.loop_start else "0"
        writer.writerow([str(k + 1), step.state, *before, *fired, *after, *params, looped])
    return out.getvalue()


def _codes() -> Iterator[str]:
    n = 0
    while True:
        code, k = "", n
        while True:
            code += _CODES[k % len(_CODES)]
            k //= len(_CODES)
            if k == 0:
                break
        yield code
        n += 1


def timescale(step_s: Fraction | None) -> tuple[str, int]:
    """The VCD timescale and the step's length in it: the coarsest unit in which the step is a whole number."""
    if step_s is None or step_s <= 0:
        return "1 s", 1
    for unit, per_second in _UNITS:
        ticks = step_s * per_second
        if ticks.denominator == 1:
            return f"1 {unit}", int(ticks)
    return "1 ns", max(round(step_s * 10**9), 1)


def _kind(values: Sequence[Number]) -> str:
    if all(isinstance(v, bool) for v in values):
        return "wire"
    return "real" if any(isinstance(v, float) for v in values) else "integer"


def _change(kind: str, value: Number, code: str) -> str:
    if kind == "wire":
        return f"{int(bool(value))}{code}"
    if kind == "real":
        return f"r{float(value)!r} {code}"
    return f"b{int(value):b} {code}" if int(value) >= 0 else f"b{int(value) & (2**64 - 1):b} {code}"


class _Signals:
    """The VCD variables of a trace: (scope, name, kind, code) and each one's value at a step."""

    def __init__(self, m: Machine, cx: Counterexample) -> None:
        codes = _codes()
        self.vars: list[tuple[str, str, str, str]] = [("state", s, "wire", next(codes)) for s in m.states]
        self.vars += [("fired", t.id, "wire", next(codes)) for t in m.transitions]
        self.columns: list[tuple[str, str]] = []
        for group, names in _groups(cx):
            for name in names:
                kind = _kind([_value(s, group, name) for s in cx.steps])
                self.vars.append((group, name, kind, next(codes)))
                self.columns.append((group, name))
        self.vars.append(("", "loop", "wire", next(codes)))

    def values(self, cx: Counterexample, k: int) -> list[Number]:
        step = cx.steps[min(k, len(cx.steps) - 1)]
        state = step.state if k < len(cx.steps) else step.outcome.next
        fired = step.outcome.transition if k < len(cx.steps) else None
        row: list[Number] = [v[1] == state for v in self.vars if v[0] == "state"]
        row += [v[1] == fired for v in self.vars if v[0] == "fired"]
        row += [_value(step, g, n) for g, n in self.columns]
        row.append(cx.loop_start is not None and k >= cx.loop_start)
        return row


def trace_vcd(m: Machine, cx: Counterexample, title: str, version: str) -> str:
    """The trace as a value change dump: a header, then at each step's time the values that changed."""
    scale, ticks = timescale(m.step_s)
    signals = _Signals(m, cx)
    lines = [
        f"$comment {_vcd_text(title)} $end",
        f"$version mlca-verify {version} $end",
        f"$timescale {scale} $end",
        f"$scope module {_vcd_name(m.name)} $end",
    ]
    scope = None
    for group, name, kind, code in signals.vars:
        if group != scope:
            if scope:
                lines.append("$upscope $end")
            if group:
                lines.append(f"$scope module {group} $end")
            scope = group
        width = 1 if kind == "wire" else 64
        lines.append(f"$var {kind} {width} {code} {_vcd_name(name)} $end")
    lines += ["$upscope $end", "$enddefinitions $end"]
    last: list[Number] | None = None
    for k in range(len(cx.steps) + 1):
        row = signals.values(cx, k)
        changes = [
            _change(v[2], value, v[3])
            for j, (v, value) in enumerate(zip(signals.vars, row, strict=True))
            if last is None or last[j] != value or type(last[j]) is not type(value)
        ]
        if changes:
            lines.append(f"#{k * ticks}")
            lines += ["$dumpvars", *changes, "$end"] if last is None else changes
        last = row
    lines.append(f"#{(len(cx.steps) + 1) * ticks}")
    return "\n".join(lines) + "\n"


def _vcd_name(name: str) -> str:
    """A VCD identifier: no whitespace, no `$` (spec names are identifiers already; this is a second fence)."""
    return NAME.sub("_", name) or "_"


def _vcd_text(text: str) -> str:
    """Free text in a $comment: one line, and no `$end` inside it."""
    return " ".join(text.split()).replace("$", "S")
