"""Each lane change checked against RSS's safe longitudinal distance (Shalev-Shwartz, Shammah and Shashua, 2017,
Definition 1) at the step it is executed, whichever controller made it: the gap to the new leader and the gap
from the new follower, against the distance the vehicle behind needs when it accelerates for the response time and
then brakes gently while the one in front brakes hard.

The params are MLCA-T's defaults, read from spec/mlca_t.toml (RHO, ACCEL_MAX, BRAKE_MIN, BRAKE_MAX, ad-rss-lib's
defaults), so that the check and MLCA-T's own rule mean the same distance; the formula here is written apart from
the spec's, and tests compare it with ad-rss-lib.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path

from mlca_verify.spec import load_spec
from sim_check.package_data import SPECS

SPEC = SPECS / "mlca_t.toml"


@dataclass(frozen=True)
class RssParams:
    rho: float  # s
    accel_max: float  # m/s², of the vehicle behind during rho
    brake_min: float  # m/s², of the vehicle behind after rho
    brake_max: float  # m/s², of the vehicle in front


@functools.cache
def spec_params(spec: Path = SPEC) -> RssParams:
    """RSS's params at their defaults in `spec`."""
    defaults = {p.name: float(p.default) for p in load_spec(spec, compare=False).machine.params}
    return RssParams(defaults["RHO"], defaults["ACCEL_MAX"], defaults["BRAKE_MIN"], defaults["BRAKE_MAX"])


def safe_distance(v_rear: float, v_front: float, p: RssParams) -> float:
    """The gap the rear vehicle needs behind the front one, both driving the same way."""
    v_reached = v_rear + p.rho * p.accel_max
    rear = v_rear * p.rho + p.accel_max * p.rho**2 / 2 + v_reached**2 / (2 * p.brake_min)
    front = v_front**2 / (2 * p.brake_max)
    return max(0.0, rear - front)


def change_is_safe(
    v: float, leader: tuple[float, float] | None, follower: tuple[float, float] | None, p: RssParams
) -> bool:
    """Whether the AV at `v` m/s, with the new leader and follower as (gap, speed) or None, keeps RSS's distance
    to both."""
    if leader is not None and leader[0] < safe_distance(v, leader[1], p):
        return False
    return follower is None or follower[0] >= safe_distance(follower[1], v, p)
