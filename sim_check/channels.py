"""The same controllers under several V2V channels, side by side (`mlca-sim channels`): V2V off, a perfect radio,
a lossy and late one, or any the user names. A channel is a scenario's `[v2v]` section, and the runs of one
channel are a results database of a sweep on that scenario; each database comes with a label.

Per channel, controller and AV count: lane changes by 20 km, collisions and SSM conflicts (summed over a run's
AVs), the messages the radio sent, lost, delivered late and delivered twice, and the times two AVs began moving
into one lane within the radius at one step, each a mean per run with its 95% bootstrap interval where it varies.
`rows` is pure; `markdown` and `figure` present them."""

from __future__ import annotations

import re
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mlca_verify.errors import UsageError
from sim_check.radio import V2V_COUNTS
from sim_check.stats import mean_ci

MAX_CHANNELS = 8
LABEL = re.compile(r"[A-Za-z0-9][A-Za-z0-9 _.+-]{0,39}")
Triple = tuple[float, float, float]


@dataclass(frozen=True)
class Channel:
    """One labelled database's finished runs, as `ResultsDB.v2v_runs` gives them."""

    label: str
    runs: list[tuple[Any, ...]]


@dataclass(frozen=True)
class Row:
    """One channel's runs of one controller with `avs` AVs: means per run, each (mean, low, high)."""

    channel: str
    controller: str
    avs: int
    runs: int
    lane_changes: Triple
    collisions: Triple
    ssm_conflicts: Triple
    messages: dict[str, Triple]  # by V2V_COUNTS name


def labelled(text: str) -> tuple[str, Path]:
    """`LABEL=FILE` of the command line: a short label (letters, digits, ` _.+-`) and a database file."""
    label, eq, path = text.partition("=")
    if not eq or not path:
        raise UsageError(f"error: --db wants LABEL=FILE (say off=off.sqlite), got {text[:60]!r}")
    if not LABEL.fullmatch(label):
        raise UsageError(f"error: a channel's label is 1 to 40 letters, digits, spaces or _.+- , got {label[:60]!r}")
    return label, Path(path)


def check_labels(labels: Sequence[str]) -> None:
    if len(labels) > MAX_CHANNELS:
        raise UsageError(f"error: at most {MAX_CHANNELS} channels (--db), got {len(labels)}")
    seen = [label for i, label in enumerate(labels) if label in labels[:i]]
    if seen:
        raise UsageError(f"error: the channel label {seen[0]!r} is given twice")


def rows(channels: Sequence[Channel]) -> list[Row]:
    """A row per (controller, AVs) and channel, ordered by controller, then AVs, then the channels' order."""
    grouped: dict[tuple[str, int], dict[str, list[tuple[Any, ...]]]] = defaultdict(lambda: defaultdict(list))
    for channel in channels:
        for run in channel.runs:
            grouped[(run[0], run[1])][channel.label].append(run)
    out: list[Row] = []
    for (controller, avs), by_label in sorted(grouped.items()):
        for channel in channels:
            runs = by_label.get(channel.label)
            if runs:
                out.append(_row(channel.label, controller, avs, runs))
    return out


def _row(label: str, controller: str, avs: int, runs: list[tuple[Any, ...]]) -> Row:
    def column(at: int) -> Triple:
        return mean_ci([float(run[at] or 0) for run in runs])

    messages = {name: column(6 + k) for k, name in enumerate(V2V_COUNTS)}
    return Row(label, controller, avs, len(runs), column(3), column(4), column(5), messages)


HEADER = (
    "channel",
    "controller",
    "AVs",
    "runs",
    "lane changes by 20 km [95% CI]",
    "collisions",
    "SSM conflicts",
    "messages sent",
    "lost",
    "late",
    "read twice",
    "two AVs into one lane",
)


def cells(row: Row) -> tuple[str, ...]:
    m = row.messages
    return (
        row.channel,
        row.controller,
        str(row.avs),
        str(row.runs),
        _ci(row.lane_changes),
        f"{row.collisions[0]:.2f}",
        f"{row.ssm_conflicts[0]:.2f}",
        *(f"{m[name][0]:.1f}" for name in ("sent", "lost", "late", "duplicated")),
        f"{m['conflicts'][0]:.2f}",
    )


def _ci(m: Triple) -> str:
    mean, lo, hi = m
    return f"{mean:.2f}" if lo == hi else f"{mean:.2f} [{lo:.2f}, {hi:.2f}]"


def markdown(table: Sequence[Row], sources: Sequence[tuple[str, str]] = ()) -> str:
    """The comparison as a Markdown page: where each channel's runs are from (label, database file name), the
    figure, and the table, every number a mean per run. Labels and names are the user's: escaped."""
    given = ", ".join(f"{_cell(label)} from `{_code(name)}`" for label, name in sources)
    head = [
        "# V2V channels side by side",
        "",
        f"The runs of each channel: {given}. Each number is a mean per run over the finished runs, summed over "
        "a run's AVs; lane changes with their 95% bootstrap interval. *Two AVs into one lane*: the times two AVs "
        "began moving into one lane near each other at one step.",
        "",
        "![V2V channels](channels.svg)",
        "",
    ]
    lines = [
        "| " + " | ".join(HEADER) + " |",
        "|" + "|".join("---" if k < 2 else "---:" for k in range(len(HEADER))) + "|",
    ]
    lines += ["| " + " | ".join(_cell(c) for c in cells(row)) + " |" for row in table]
    return "\n".join((head if sources else []) + lines) + "\n"


def _code(text: str) -> str:
    """Text for a code span: one line, no backtick."""
    return " ".join(text.replace("`", "'").split())


def _cell(text: str) -> str:
    return re.sub(r"([\\|<>`&*_\[\]])", r"\\\1", text)


def text(table: Sequence[Row]) -> str:
    """The comparison as aligned columns for a terminal."""
    body = [HEADER, *(cells(row) for row in table)]
    widths = [max(len(r[k]) for r in body) for k in range(len(HEADER))]
    return "\n".join("  ".join(c.ljust(w) for c, w in zip(r, widths, strict=True)).rstrip() for r in body) + "\n"


def _panels(table: Sequence[Row]) -> list[tuple[str, list[Triple]]]:
    return [
        ("lane changes by 20 km per run", [r.lane_changes for r in table]),
        ("SSM conflicts per run", [r.ssm_conflicts for r in table]),
        ("two AVs into one lane per run", [r.messages["conflicts"] for r in table]),
        ("messages lost per run", [r.messages["lost"] for r in table]),
    ]


def figure(table: Sequence[Row], out: Path) -> list[Path]:
    """channels.svg and .png: lane changes, SSM conflicts, two AVs into one lane and messages lost per run, each
    bar a controller with its AVs under one channel."""
    from sim_check.report import pyplot, save_figure

    plt = pyplot()
    groups = sorted({(r.controller, r.avs) for r in table})
    labels = list(dict.fromkeys(r.channel for r in table))
    fig, axes = plt.subplots(1, 4, figsize=(17, 4.2))
    width = 0.8 / max(len(labels), 1)
    for ax, (title, values) in zip(axes, _panels(table), strict=True):
        for k, label in enumerate(labels):
            at = {(r.controller, r.avs): v for r, v in zip(table, values, strict=True) if r.channel == label}
            xs = [i + (k - (len(labels) - 1) / 2) * width for i, g in enumerate(groups) if g in at]
            means = [at[g][0] for g in groups if g in at]
            errs = [[at[g][0] - at[g][1] for g in groups if g in at], [at[g][2] - at[g][0] for g in groups if g in at]]
            ax.bar(xs, means, width, yerr=errs, capsize=2, label=label)
        ax.set_xticks(range(len(groups)), [f"{c} ({a})" for c, a in groups], rotation=30, fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.legend(fontsize=8)
    fig.suptitle("V2V channels: mean per run, 95% CI (controller (AVs))")
    fig.tight_layout()
    paths = save_figure(fig, out, "channels")
    plt.close(fig)
    return paths
