"""Statistics for the report: bootstrap confidence intervals, Mann-Whitney U with its effect size, and the verdict
rules for the paper's claims. Pure functions of lists of per-run numbers; the bootstrap is seeded, so the same
database gives the same report."""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.stats import mannwhitneyu

RESAMPLES = 4000
ALPHA = 0.05


def _rng() -> np.random.Generator:
    return np.random.default_rng(20240)


def mean_ci(values: Sequence[float]) -> tuple[float, float, float]:
    """Mean and its 95% percentile-bootstrap interval."""
    x = np.asarray(values, dtype=float)
    if len(x) == 0:
        return float("nan"), float("nan"), float("nan")
    means = x[_rng().integers(0, len(x), (RESAMPLES, len(x)))].mean(axis=1)
    lo, hi = np.percentile(means, [2.5, 97.5])
    return float(x.mean()), float(lo), float(hi)


def reduction_ci(subject: Sequence[float], baseline: Sequence[float]) -> tuple[float, float, float]:
    """Relative reduction 1 - mean(subject)/mean(baseline) and its 95% bootstrap interval (each group resampled
    on its own). NaN where the baseline's mean is zero."""
    a, b = np.asarray(subject, dtype=float), np.asarray(baseline, dtype=float)
    if len(a) == 0 or len(b) == 0 or b.mean() == 0:
        return float("nan"), float("nan"), float("nan")
    rng = _rng()
    ma = a[rng.integers(0, len(a), (RESAMPLES, len(a)))].mean(axis=1)
    mb = b[rng.integers(0, len(b), (RESAMPLES, len(b)))].mean(axis=1)
    ok = mb > 0
    reductions = 1.0 - ma[ok] / mb[ok]
    lo, hi = np.percentile(reductions, [2.5, 97.5])
    return float(1.0 - a.mean() / b.mean()), float(lo), float(hi)


@dataclass(frozen=True)
class Test:
    """One-sided Mann-Whitney U (is `subject` stochastically smaller than `baseline`?) and the rank-biserial
    correlation: -1 when every subject value is below every baseline value, +1 for the reverse, 0 for none."""

    u: float
    p: float
    effect: float


def mann_whitney_less(subject: Sequence[float], baseline: Sequence[float]) -> Test:
    a, b = np.asarray(subject, dtype=float), np.asarray(baseline, dtype=float)
    if len(a) == 0 or len(b) == 0:
        return Test(float("nan"), float("nan"), float("nan"))
    if np.all(a == a[0]) and np.all(b == a[0]):  # identical constants: no evidence either way
        return Test(len(a) * len(b) / 2.0, 1.0, 0.0)
    result = mannwhitneyu(a, b, alternative="less")
    u = float(result.statistic)
    return Test(u, float(result.pvalue), 2.0 * u / (len(a) * len(b)) - 1.0)


ClaimStanding = Literal["reproduced", "not reproduced", "not comparable"]


@dataclass(frozen=True)
class ClaimVerdict:
    verdict: ClaimStanding
    measured: str
    test: str


def reduction_verdict(subject: Sequence[float], baseline: Sequence[float], claimed: float) -> ClaimVerdict:
    """Reproduced when the 95% interval of the measured reduction holds the claimed one and the one-sided
    Mann-Whitney test finds the subject smaller (p < 0.05); not comparable when the baseline never has the event."""
    if not len(subject) or not len(baseline):
        return ClaimVerdict("not comparable", "no runs to compare", "")
    r, lo, hi = reduction_ci(subject, baseline)
    t = mann_whitney_less(subject, baseline)
    test = f"Mann-Whitney U = {t.u:.0f}, one-sided p = {_p(t.p)}, rank-biserial r = {t.effect:+.2f}"
    if math.isnan(r):
        mean_s = float(np.mean(subject))
        return ClaimVerdict(
            "not comparable", f"baseline mean 0 (subject mean {mean_s:.2f}): no reduction is defined", test
        )
    measured = f"{r:+.0%} [{lo:+.0%}, {hi:+.0%}]"
    if lo <= claimed <= hi and t.p < ALPHA:
        return ClaimVerdict("reproduced", measured, test)
    return ClaimVerdict("not reproduced", measured, test)


def extreme_verdict(subject: str, groups: Mapping[str, Sequence[float]], lowest: bool) -> ClaimVerdict:
    """Reproduced when the subject's mean is the lowest (highest), shared with no other group, and no other
    group's is significantly lower (higher) by a one-sided Mann-Whitney test; not comparable when every group's
    mean is zero. A tie for first place does not make the subject the lowest (highest)."""
    means = {name: float(np.mean(v)) for name, v in groups.items() if len(v)}
    if subject not in means or not any(means.values()):
        return ClaimVerdict("not comparable", "no events in any group", "")
    sign = 1.0 if lowest else -1.0
    order = sorted(means, key=lambda n: (sign * means[n], n != subject, n))
    ties = sorted(n for n in means if n != subject and means[n] == means[subject])
    rivals = []
    mine = groups[subject]
    for name, values in groups.items():
        if name == subject or not len(values):
            continue
        t = mann_whitney_less(values, mine) if lowest else mann_whitney_less(mine, values)
        rivals.append((t.p, name))
    beaten = [name for p, name in rivals if p < ALPHA]
    rank = 1 + sum(sign * means[n] < sign * means[subject] for n in means)
    measured = f"rank {rank} of {len(order)} (mean {means[subject]:.2f} per run"
    measured += f"; {order[0]} first at {means[order[0]]:.2f})" if rank > 1 else ")"
    if ties:
        measured += f"; tied with {', '.join(ties)}"
    worst_p = min(rivals)[0] if rivals else float("nan")
    test = f"one-sided Mann-Whitney against each other controller: smallest p = {_p(worst_p)}"
    if rank == 1 and not beaten and not ties:
        return ClaimVerdict("reproduced", measured, test)
    if beaten:
        measured += f"; significantly {'lower' if lowest else 'higher'}: {', '.join(sorted(beaten))}"
    return ClaimVerdict("not reproduced", measured, test)


def _p(p: float) -> str:
    return "n/a" if math.isnan(p) else ("< 0.001" if p < 0.001 else f"{p:.3f}")
