"""Text tables and JSON documents for check and diff results (pure: strings and dicts, no I/O)."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from mlca_verify.escape import terminal
from mlca_verify.json_types import Json, JsonObject
from mlca_verify.logic.equiv import EquivalenceResult, Region
from mlca_verify.logic.property_diff import PropertyChange
from mlca_verify.logic.results import Counterexample, Outcome, Result, Step
from mlca_verify.spec_diff import TransitionChange, VerdictChange
from mlca_verify.words import count

CHECK_SCHEMA = "mlca-verify.check/3"
CITE_WIDTH = 60
TRACE_CITE_WIDTH = 44


def table(headers: Sequence[str], rows: Sequence[Sequence[str]], indent: str = "") -> str:
    """A plain, aligned text table."""
    widths = [max(len(h), *(len(r[i]) for r in rows)) if rows else len(h) for i, h in enumerate(headers)]

    def line(cells: Sequence[str]) -> str:
        return (indent + "  ".join(c.ljust(w) for c, w in zip(cells, widths, strict=True))).rstrip()

    rule = indent + "  ".join("-" * w for w in widths)
    return "\n".join([line(headers), rule, *(line(r) for r in rows)])


def _clip(text: str, width: int) -> str:
    """Spec text cut to `width` for a terminal table: control characters shown as escapes, never sent."""
    text = terminal(text)
    return text if len(text) <= width else text[: width - 3] + "..."


def _fired_text(o: Outcome) -> str:
    who = f"{o.machine}: " if o.machine else ""
    if o.transition is None:
        return f"{who}(no transition)"
    cited = f" ({_clip(o.cite, TRACE_CITE_WIDTH)})" if o.cite else ""
    return f"{who}{o.transition}{cited}"


def _outcome_text(o: Outcome) -> str:
    return _fired_text(o) if o.transition is None else f"{_fired_text(o)} -> {o.next}"


def number_text(value: bool | int | float) -> str:
    if isinstance(value, bool):
        return "1" if value else "0"
    return str(value) if isinstance(value, int) else f"{value:.6g}"


def _data_columns(cx: Counterexample) -> list[str]:
    """Definitions as the step's guards saw them, then variables and outputs after the step."""
    first = cx.steps[0] if cx.steps else None
    if first is None:
        return []
    return [*first.definitions, *first.variables, *first.outputs]


FOLD_AT = 5  # steps alike in a row that a trace shows as their first, a line for the middle, and their last


def _alike(a: Step, b: Step) -> bool:
    """The same step but for its variables: state, inputs, signals, definitions, outputs and what fired."""
    return (a.state, a.inputs, a.signals, a.definitions, a.outputs, a.outcome, a.alternatives) == (
        b.state,
        b.inputs,
        b.signals,
        b.definitions,
        b.outputs,
        b.outcome,
        b.alternatives,
    )


def _deltas(a: Step, b: Step) -> dict[str, object]:
    return {k: b.variables[k] - a.variables[k] for k in a.variables if not isinstance(a.variables[k], bool)}


def folds(cx: Counterexample) -> list[tuple[int, int]]:
    """The runs of steps (first and last index) shown folded: at least FOLD_AT steps alike, whose variables keep
    their values or count by one constant amount a step, and no loop starting inside."""
    found: list[tuple[int, int]] = []
    start = 0
    steps = cx.steps
    for k in range(1, len(steps) + 1):
        same = (
            k < len(steps)
            and _alike(steps[k], steps[start])
            and cx.loop_start != k
            and all(v == steps[start].variables[n] for n, v in steps[k].variables.items() if isinstance(v, bool))
            and (k - start < 2 or _deltas(steps[k - 1], steps[k]) == _deltas(steps[start], steps[start + 1]))
        )
        if not same:
            if k - start >= FOLD_AT:
                found.append((start, k - 1))
            start = k
    return found


def _fold_line(cx: Counterexample, first: int, last: int) -> str:
    a, b = cx.steps[first + 1], cx.steps[last - 1]
    counting = [
        f"{n} counts {number_text(a.variables[n])} to {number_text(b.variables[n])}"
        for n in a.variables
        if a.variables[n] != b.variables[n]
    ]
    return f"steps {first + 2}-{last}: as step {first + 1}" + "".join(f"; {c}" for c in counting)


def _shown(cx: Counterexample) -> list[int | tuple[int, int]]:
    """Step indexes to show as rows, and in place of each fold's middle, its (first, last)."""
    middle = {k: (a, b) for a, b in folds(cx) for k in range(a + 1, b)}
    out: list[int | tuple[int, int]] = []
    for k in range(len(cx.steps)):
        if k not in middle:
            out.append(k)
        elif k == middle[k][0] + 1:
            out.append(middle[k])
    return out


def trace_text(cx: Counterexample, inputs: Sequence[str], indent: str = "    ") -> str:
    """A counterexample as a table of steps; inputs as 1/0; the loop of a lasso marked. A machine with data adds
    its params, a column per definition, variable (after the step) and output, and the signals below. A run of
    steps alike (see `folds`) shows its first and last step and one line for those between; the JSON report
    keeps every step."""
    if cx.point:
        return point_text(cx, indent)
    rows = []
    extra = _data_columns(cx)
    width = 3 + len(inputs) + len(extra)
    shown_steps = _shown(cx)  # the folds, found once for both tables
    for item in shown_steps:
        if isinstance(item, tuple):
            rows.append(["", "...", "", *[""] * (width - 3), _fold_line(cx, *item), ""])
            continue
        index, step = item, cx.steps[item]
        mark = "loop->" if cx.loop_start == index else ""
        values = list(bits(step.inputs, inputs))
        stuck = step.outcome.transition is None and not step.alternatives and step.outcome.next is None
        nxt = "stuck" if stuck else (step.outcome.next or "-")
        shown = {**step.definitions, **step.variables, **step.outputs}
        data = [number_text(shown[c]) if c in shown else "" for c in extra]
        rows.append([mark, str(index + 1), step.state, *values, *data, _fired_text(step.outcome), nxt])
        blanks = [""] * (len(inputs) + len(extra))
        rows.extend(["", "", "", *blanks, "  or " + _outcome_text(alt), ""] for alt in step.alternatives)
    headers = ["", "step", "state", *inputs, *extra, "transition", "next"]
    text = table(headers, rows, indent)
    if cx.params:
        text = f"{indent}params: " + ", ".join(f"{k} = {number_text(v)}" for k, v in cx.params.items()) + "\n" + text
    if cx.steps and cx.steps[0].signals:
        names = list(cx.steps[0].signals)
        signal_rows = [
            [f"{item[0] + 2}-{item[1]}", *(["as above"] + [""] * (len(names) - 1))]
            if isinstance(item, tuple)
            else [str(item + 1), *(number_text(cx.steps[item].signals[n]) for n in names)]
            for item in shown_steps
        ]
        text += f"\n{indent}signals:\n" + table(["step", *names], signal_rows, indent)
    if cx.loop_start is not None:
        text += f"\n{indent}(steps {cx.loop_start + 1}..{len(cx.steps)} repeat forever)"
    return text


def point_text(cx: Counterexample, indent: str = "    ") -> str:
    """A lemma's counterexample: the values of the signals, params and definitions at which it fails."""
    step = cx.steps[0]
    lines = []
    for label, values in (
        ("signals", step.signals),
        ("inputs", {k: int(v) for k, v in step.inputs.items()}),
        ("params", cx.params),
        ("definitions", step.definitions),
    ):
        if values:
            lines.append(f"{indent}{label}: " + ", ".join(f"{k} = {number_text(v)}" for k, v in values.items()))
    return "\n".join(lines)


def results_text(
    spec_path: str,
    machine: str,
    results: Sequence[Result],
    inputs: Sequence[str],
    assumptions: Sequence[str] = (),
    *,
    reals: str = "binary64",
    charts: Mapping[str, str] | None = None,
) -> str:
    """The table of `results`, what they assume, and each counterexample as a trace (followed by its chart in
    `charts`, by property: a network's message sequence)."""
    rows = []
    for r in results:
        status = ("ok" if r.ok else "UNEXPECTED") + (" (reals)" if r.caveat else "")
        rows.append([r.prop, r.kind, r.verdict, r.expected, status, _clip(r.cite, CITE_WIDTH)])
    parts = [
        f"{terminal(spec_path)} ({machine})",
        table(["property", "kind", "verdict", "expected", "", "cite"], rows, "  "),
    ]
    if assumptions:
        parts.append("  every verdict assumes of the environment, at every step:")
        parts += [f"    {_clip(a, 110)}" for a in assumptions]
    for r in results:
        if r.counterexample is not None and r.counterexample.steps:
            parts.append(f"\n  {r.prop} {r.verdict}: {r.detail}")
            parts.append(trace_text(r.counterexample, inputs))
            if charts and r.prop in charts:
                parts.append(f"\n    message sequence ('|-- id -->': a message on channel id):\n{charts[r.prop]}")
        elif r.verdict != "holds":
            parts.append(f"\n  {r.prop} {r.verdict}: {r.detail}")
    caveats = [r for r in results if r.caveat]
    if caveats:
        parts.append(f"\n  (reals): decided over the reals, not shown for the generated code's {reals}:")
        parts += [f"    {r.prop}: {terminal(_clip(r.caveat, 200))}" for r in caveats]
    return "\n".join(parts)


def summary_text(results: Sequence[Result]) -> str:
    bad = [r for r in results if not r.ok]
    counts = {v: sum(1 for r in results if r.verdict == v) for v in ("holds", "violated", "unknown")}
    line = f"{count(len(results), 'property', 'properties')}: {counts['holds']} hold, "
    line += f"{counts['violated']} violated, {counts['unknown']} unknown"
    reals = sum(1 for r in results if r.caveat)
    if reals:
        line += f" ({reals} over the reals only)"
    if bad:
        return line + f"; {len(bad)} not as expected: " + ", ".join(r.prop for r in bad)
    return line + "; all as expected"


@dataclass(frozen=True)
class Checked:
    """One spec's part of the `check --json` document: its results, and for a network what it is
    (`network`) and each counterexample's messages (`messages`, by property)."""

    path: str
    sha256: str
    machine: str
    results: Sequence[Result]
    network: JsonObject | None = None
    messages: Mapping[str, list[JsonObject]] = field(default_factory=dict)

    def to_json(self) -> JsonObject:
        results: list[Json] = []
        for r in self.results:
            data = r.to_json()
            cx = data.get("counterexample")
            if isinstance(cx, dict) and r.prop in self.messages:
                cx["messages"] = list(self.messages[r.prop])
            results.append(data)
        entry: JsonObject = {"path": self.path, "sha256": self.sha256, "machine": self.machine, "results": results}
        if self.network is not None:
            entry["network"] = self.network
        return entry


def check_document(specs: Sequence[Checked]) -> JsonObject:
    """The `mlca-verify check --json` document (schema CHECK_SCHEMA)."""
    return {"schema": CHECK_SCHEMA, "specs": [s.to_json() for s in specs]}


def cube_text(cube: dict[str, bool]) -> str:
    if not cube:
        return "any inputs"
    return " and ".join(name if value else f"not {name}" for name, value in cube.items())


def _short_outcome(o: Outcome) -> str:
    return "no transition" if o.transition is None else f"{o.transition} -> {o.next}"


def bits(inputs: dict[str, bool], names: Sequence[str]) -> str:
    return "".join("1" if inputs.get(n) else "0" for n in names)


def regions_text(regions: Sequence[Region], left_name: str, right_name: str, names: Sequence[str]) -> str:
    rows = []
    for r in regions:
        left = "; ".join(_short_outcome(o) for o in r.left)
        right = "; ".join(_short_outcome(o) for o in r.right)
        rows.append([r.state, cube_text(r.cube), left, right, " ".join(bits(w, names) for w in r.witness)])
    witness = f"witness ({''.join(names)} per step)"
    return table(["state", "when", left_name, right_name, witness], rows, "  ")


def regression_text(changes: Sequence[VerdictChange], transitions: Sequence[TransitionChange] | None) -> str:
    """The verdicts that changed, and the transitions (None: a network, which has none of its own)."""
    parts = []
    if changes:
        rows = [[c.prop, c.old or "-", c.new or "-", c.label] for c in changes]
        parts += ["verdicts that changed:", table(["property", "old", "new", ""], rows, "  "), ""]
    else:
        parts += ["verdicts: none changed", ""]
    if transitions:
        rows = [[t.id, t.change, t.old or "-", t.new or "-"] for t in transitions]
        parts += ["transitions (matched by id):", table(["id", "change", "old", "new"], rows, "  "), ""]
    elif transitions is not None:
        parts += ["transitions: none added, removed or changed", ""]
    return "\n".join(parts)


def meaning_text(changes: Sequence[PropertyChange]) -> str:
    """Declared properties whose text changed, and how their meaning did (by z3)."""
    if not changes:
        return "properties: none reworded\n"
    labels = {
        "weakened": "WEAKENED (REGRESSION)",
        "incomparable": "CHANGED, neither implies the other (REGRESSION)",
        "strengthened": "strengthened",
        "equivalent": "equivalent (reworded)",
        "unknown": "changed (z3 could not decide how)",
    }
    lines = ["properties reworded (compared by meaning), each expression whole:"]
    for c in changes:
        lines += [f"  {c.prop}: {labels[c.relation]}", f"    old: {c.old}", f"    new: {c.new}"]
    return "\n".join([*lines, ""])


def diff_text(left: str, right: str, comparison: EquivalenceResult, inputs: Sequence[str]) -> str:
    if comparison.verdict == "holds":
        return f"{left} and {right} are equivalent: {comparison.detail}"
    if comparison.verdict == "unknown":
        return f"{left} vs {right}: unknown (a solver query timed out)"
    parts = [f"{left} and {right} differ: {comparison.detail}"]
    if comparison.regions:
        parts += ["", "where they differ (states both reach, and the inputs on which they do different things):"]
        parts.append(regions_text(comparison.regions, left, right, inputs))
    if comparison.counterexample is not None and comparison.counterexample.steps:
        parts += ["", "shortest distinguishing sequence:", trace_text(comparison.counterexample, inputs)]
    return "\n".join(parts)
