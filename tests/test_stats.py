"""The report's statistics and verdict rules on data whose answer is known."""

from __future__ import annotations

import math

from sim_check.stats import extreme_verdict, mann_whitney_less, mean_ci, reduction_ci, reduction_verdict


def test_mean_ci_brackets_the_mean_and_is_repeatable() -> None:
    values = [float(v % 7) for v in range(100)]
    mean, lo, hi = mean_ci(values)
    assert mean == sum(values) / len(values)
    assert lo < mean < hi
    assert mean_ci(values) == (mean, lo, hi)
    assert mean_ci([3.0] * 10) == (3.0, 3.0, 3.0)
    assert all(math.isnan(x) for x in mean_ci([]))


def test_reduction_of_exactly_half() -> None:
    subject, baseline = [2.0, 2.0, 3.0, 1.0] * 25, [4.0, 4.0, 6.0, 2.0] * 25
    r, lo, hi = reduction_ci(subject, baseline)
    assert r == 0.5
    assert lo < 0.5 < hi
    verdict = reduction_verdict(subject, baseline, 0.5)
    assert verdict.verdict == "reproduced"
    assert "+50%" in verdict.measured


def test_claimed_reduction_outside_the_interval_is_not_reproduced() -> None:
    subject, baseline = [2.0, 2.0, 3.0, 1.0] * 25, [4.0, 4.0, 6.0, 2.0] * 25
    assert reduction_verdict(subject, baseline, 0.35).verdict == "not reproduced"
    # the reverse direction: the subject has more
    assert reduction_verdict(baseline, subject, 0.35).verdict == "not reproduced"


def test_no_reduction_is_defined_from_a_baseline_without_events() -> None:
    verdict = reduction_verdict([0.0, 1.0], [0.0, 0.0], 0.28)
    assert verdict.verdict == "not comparable"
    assert math.isnan(reduction_ci([1.0], [0.0])[0])


def test_mann_whitney_effect_size_at_its_extremes() -> None:
    low, high = [1.0, 2.0, 3.0], [10.0, 11.0, 12.0]
    t = mann_whitney_less(low, high)
    assert t.u == 0 and t.effect == -1.0 and t.p < 0.1
    assert mann_whitney_less(high, low).effect == 1.0
    assert mann_whitney_less([0.0] * 5, [0.0] * 5).p == 1.0


def test_lowest_and_highest() -> None:
    groups = {"a": [0.0] * 50, "b": [1.0] * 50, "c": [0.0, 1.0] * 25}
    assert extreme_verdict("a", groups, lowest=True).verdict == "reproduced"
    assert extreme_verdict("b", groups, lowest=False).verdict == "reproduced"
    lost = extreme_verdict("c", groups, lowest=True)
    assert lost.verdict == "not reproduced" and "a" in lost.measured
    assert extreme_verdict("a", {"a": [0.0], "b": [0.0]}, lowest=True).verdict == "not comparable"
    tied = extreme_verdict("a", {**groups, "d": [0.0] * 50}, lowest=True)
    assert tied.verdict == "not reproduced" and "rank 1 of 4" in tied.measured and "tied with d" in tied.measured


def test_a_group_without_runs_is_not_comparable() -> None:
    verdict = reduction_verdict([1.0, 2.0], [], 0.35)
    assert verdict.verdict == "not comparable" and verdict.measured == "no runs to compare"
