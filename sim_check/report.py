"""`mlca-sim report`: the paper's figures redrawn from a results database, each bar with its 95% confidence
interval and the paper's value beside it, and report.md: paper value against measured value per figure, a verdict
per claim of the paper with the test behind it, the mechanism behind MLCA's numbers and the cost the paper left
out (travel time and speed of the AVs and of the other traffic).

Reading the database is `load`, through its API (sim_check.db.ResultsDB); the numbers are pure functions of what
it returns; drawing is matplotlib (Agg), with fixed metadata so that the same database gives byte-identical files."""

from __future__ import annotations

import io
import math
from collections import defaultdict
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import jinja2

from mlca_verify.escape import one_line
from mlca_verify.files import write_atomic
from sim_check import loop_report, rss
from sim_check.controllers import SETUPS
from sim_check.db import LoopRows, MechanismTotals, ResultsDB, RunTotals
from sim_check.loop_report import label, share
from sim_check.paper_results import (
    CLAIMS,
    COLLISION_CITE,
    COLLISION_ORDER,
    LANE_FIGURES,
    MARKS,
    PAPER_COLLISIONS,
    V2V_SUBJECT,
    Claim,
    LaneFigure,
)
from sim_check.run_results import STATES
from sim_check.stats import ClaimVerdict, extreme_verdict, mean_ci, reduction_verdict

Key = tuple[str, int]  # controller, AVs


@dataclass
class Group:
    """The finished runs of one (controller, AVs): one value per run (sums over the run's AVs for counts, means
    over its AVs for times and speeds)."""

    seeds: list[int] = field(default_factory=list)
    lc: dict[int, list[float]] = field(default_factory=lambda: {km: [] for km in MARKS})
    collisions: list[float] = field(default_factory=list)
    mingap: list[float] = field(default_factory=list)
    travel_s: list[float] = field(default_factory=list)
    speed_ms: list[float] = field(default_factory=list)
    bg_speed_ms: list[float] = field(default_factory=list)
    failed: int = 0
    violations: int = 0
    # per AV (mechanism, machines and "without" only)
    needs: int = 0
    moved: int = 0
    open: int = 0
    deferred: int = 0
    need_s: float = 0.0
    deferred_s: float = 0.0
    state_s: dict[str, float] = field(default_factory=lambda: dict.fromkeys(STATES, 0.0))
    av_count: int = 0


@dataclass
class Data:
    db: Path
    groups: dict[Key, Group]
    loop: LoopRows = field(default_factory=LoopRows)

    def values(self, controller: str, avs: int, metric: str, km: int = 20) -> list[float]:
        g = self.groups.get((controller, avs))
        if g is None:
            return []
        return g.lc[km] if metric == "lc" else g.collisions

    def pooled(self, controller: str, metric: str) -> list[float]:
        return [v for avs in (1, 3) for v in self.values(controller, avs, metric)]

    def present(self) -> list[str]:
        """The controllers of the paper's collision figure (and ours) that have runs, in its order."""
        return [c for c in COLLISION_ORDER if any((c, a) in self.groups for a in (1, 3))]

    def ordered(self) -> Iterator[tuple[str, int, Group]]:
        """(controller, AVs, group) in the collision figure's order, 1 AV before 3."""
        for controller in self.present():
            for avs in (1, 3):
                if (controller, avs) in self.groups:
                    yield controller, avs, self.groups[(controller, avs)]


def load(results: ResultsDB) -> Data:
    """The groups of a results database, from one snapshot of its rows."""
    rows = results.report_rows()
    groups: dict[Key, Group] = defaultdict(Group)
    for status in rows.statuses:
        g = groups[(status.controller, status.avs)]
        g.failed += status.status != "done"
        g.violations += status.monitor_violations or 0
    for run in rows.finished:
        _add_run(groups[(run.controller, run.avs)], run)
    for mechanism in rows.mechanism:
        _add_mechanism(groups[(mechanism.controller, mechanism.avs)], mechanism)
    return Data(results.path, dict(groups), rows.loop)


def _add_run(g: Group, run: RunTotals) -> None:
    g.seeds.append(run.seed)
    for km, value in zip(MARKS, run.lane_changes, strict=True):
        g.lc[km].append(float(value))
    g.collisions.append(float(run.collisions))
    g.mingap.append(float(run.mingap_contacts or 0))
    for target, mean in (
        (g.travel_s, run.travel_time_s),
        (g.speed_ms, run.mean_speed_ms),
        (g.bg_speed_ms, run.bg_mean_speed_ms),
    ):
        if mean is not None:
            target.append(float(mean))


def _add_mechanism(g: Group, m: MechanismTotals) -> None:
    g.av_count, g.needs, g.moved = m.av_count, int(m.needs), int(m.moved)
    g.open, g.deferred = int(m.open), int(m.deferred)
    g.need_s, g.deferred_s = float(m.need_s), float(m.deferred_s)
    g.state_s = {s: float(v or 0.0) for s, v in zip(STATES, m.state_s, strict=True)}


Triple = tuple[float, float, float]


def _scaled(m: Triple, factor: float) -> Triple:
    return m[0] * factor, m[1] * factor, m[2] * factor


def _fmt(m: Triple, digits: int = 2) -> str:
    mean, lo, hi = m
    return "-" if math.isnan(mean) else f"{mean:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


# ---------------------------------------------------------------------------------------------------- figures
def pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "mlca-verify"
    import matplotlib.pyplot as plt

    return plt


def save_figure(fig: Any, out: Path, stem: str) -> list[Path]:
    png, svg = io.BytesIO(), io.BytesIO()
    fig.savefig(png, format="png", dpi=110, metadata={"Software": None})
    fig.savefig(svg, format="svg", metadata={"Date": None, "Creator": None})
    paths = [out / f"{stem}.png", out / f"{stem}.svg"]
    for path, drawn in zip(paths, (png, svg), strict=True):
        write_atomic(path, drawn.getvalue())
    return paths


COLORS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860")


def shown(data: Data, fig_spec: LaneFigure) -> tuple[str, ...]:
    """The controllers a lane-change figure shows: the paper's, and those beside them that have runs."""
    extra = tuple(c for c in fig_spec.extra if any((c, avs) in data.groups for avs in (1, 3)))
    return (*fig_spec.series, *extra)


def lane_figure(data: Data, fig_spec: LaneFigure, out: Path) -> list[Path]:
    plt = pyplot()
    series = [(c, avs) for avs in (1, 3) for c in shown(data, fig_spec)]
    fig, ax = plt.subplots(figsize=(12.5, 4.8))
    width = 0.8 / (len(series) * 2)
    for k, (controller, avs) in enumerate(series):
        xs = [i + (2 * k - len(series)) * width + width / 2 for i in range(len(MARKS))]
        stats = [mean_ci(data.values(controller, avs, "lc", km)) for km in MARKS]
        means = [s[0] for s in stats]
        err = [[s[0] - s[1] for s in stats], [s[2] - s[0] for s in stats]]
        name = f"{label(controller)} ({avs} AV{'s' if avs > 1 else ''})"
        ax.bar(xs, means, width, color=COLORS[k % len(COLORS)], label=f"{name}, measured", yerr=err, capsize=2)
        paper = fig_spec.paper.get((controller, avs))
        if paper:
            ax.bar(
                [x + width for x in xs],
                paper,
                width,
                facecolor="none",
                edgecolor=COLORS[k % len(COLORS)],
                hatch="///",
                label=f"{name}, paper",
            )
    ax.set_xticks(range(len(MARKS)), [f"{km} km" for km in MARKS])
    ax.set_xlabel("cumulative distance")
    ax.set_ylabel("lane changes per run (sum over the AVs)")
    ax.set_title(f"{fig_spec.title} (paper: {fig_spec.cite}); bars: mean of the runs, 95% CI")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    paths = save_figure(fig, out, fig_spec.key)
    plt.close(fig)
    return paths


def _av_bars(
    ax: Any, data: Data, controllers: list[str], attr: str, *, scale: float, width: float, shift: float
) -> None:
    """One bar per controller for 1 AV and one for 3 AVs: the mean of `attr` times `scale`, with its 95% CI."""
    for k, avs in enumerate((1, 3)):
        stats = [
            _scaled(mean_ci(getattr(data.groups[(c, avs)], attr)), scale)
            if (c, avs) in data.groups
            else (0.0, 0.0, 0.0)
            for c in controllers
        ]
        xs = [i + (k + shift) * width for i in range(len(controllers))]
        ax.bar(
            xs,
            [s[0] for s in stats],
            width,
            color=COLORS[k],
            label=f"{avs} AV{'s' if avs > 1 else ''}",
            yerr=[[s[0] - s[1] for s in stats], [s[2] - s[0] for s in stats]],
            capsize=2,
        )


def _finish(ax: Any, controllers: list[str], ylabel: str, title: str) -> None:
    ax.set_xticks(range(len(controllers)), [label(c) for c in controllers], rotation=30, fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)


def _close(fig: Any, out: Path, stem: str, title: str) -> list[Path]:
    fig.suptitle(title)
    fig.tight_layout()
    paths = save_figure(fig, out, stem)
    pyplot().close(fig)
    return paths


def collision_figure(data: Data, out: Path) -> list[Path]:
    plt = pyplot()
    controllers = data.present()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), sharey=False)
    for ax, attr, title in (
        (axes[0], "collisions", "physical contact (mingap-factor 0)"),
        (axes[1], "mingap", "closer than minGap (SUMO's default criterion)"),
    ):
        width = 0.26
        _av_bars(ax, data, controllers, attr, scale=100.0, width=width, shift=-1.0)
        if attr == "collisions":
            xs = [i + width for i, c in enumerate(controllers) if c in PAPER_COLLISIONS]
            ax.bar(
                xs,
                [PAPER_COLLISIONS[c] for c in controllers if c in PAPER_COLLISIONS],
                width,
                facecolor="none",
                edgecolor="black",
                hatch="///",
                label=f"paper ({COLLISION_CITE})",
            )
        _finish(ax, controllers, "AV collisions per 100 runs", title)
    return _close(fig, out, "fig5_collisions", "Collisions involving an AV per 100 runs (20 km); 95% CI")


def cost_figure(data: Data, controllers: list[str], out: Path) -> list[Path]:
    plt = pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.38
    for ax, attr, unit, title in (
        (axes[0], "travel_s", "s", "AV travel time"),
        (axes[1], "bg_speed_ms", "km/h", "mean speed of the other traffic"),
    ):
        scale = 3.6 if unit == "km/h" else 1.0
        _av_bars(ax, data, controllers, attr, scale=scale, width=width, shift=-0.5)
        values = [
            s for c in controllers for a in (1, 3) if (c, a) in data.groups for s in getattr(data.groups[(c, a)], attr)
        ]
        if values:
            low, high = min(values) * scale, max(values) * scale
            ax.set_ylim(low - 0.1 * (high - low + 1), high + 0.1 * (high - low + 1))
        _finish(ax, controllers, unit, title)
    return _close(fig, out, "fig6_cost", "The cost the paper left out (its Sec. V): mean of the runs, 95% CI")


# ---------------------------------------------------------------------------------------------------- report.md
def claim_rows(data: Data, claim: Claim) -> list[tuple[str, ClaimVerdict]]:
    """(scope, verdict) per evaluation of one claim."""
    if claim.kind == "reduction":
        if claim.metric == "collisions":
            subject, baseline = data.pooled(claim.subject, "collisions"), data.pooled(claim.baseline, "collisions")
            return [("1 and 3 AVs pooled", reduction_verdict(subject, baseline, claim.claimed))]
        return [
            (
                f"{avs} AV{'s' if avs > 1 else ''}, 20 km",
                reduction_verdict(
                    data.values(claim.subject, avs, "lc"), data.values(claim.baseline, avs, "lc"), claim.claimed
                ),
            )
            for avs in claim.avs
        ] + _v2v_rows(data, claim)
    groups = {c: data.pooled(c, claim.metric) for c in COLLISION_ORDER if data.pooled(c, claim.metric)}
    return [("1 and 3 AVs pooled", extreme_verdict(claim.subject, groups, lowest=claim.kind == "lowest"))]


def _v2v_rows(data: Data, claim: Claim) -> list[tuple[str, ClaimVerdict]]:
    """A lane-change claim for three AVs judged on MLCA with V2V (V2V_SUBJECT), where the runs hold it."""
    if 3 not in claim.avs or not data.values(V2V_SUBJECT, 3, "lc"):
        return []
    subject, baseline = data.values(V2V_SUBJECT, 3, "lc"), data.values(claim.baseline, 3, "lc")
    return [(f"3 AVs, 20 km, with V2V (`{V2V_SUBJECT}`)", reduction_verdict(subject, baseline, claim.claimed))]


TEMPLATE_DIR = Path(__file__).resolve().parent / "templates"  # shipped as package data
TEMPLATE = "report.md.j2"
Row = tuple[str, ...]  # the cells of one table row, formatted


def cell(text: str) -> str:
    """Text from a results database for one Markdown table cell: one line, its backslashes kept literal, its '|'
    unable to end the cell, and no HTML, code span or link (plain names and numbers pass unchanged)."""
    text = text.replace("\\", "\\\\").replace("|", "\\|")
    for char in "<>`&":
        text = text.replace(char, "\\" + char)
    return one_line(text.replace("](", "]\\("))


def _environment() -> jinja2.Environment:
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(TEMPLATE_DIR)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        trim_blocks=True,
        lstrip_blocks=True,
        autoescape=False,
    )
    env.filters.update(cell=cell, line=one_line)
    return env


def _claims(data: Data) -> list[Row]:
    """key, text, cite, scope, verdict, measured, test per evaluation of each claim."""
    return [
        (claim.key, claim.text, claim.cite, scope, v.verdict, v.measured, v.test)
        for claim in CLAIMS
        for scope, v in claim_rows(data, claim)
    ]


def _lane_rows(data: Data, fig_spec: LaneFigure) -> list[Row]:
    """controller, AVs, km, paper, measured mean [95% CI], runs."""
    rows: list[Row] = []
    for avs in (1, 3):
        for controller in shown(data, fig_spec):
            paper = fig_spec.paper.get((controller, avs))
            for i, km in enumerate(MARKS):
                values = data.values(controller, avs, "lc", km)
                cells = (str(avs), str(km), str(paper[i]) if paper else "-", _fmt(mean_ci(values)), str(len(values)))
                rows.append((label(controller), *cells))
    return rows


def _collision_rows(data: Data) -> list[Row]:
    """controller, AVs, paper (per 100 runs), physical contact and closer than minGap per 100 runs, runs."""
    rows: list[Row] = []
    for controller, avs, g in data.ordered():
        contact = _fmt(_scaled(mean_ci(g.collisions), 100.0), 1)
        mingap = _fmt(_scaled(mean_ci(g.mingap), 100.0), 1)
        paper = str(PAPER_COLLISIONS.get(controller, "-"))
        rows.append((label(controller), str(avs), paper, contact, mingap, str(len(g.seeds))))
    return rows


def _mechanism_rows(data: Data) -> list[dict[str, object]]:
    """Per (controller, AVs) with AVs on record: counts, shares of the episodes, and seconds per AV."""
    rows: list[dict[str, object]] = []
    for (controller, avs), g in sorted(data.groups.items()):
        if not g.av_count:
            continue
        n = g.av_count
        machine = controller in SETUPS and SETUPS[controller].kind == "fsm"  # a name this version does not know
        rows.append(
            {
                "controller": label(controller),
                "avs": avs,
                "av_runs": n,
                "episodes": g.needs,
                "moved": g.moved,
                "moved_share": share(g.moved, g.needs),
                "deferred": g.deferred,
                "deferred_share": share(g.deferred, g.needs),
                "never_resolved": g.open,
                "never_resolved_share": share(g.open, g.needs),
                "need_s": f"{g.need_s / n:.1f}",
                "deferred_s": f"{g.deferred_s / n:.1f}",
                "state_s": [f"{g.state_s[s] / n:.1f}" if machine else "-" for s in STATES],
            }
        )
    return rows


def _state_seconds(data: Data) -> dict[str, dict[str, float]]:
    """The seconds the AVs of each controller spent in each state of its machine, over all its runs (the
    mechanism's sums, one and three AVs together)."""
    seconds: dict[str, dict[str, float]] = defaultdict(lambda: dict.fromkeys(STATES, 0.0))
    for (controller, _avs), g in data.groups.items():
        if g.av_count:
            for state, s in g.state_s.items():
                seconds[controller][state] += s
    return seconds


def _cost_rows(data: Data) -> list[Row]:
    """controller, AVs, AV travel time s, AV and other traffic mean speed km/h (means with 95% CIs)."""
    rows: list[Row] = []
    for controller, avs, g in data.ordered():
        travel = _fmt(mean_ci(g.travel_s), 1)
        speed = _fmt(_scaled(mean_ci(g.speed_ms), 3.6), 2)
        other = _fmt(_scaled(mean_ci(g.bg_speed_ms), 3.6), 2)
        rows.append((label(controller), str(avs), travel, speed, other))
    return rows


def markdown(data: Data, figures: list[Path]) -> str:
    """report.md: the numbers formatted here, the words and the layout in templates/report.md.j2."""
    values = {
        "db_name": data.db.name,
        "runs": sum(len(g.seeds) for g in data.groups.values()),
        "configurations": len(data.groups),
        "failed": sum(g.failed for g in data.groups.values()),
        "violations": sum(g.violations for g in data.groups.values()),
        "stands_for": {controller: setup.stands_for for controller, setup in SETUPS.items()},
        "claims": _claims(data),
        "lane_figures": [
            {"title": f.title, "cite": f.cite, "key": f.key, "rows": _lane_rows(data, f)} for f in LANE_FIGURES
        ],
        "collision_cite": COLLISION_CITE,
        "collisions": _collision_rows(data),
        "states": STATES,
        "mechanism": _mechanism_rows(data),
        "cost": _cost_rows(data),
        "coverage": loop_report.coverage(data.loop, _state_seconds(data)),
        "shadow": loop_report.shadow(data.loop),
        "wish_reasons": loop_report.wish_reasons(data.loop),
        "safety": loop_report.safety(data.loop),
        "rss": rss.spec_params(),
        "files": [p.name for p in figures],
    }
    return _environment().get_template(TEMPLATE).render(values)


def write_report(db: Path, out: Path) -> list[Path]:
    """Write the figures (PNG and SVG) and report.md into `out` from the results database `db`, which is read
    (and refused when it is not one) before anything is written; returns the files written."""
    with ResultsDB.open_for_reading(db) as results:
        data = load(results)
    out.mkdir(parents=True, exist_ok=True)
    figures: list[Path] = []
    for fig_spec in LANE_FIGURES:
        figures += lane_figure(data, fig_spec, out)
    figures += collision_figure(data, out)
    figures += cost_figure(data, data.present(), out)
    report = out / "report.md"
    write_atomic(report, markdown(data, figures))
    return [*figures, report]
