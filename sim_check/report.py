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

from mlca_verify.files import write_atomic
from sim_check.controllers import SETUPS
from sim_check.db import MechanismTotals, ResultsDB, RunTotals
from sim_check.paper_results import (
    CLAIMS,
    COLLISION_CITE,
    COLLISION_ORDER,
    LANE_FIGURES,
    MARKS,
    PAPER_COLLISIONS,
    Claim,
    LaneFigure,
)
from sim_check.results import STATES
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
    return Data(results.path, dict(groups))


def _add_run(g: Group, run: RunTotals) -> None:
    g.seeds.append(run.seed)
    for km, value in zip(MARKS, run.lane_changes, strict=True):
        g.lc[km].append(float(value))
    g.collisions.append(float(run.collisions))
    g.mingap.append(float(run.mingap_contacts or 0))
    for target, mean in ((g.travel_s, run.travel_time_s), (g.speed_ms, run.mean_speed_ms),
                         (g.bg_speed_ms, run.bg_mean_speed_ms)):  # fmt: skip
        if mean is not None:
            target.append(float(mean))


def _add_mechanism(g: Group, m: MechanismTotals) -> None:
    g.av_count, g.needs, g.moved = m.av_count, int(m.needs), int(m.moved)
    g.open, g.deferred = int(m.open), int(m.deferred)
    g.need_s, g.deferred_s = float(m.need_s), float(m.deferred_s)
    g.state_s = {s: float(v or 0.0) for s, v in zip(STATES, m.state_s, strict=True)}


def label(controller: str) -> str:
    return SETUPS[controller].label if controller in SETUPS else controller


Triple = tuple[float, float, float]


def _scaled(m: Triple, factor: float) -> Triple:
    return m[0] * factor, m[1] * factor, m[2] * factor


def _fmt(m: Triple, digits: int = 2) -> str:
    mean, lo, hi = m
    return "-" if math.isnan(mean) else f"{mean:.{digits}f} [{lo:.{digits}f}, {hi:.{digits}f}]"


# ---------------------------------------------------------------------------------------------------- figures
def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    matplotlib.rcParams["svg.hashsalt"] = "mlca-verify"
    import matplotlib.pyplot as plt

    return plt


def _save(fig: Any, out: Path, stem: str) -> list[Path]:
    png, svg = io.BytesIO(), io.BytesIO()
    fig.savefig(png, format="png", dpi=110, metadata={"Software": None})
    fig.savefig(svg, format="svg", metadata={"Date": None, "Creator": None})
    paths = [out / f"{stem}.png", out / f"{stem}.svg"]
    for path, drawn in zip(paths, (png, svg), strict=True):
        write_atomic(path, drawn.getvalue())
    return paths


COLORS = ("#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860")


def lane_figure(data: Data, fig_spec: LaneFigure, out: Path) -> list[Path]:
    plt = _pyplot()
    series = [(c, avs) for avs in (1, 3) for c in (*fig_spec.series, *fig_spec.extra)]
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
            ax.bar([x + width for x in xs], paper, width, facecolor="none", edgecolor=COLORS[k % len(COLORS)],
                   hatch="///", label=f"{name}, paper")  # fmt: skip
    ax.set_xticks(range(len(MARKS)), [f"{km} km" for km in MARKS])
    ax.set_xlabel("cumulative distance")
    ax.set_ylabel("lane changes per run (sum over the AVs)")
    ax.set_title(f"{fig_spec.title} (paper: {fig_spec.cite}); bars: mean of the runs, 95% CI")
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    paths = _save(fig, out, fig_spec.key)
    plt.close(fig)
    return paths


def _av_bars(
    ax: Any, data: Data, controllers: list[str], attr: str, *, scale: float, width: float, shift: float
) -> None:
    """One bar per controller for 1 AV and one for 3 AVs: the mean of `attr` times `scale`, with its 95% CI."""
    for k, avs in enumerate((1, 3)):
        stats = [_scaled(mean_ci(getattr(data.groups[(c, avs)], attr)), scale) if (c, avs) in data.groups
                 else (0.0, 0.0, 0.0) for c in controllers]  # fmt: skip
        xs = [i + (k + shift) * width for i in range(len(controllers))]
        ax.bar(xs, [s[0] for s in stats], width, color=COLORS[k], label=f"{avs} AV{'s' if avs > 1 else ''}",
               yerr=[[s[0] - s[1] for s in stats], [s[2] - s[0] for s in stats]], capsize=2)  # fmt: skip


def _finish(ax: Any, controllers: list[str], ylabel: str, title: str) -> None:
    ax.set_xticks(range(len(controllers)), [label(c) for c in controllers], rotation=30, fontsize=8)
    ax.set_ylabel(ylabel)
    ax.set_title(title, fontsize=10)
    ax.legend(fontsize=8)


def _close(fig: Any, out: Path, stem: str, title: str) -> list[Path]:
    fig.suptitle(title)
    fig.tight_layout()
    paths = _save(fig, out, stem)
    _pyplot().close(fig)
    return paths


def collision_figure(data: Data, out: Path) -> list[Path]:
    plt = _pyplot()
    controllers = data.present()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), sharey=False)
    for ax, attr, title in ((axes[0], "collisions", "physical contact (mingap-factor 0)"),
                            (axes[1], "mingap", "closer than minGap (SUMO's default criterion)")):  # fmt: skip
        width = 0.26
        _av_bars(ax, data, controllers, attr, scale=100.0, width=width, shift=-1.0)
        if attr == "collisions":
            xs = [i + width for i, c in enumerate(controllers) if c in PAPER_COLLISIONS]
            ax.bar(xs, [PAPER_COLLISIONS[c] for c in controllers if c in PAPER_COLLISIONS], width, facecolor="none",
                   edgecolor="black", hatch="///", label=f"paper ({COLLISION_CITE})")  # fmt: skip
        _finish(ax, controllers, "AV collisions per 100 runs", title)
    return _close(fig, out, "fig5_collisions", "Collisions involving an AV per 100 runs (20 km); 95% CI")


def cost_figure(data: Data, controllers: list[str], out: Path) -> list[Path]:
    plt = _pyplot()
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.2))
    width = 0.38
    for ax, attr, unit, title in ((axes[0], "travel_s", "s", "AV travel time"),
                                  (axes[1], "bg_speed_ms", "km/h", "mean speed of the other traffic")):  # fmt: skip
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
            (f"{avs} AV{'s' if avs > 1 else ''}, 20 km",
             reduction_verdict(data.values(claim.subject, avs, "lc"), data.values(claim.baseline, avs, "lc"),
                               claim.claimed))
            for avs in claim.avs
        ]  # fmt: skip
    groups = {c: data.pooled(c, claim.metric) for c in COLLISION_ORDER if data.pooled(c, claim.metric)}
    return [("1 and 3 AVs pooled", extreme_verdict(claim.subject, groups, lowest=claim.kind == "lowest"))]


def _stand_ins() -> list[str]:
    lines = ["| paper's name | controller | what runs |", "|---|---|---|"]
    names = {"lc2013": "LC2013, LC2014", "sl2015": "LC2017, Continuous (sublane)", "continuous": "Continuous",
             "idm-lc": "IDM/LC", "mobil": "MOBIL", "without": "without algorithm", "mlca-c": "MLCA",
             "mlca_r-c": "(not in the paper) MLCA-R, the repair"}  # fmt: skip
    for controller, name in names.items():
        lines.append(f"| {name} | `{controller}` | {SETUPS[controller].stands_for} |")
    return lines


def markdown(data: Data, figures: list[Path]) -> str:
    keys = sorted(data.groups)
    runs = sum(len(g.seeds) for g in data.groups.values())
    failed = sum(g.failed for g in data.groups.values())
    violations = sum(g.violations for g in data.groups.values())
    out = [
        "# The paper's comparison, reproduced",
        "",
        f"From `{data.db.name}`: {runs} finished runs in {len(keys)} configurations (controller x AVs), "
        f"{failed} failed runs, {violations} monitor violations. Lane changes are counted per run and summed over "
        "the run's AVs; collisions are those involving an AV (SUMO's collision detection, junctions included). "
        "Intervals are 95% bootstrap intervals of the mean over runs.",
        "",
        "## Which model stands for which name of the paper",
        "",
        "SUMO 1.28 ships the lane-change models LC2013, SL2015 and DK2008; it has no model named LC2014, LC2017 or "
        "MOBIL.",
        "",
        *_stand_ins(),
        "",
        "## Claims",
        "",
        "Rule: a reduction claim is *reproduced* when the 95% interval of the measured reduction contains the "
        "claimed one and a one-sided Mann-Whitney U test finds MLCA lower (p < 0.05); *not comparable* when the "
        "baseline has no events, so no reduction is defined. A ranking claim is reproduced when the controller "
        "ranks first and no other is significantly better (one-sided Mann-Whitney, p < 0.05).",
        "",
        "| claim | where | scope | verdict | measured | test |",
        "|---|---|---|---|---|---|",
    ]
    for claim in CLAIMS:
        for scope, v in claim_rows(data, claim):
            out.append(f"| {claim.key}: {claim.text} | {claim.cite} | {scope} | **{v.verdict}** | {v.measured} | "
                       f"{v.test} |")  # fmt: skip
    for fig_spec in LANE_FIGURES:
        out += ["", f"## {fig_spec.title} ({fig_spec.cite})", "", f"![{fig_spec.title}]({fig_spec.key}.svg)", "",
                "| controller | AVs | km | paper | measured mean [95% CI] | runs |",
                "|---|---|---|---|---|---|"]  # fmt: skip
        for avs in (1, 3):
            for controller in (*fig_spec.series, *fig_spec.extra):
                paper = fig_spec.paper.get((controller, avs))
                for i, km in enumerate(MARKS):
                    values = data.values(controller, avs, "lc", km)
                    out.append(f"| {label(controller)} | {avs} | {km} | {paper[i] if paper else '-'} | "
                               f"{_fmt(mean_ci(values))} | {len(values)} |")  # fmt: skip
    out += ["", f"## Collisions ({COLLISION_CITE})", "", "![collisions](fig5_collisions.svg)", "",
            "| controller | AVs | paper (per 100 runs) | physical contact per 100 runs [95% CI] | "
            "closer than minGap per 100 runs [95% CI] | runs |", "|---|---|---|---|---|---|"]  # fmt: skip
    for controller, avs, g in data.ordered():
        coll = _scaled(mean_ci(g.collisions), 100.0)
        mingap = _scaled(mean_ci(g.mingap), 100.0)
        out.append(f"| {label(controller)} | {avs} | {PAPER_COLLISIONS.get(controller, '-')} | "
                   f"{_fmt(coll, 1)} | {_fmt(mingap, 1)} | {len(g.seeds)} |")  # fmt: skip
    out += _mechanism(data)
    out += _cost(data)
    out += ["", "## Files", "", *[f"- `{p.name}`" for p in figures], ""]
    return "\n".join(out)


def _mechanism(data: Data) -> list[str]:
    lines = ["", "## Mechanism: what the machines do with a need to change lane", "",
             "Per AV: an *episode* is a stretch of steps in which N holds (a lane change is wanted). *Moved*: the "
             "AV changed lane during it. *Deferred*: a safe gap towards the wanted side (L or R) was seen and not "
             "taken. *Never resolved*: the episode was still open when the AV reached the end of the road. Times "
             "are per AV, in seconds; state times only for the generated machines.", "",
             "| controller | AVs | AV runs | episodes | moved | deferred | never resolved | N held s/AV | "
             "gap passed up s/AV | " + " | ".join(f"{s} s/AV" for s in STATES) + " |",
             "|---|---|---|---|---|---|---|---|---|" + "---|" * len(STATES)]  # fmt: skip
    for (controller, avs), g in sorted(data.groups.items()):
        if not g.av_count:
            continue
        n = g.av_count
        lines.append(
            f"| {label(controller)} | {avs} | {n} | {g.needs} | {g.moved} ({g.moved / max(g.needs, 1):.0%}) | "
            f"{g.deferred} ({g.deferred / max(g.needs, 1):.0%}) | {g.open} ({g.open / max(g.needs, 1):.0%}) | "
            f"{g.need_s / n:.1f} | {g.deferred_s / n:.1f} | "
            + " | ".join(f"{g.state_s[s] / n:.1f}" if SETUPS[controller].kind == "fsm" else "-" for s in STATES)
            + " |"
        )
    return lines


def _cost(data: Data) -> list[str]:
    lines = ["", "## Cost: travel time and speed (the paper's Sec. V leaves these out)", "",
             "![cost](fig6_cost.svg)", "",
             "| controller | AVs | AV travel time s | AV mean speed km/h | other traffic mean speed km/h |",
             "|---|---|---|---|---|"]  # fmt: skip
    for controller, avs, g in data.ordered():
        speed = _scaled(mean_ci(g.speed_ms), 3.6)
        bg = _scaled(mean_ci(g.bg_speed_ms), 3.6)
        lines.append(f"| {label(controller)} | {avs} | {_fmt(mean_ci(g.travel_s), 1)} | {_fmt(speed, 2)} | "
                     f"{_fmt(bg, 2)} |")  # fmt: skip
    return lines


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
