"""What the closed loop reads of SUMO every step, bound once per run.

Where `sumo` is libsumo, its compiled functions are bound directly: libsumo's Python methods only forward to them,
and every Python call between two SUMO steps is paid for with a cold cache (SUMO's step leaves little of the
loop's code and data in it). The values are the same as the methods', except getLeader's "no leader": ("", -1.0)
here, where libsumo's method returns None. Anything without libsumo's compiled module (TraCI) is read through its
methods.
"""

from __future__ import annotations

from typing import Any

Leader = tuple[str, float] | None  # a vehicle ahead: (id, gap in metres), or None

# getNeighbors' mode bits (TraCI's vehicle variable 0xbf): bit 0 set is the right side, bit 1 set is leaders
_RIGHT, _LEADERS = 1, 2


def neighbour_mode(side: int, leaders: bool) -> int:
    """getNeighbors' mode for the nearest leaders (or followers) in the lane on `side` (+1 left, -1 right)."""
    return (_RIGHT if side < 0 else 0) | (_LEADERS if leaders else 0)


class Reads:
    """The SUMO getters the loop, sensing and MOBIL call, as plain callables."""

    def __init__(self, sumo: Any) -> None:
        compiled = getattr(sumo, "_libsumo", None)

        def bind(domain: str, name: str) -> Any:
            if compiled is not None:
                return getattr(compiled, f"{domain}_{name}")
            return getattr(getattr(sumo, domain), name)

        self.time = bind("simulation", "getTime")
        self.vehicle_count = bind("vehicle", "getIDCount")
        self.departed = bind("simulation", "getDepartedIDList")
        self.arrived = bind("simulation", "getArrivedIDList")
        self.collisions = bind("simulation", "getCollisions")
        self.road = bind("vehicle", "getRoadID")
        self.lane = bind("vehicle", "getLaneIndex")
        self.position = bind("vehicle", "getLanePosition")
        self.distance = bind("vehicle", "getDistance")
        self.acceleration = bind("vehicle", "getAcceleration")
        self.speed = bind("vehicle", "getSpeed")
        self.allowed_speed = bind("vehicle", "getAllowedSpeed")
        self.length = bind("vehicle", "getLength")
        self.min_gap = bind("vehicle", "getMinGap")
        self.leader = bind("vehicle", "getLeader")
        self.follower = bind("vehicle", "getFollower")
        self.neighbors = bind("vehicle", "getNeighbors")
        self.lane_change_state = bind("vehicle", "getLaneChangeState")
        self.edge_vehicles = bind("edge", "getLastStepVehicleNumber")
        self.edge_speed = bind("edge", "getLastStepMeanSpeed")

    def neighbours(self, av: str, side: int, leaders: bool) -> Any:
        """The nearest vehicles ahead (`leaders`) or behind in the lane on `side` (+1 left, -1 right), as
        (id, gap) pairs; a vehicle beside the AV comes back with a negative gap."""
        return self.neighbors(av, neighbour_mode(side, leaders))
