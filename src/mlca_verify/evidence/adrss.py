"""Intel's ad-rss-lib (PyPI `ad-rss`, import `ad_rss`) as a reference for RSS's safe longitudinal distance, same
direction (Shalev-Shwartz, Shammah and Shashua, 2017, Definition 1). It is an optional dependency: `available()`
says whether it can be imported, and nothing else here may be called without it."""

from __future__ import annotations

import importlib.util
import warnings
from functools import cache
from typing import Any


def available() -> bool:
    return importlib.util.find_spec("ad_rss") is not None


@cache
def _lib() -> Any:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the bindings register a converter twice
        import ad_rss  # type: ignore[import-untyped]
    return ad_rss


def _dynamics(rho: float, accel: float, brake_min: float, brake_max: float) -> Any:
    """RSS dynamics with those longitudinal params (the lateral and unstructured ones are ad-rss-lib's examples;
    the same-direction distance does not read them)."""
    lib = _lib()
    physics, world = lib.physics, lib.rss.world
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
    return dynamics


def _object(speed: float, rho: float, accel: float, brake_min: float, brake_max: float) -> Any:
    """A vehicle in ad-rss-lib's structured world at the given longitudinal speed, with those RSS dynamics."""
    lib = _lib()
    physics, core = lib.physics, lib.rss.core
    world = lib.rss.world
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
    state.object_type, state.dynamics = world.ObjectType.OtherVehicle, _dynamics(rho, accel, brake_min, brake_max)
    state.structured_object_state, state.unstructured_object_state = structured_state, shape
    return state


def ad_rss_gap(v_rear: float, v_front: float, params: tuple[float, ...]) -> float:
    """ad-rss-lib's safe distance behind a vehicle at `v_front` for one at `v_rear`, with `params` = (response
    time, largest acceleration during it, smallest braking behind, largest braking in front)."""
    lib = _lib()
    distance = lib.physics.Distance(0.0)
    ok = lib.rss.structured.calculateSafeLongitudinalDistanceSameDirection(
        _object(v_front, *params), _object(v_rear, *params), distance
    )
    if not ok:
        raise ValueError(f"ad-rss-lib refused the situation {v_rear, v_front, params}")
    return float(distance.mDistance)
