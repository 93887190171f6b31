"""The RSS lemma template (docs/lemmas/rss_longitudinal.toml) against Intel's ad-rss-lib: its `rss_gap`, as the
engine evaluates it (z3) and as the brute-force evaluator does (exact fractions, no code shared with the
engine), equals ad-rss-lib's safe longitudinal distance (same direction) to 1 mm on a grid of speeds and params;
and its lemmas have their expected verdicts (a one-response-time gap is not RSS-safe)."""

from __future__ import annotations

import itertools
import warnings
from fractions import Fraction
from typing import Any

import pytest
import z3

from mlca_verify.logic import check_all
from mlca_verify.logic.symbolic import StepInputs, System, Valuation, python_value, value_of
from mlca_verify.model import Var
from mlca_verify.spec import load_spec
from tests.bruteforce_data import Point, ev
from tests.conftest import ROOT

TEMPLATE = ROOT / "docs" / "lemmas" / "rss_longitudinal.toml"
SPEEDS = (0.0, 2.5, 13.9, 30.0, 41.7, 70.0)
PARAMS = (  # RHO, ACCEL_MAX, BRAKE_MIN, BRAKE_MAX: ad-rss-lib's defaults, then others within the ranges
    (1.0, 3.5, 4.0, 8.0),
    (0.5, 2.0, 3.0, 6.0),
    (2.0, 1.0, 6.0, 10.0),
    (0.2, 0.0, 9.5, 9.5),
)

with warnings.catch_warnings():
    warnings.simplefilter("ignore")  # the bindings register a converter twice
    import ad_rss

physics = ad_rss.physics
core, world, structured = ad_rss.rss.core, ad_rss.rss.world, ad_rss.rss.structured


def _object(speed: float, rho: float, accel: float, brake_min: float, brake_max: float) -> Any:
    """A vehicle in ad-rss-lib's structured world with the given longitudinal speed and RSS dynamics."""
    lon = world.LongitudinalRssAccelerationValues()
    lon.accel_max, lon.brake_min, lon.brake_max = (physics.Acceleration(a) for a in (accel, -brake_min, -brake_max))
    lon.brake_min_correct = physics.Acceleration(-min(brake_min, 3.0))
    lat = world.LateralRssAccelerationValues()
    lat.accel_max, lat.brake_min = physics.Acceleration(0.2), physics.Acceleration(-0.8)
    settings = world.UnstructuredSettings()
    settings.pedestrian_turning_radius, settings.vehicle_min_radius = physics.Distance(2.0), physics.Distance(3.5)
    settings.drive_away_max_angle = physics.Angle(2.4)
    settings.vehicle_yaw_rate_change = physics.AngularAcceleration(0.3)
    settings.vehicle_trajectory_calculation_step = physics.Duration(0.2)
    dynamics = world.RssDynamics()
    dynamics.alpha_lon, dynamics.alpha_lat, dynamics.unstructured_settings = lon, lat, settings
    dynamics.response_time, dynamics.max_speed_on_acceleration = physics.Duration(rho), physics.Speed(100.0)
    dynamics.lateral_fluctuation_margin = physics.Distance(0.0)
    dynamics.min_longitudinal_safety_distance = physics.Distance(0.0)
    velocity = world.Velocity()
    velocity.speed_lon_min = velocity.speed_lon_max = physics.Speed(speed)
    velocity.speed_lat_min = velocity.speed_lat_max = physics.Speed(0.0)
    structured_state = core.StructuredObjectState()
    structured_state.velocity, structured_state.has_priority, structured_state.is_in_correct_lane = (
        velocity,
        False,
        True,
    )
    structured_state.distance_to_enter_intersection = physics.Distance(0.0)
    structured_state.distance_to_leave_intersection = physics.Distance(0.0)
    shape = world.ObjectState()
    shape.yaw, shape.steering_angle, shape.yaw_rate = (
        physics.Angle(0.0),
        physics.Angle(0.0),
        physics.AngularVelocity(0.0),
    )
    shape.dimension = physics.Dimension2D()
    shape.dimension.length, shape.dimension.width = physics.Distance(4.0), physics.Distance(2.0)
    shape.center_point = physics.Distance2D()
    shape.center_point.x, shape.center_point.y = physics.Distance(0.0), physics.Distance(0.0)
    shape.speed_range = physics.SpeedRange()
    shape.speed_range.minimum = shape.speed_range.maximum = physics.Speed(speed)
    state = core.RelativeObjectState()
    state.object_type, state.dynamics = world.ObjectType.OtherVehicle, dynamics
    state.structured_object_state, state.unstructured_object_state = structured_state, shape
    return state


def ad_rss_gap(v_rear: float, v_front: float, params: tuple[float, ...]) -> float:
    distance = physics.Distance(0.0)
    ok = structured.calculateSafeLongitudinalDistanceSameDirection(
        _object(v_front, *params), _object(v_rear, *params), distance
    )
    assert ok, (v_rear, v_front, params)
    return float(distance.mDistance)


def test_the_template_equals_ad_rss_lib_to_a_millimetre() -> None:
    machine = load_spec(TEMPLATE).machine
    system = System(machine, (), (), frozenset(), False)
    names = ("RHO", "ACCEL_MAX", "BRAKE_MIN", "BRAKE_MAX")
    compared = 0
    for params, v_rear, v_front in itertools.product(PARAMS, SPEEDS, SPEEDS):
        exact = {n: Fraction(p) for n, p in zip(names, params, strict=True)}
        samples = {"v_rear": Fraction(v_rear), "v_front": Fraction(v_front), "gap": Fraction(0)}
        signals = {k: value_of(x, "real") for k, x in samples.items()}
        valuation = Valuation(
            z3.IntVal(0),
            {},
            StepInputs({"N": z3.BoolVal(False)}, signals, {}),
            {k: value_of(x, "real") for k, x in exact.items()},
        )
        engine = python_value(z3.simplify(system.ev(Var("rss_gap"), valuation)))
        brute = ev(Var("rss_gap"), Point(machine, "IDLE", {}, {**samples, "N": False}, exact))
        reference = ad_rss_gap(v_rear, v_front, params)
        assert abs(float(engine) - reference) <= 1e-3, (v_rear, v_front, params, engine, reference)
        assert abs(float(brute) - reference) <= 1e-3, (v_rear, v_front, params, brute, reference)
        compared += 1
    assert compared == len(PARAMS) * len(SPEEDS) ** 2
    assert ad_rss_gap(30.0, 30.0, PARAMS[0]) == pytest.approx(115.78125)  # "about 116 m" at 30 m/s


def test_the_template_lemmas_have_their_expected_verdicts() -> None:
    results = {r.prop: r for r in check_all(load_spec(TEMPLATE).machine) if r.kind == "lemma"}
    assert {k: r.verdict for k, r in results.items()} == {
        "front-braking-only-helps": "holds",
        "time-gap-rule-is-rss-safe": "violated",
    }
    cx = results["time-gap-rule-is-rss-safe"].counterexample
    assert cx is not None
    values = cx.steps[0].definitions
    assert values["time_gap_rule"] and not values["rss_safe"]
