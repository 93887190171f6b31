"""MOBIL's decision function on cases computed by hand from the formulas of Kesting, Treiber and Helbing (2007)
and the IDM of Treiber, Hennecke and Helbing (2000). Each expected number below is worked out in the comment
beside it, with a = 1.4, b = 2.0, T = 1.5 s, s0 = 2 m, delta = 4."""

from __future__ import annotations

import math

import pytest

from sim_check.mobil import FREE, Car, Idm, Mobil, Scene, evaluate

IDM = Idm(v0=30.0)
SQRT_AB = math.sqrt(1.4 * 2.0)  # 1.6733


def test_idm_free_road() -> None:
    # a (1 - (v/v0)^4) = 1.4 (1 - (20/30)^4) = 1.4 (1 - 0.197531) = 1.123457
    assert IDM.accel(20.0) == pytest.approx(1.123457, abs=1e-6)
    assert IDM.accel(30.0) == pytest.approx(0.0, abs=1e-12)  # at the desired speed


def test_idm_following_at_equal_speed() -> None:
    # s* = s0 + v T = 2 + 30 = 32; a = 1.4 (1 - 0.197531 - (32/30)^2) = 1.4 (0.802469 - 1.137778) = -0.469432
    assert IDM.accel(20.0, gap=30.0, v_lead=20.0) == pytest.approx(-0.469432, abs=1e-6)


def test_idm_closing_in_brakes_harder() -> None:
    # s* = 2 + 30 + 20 * 5 / (2 sqrt(2.8)) = 32 + 100 / 3.346640 = 61.880613
    # a = 1.4 (0.802469 - (61.880613 / 30)^2) = 1.4 (0.802469 - 4.254690) = -4.833109
    assert IDM.accel(20.0, gap=30.0, v_lead=15.0) == pytest.approx(-4.833109, abs=1e-5)


def test_idm_never_uses_a_negative_desired_gap() -> None:
    # a much faster leader: v T + v dv / (2 sqrt(ab)) = 30 - 20 * 20 / 3.34664 < 0, so s* = s0 = 2
    # a = 1.4 (0.802469 - (2/30)^2) = 1.4 (0.802469 - 0.004444) = 1.117235
    assert IDM.accel(20.0, gap=30.0, v_lead=40.0) == pytest.approx(1.117235, abs=1e-6)


def stuck(**changes: Car) -> Scene:
    """An AV at 20 m/s, 30 m behind a leader at 20 m/s, with an empty target lane unless changed."""
    base = {"leader": Car(30.0, 20.0), "follower": Car(), "new_leader": Car(), "new_follower": Car()}
    base.update(changes)
    return Scene(v=20.0, length=5.0, **base)


def test_empty_target_lane_is_an_incentive_equal_to_the_own_gain() -> None:
    # no followers: incentive = a~c - ac = 1.123457 - (-0.469432) = 1.592889 > a_thr + bias = 0.4
    verdict = evaluate(stuck(), +1, IDM, IDM)
    assert verdict.incentive == pytest.approx(1.592889, abs=1e-5)
    assert verdict.safe and verdict.change


def test_threshold_and_keep_right_bias() -> None:
    # new leader at 60 m going 20 m/s: a~c = 1.4 (0.802469 - (32/60)^2) = 1.4 (0.802469 - 0.284444) = 0.725235
    # incentive = 0.725235 + 0.469432 = 1.194667: both sides pass; with a_thr 1.0 and bias 0.2, the left needs
    # more than 1.2 (no) and the right more than 0.8 (yes)
    scene = stuck(new_leader=Car(60.0, 20.0))
    strict = Mobil(a_thr=1.0, bias=0.2)
    left, right = evaluate(scene, +1, IDM, IDM, strict), evaluate(scene, -1, IDM, IDM, strict)
    assert left.incentive == pytest.approx(1.194667, abs=1e-5) == right.incentive
    assert not left.change and right.change
    assert evaluate(scene, +1, IDM, IDM, Mobil(a_thr=1.0, bias=0.0)).change  # symmetric rules


def test_safety_criterion_vetoes_a_change_that_makes_the_new_follower_brake_hard() -> None:
    # new follower 10 m behind at 30 m/s, the AV at 20: s* = 2 + 45 + 30 * 10 / 3.346640 = 136.641
    # a~n = 1.4 (1 - 1 - (136.641 / 10)^2) = -261.4 < -b_safe = -4
    verdict = evaluate(stuck(new_follower=Car(10.0, 30.0)), +1, IDM, IDM)
    assert not verdict.safe and not verdict.change


def test_politeness_weighs_the_followers() -> None:
    # the old follower, 20 m behind at 20 m/s, gains from the change: before, it follows the AV at 20 m:
    #   a_o = 1.4 (0.802469 - (32/20)^2) = 1.4 (0.802469 - 2.56) = -2.460543
    # after, it follows the AV's old leader at 20 + 5 + 30 = 55 m:
    #   a~o = 1.4 (0.802469 - (32/55)^2) = 1.4 (0.802469 - 0.338512) = 0.649540
    # incentive = 1.592889 + p (a~o - a_o) = 1.592889 + 0.5 * 3.110083 = 3.147931
    scene = stuck(follower=Car(20.0, 20.0))
    assert evaluate(scene, +1, IDM, IDM).incentive == pytest.approx(3.147931, abs=1e-5)
    assert evaluate(scene, +1, IDM, IDM, Mobil(p=0.0)).incentive == pytest.approx(1.592889, abs=1e-5)


def test_a_lane_that_ends_forces_the_merge() -> None:
    # the end of the acceleration lane is a standing obstacle 20 m ahead of an AV at 15 m/s:
    # s* = 2 + 22.5 + 15 * 15 / 3.346640 = 91.732; a = 1.4 (1 - (15/30)^4 - (91.732/20)^2) = -28.14
    scene = Scene(15.0, 5.0, Car(20.0, 0.0), Car(), Car(FREE, 0.0), Car())
    verdict = evaluate(scene, +1, IDM, IDM)
    assert verdict.change and verdict.incentive > 25.0
