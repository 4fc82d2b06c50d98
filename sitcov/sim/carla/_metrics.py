"""Criticality metrics of a CARLA run, accumulated tick by tick (sitcov frame).

The same quantities, with the same definitions, as the embedded backend reports: minimum
distance between the two vehicle boxes, minimum time-to-collision and post-encroachment
time as :mod:`sitcov.sim._metrics` defines them, the AEB's first firing, and the relative
speed at a collision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from sitcov.sim._metrics import (
    disc_radius,
    post_encroachment_time,
    time_to_collision,
    zone_clocks,
)
from sitcov.sim.carla._geometry import box_corners, box_distance


@dataclass
class VehicleState:
    """One vehicle at one tick, sitcov frame: position [m], yaw [rad], velocity [m/s]."""

    x: float
    y: float
    yaw: float
    vx: float
    vy: float
    half_length: float
    half_width: float

    @property
    def speed(self) -> float:
        """Speed [m/s]."""
        return math.hypot(self.vx, self.vy)


@dataclass
class MetricTracker:
    """Accumulates the run's metrics; call :meth:`update` once per tick.

    ``min_ttc`` and ``pet`` follow the one definition of :mod:`sitcov.sim._metrics` (the
    embedded backend's): disc time-to-collision, and PET at the conflict zone where the
    two routes' swept paths overlap, timed by each vehicle's arc length on its route.

    Args:
        ego_route, ov_route: the vehicles' routes, (x, y) [m] in the sitcov frame.
    """

    ego_route: list[tuple[float, float]]
    ov_route: list[tuple[float, float]]
    min_distance: float = math.inf
    min_ttc: float | None = None
    #: the largest DRAC [m/s^2]: |v_rel| / (2 TTC) for TTC > 0 (docs/metrics.md)
    max_drac: float | None = None
    aeb_time: float | None = None
    _zone: Any = None  # (ego path, OV path, ego clock, OV clock, hints), built on first tick

    def _zones(self, ego: VehicleState, ov: VehicleState) -> Any:
        """The routes as paths and the conflict-zone clocks (needs the vehicles' sizes)."""
        if self._zone is None:
            from sitcov.sim.embedded._map import find_conflict
            from sitcov.sim.embedded._path import Path

            e_path, o_path = Path.from_points(self.ego_route), Path.from_points(self.ov_route)
            conflict = find_conflict(e_path, o_path, ego.half_width + ov.half_width)
            clocks = zone_clocks(conflict, ego.half_length, ov.half_length)
            self._zone = [e_path, o_path, *clocks, 0, 0]
        return self._zone

    def update(self, t: float, ego: VehicleState, ov: VehicleState) -> None:
        """Add the tick at time ``t`` [s] (the AEB time is set by the caller)."""
        a = box_corners(ego.x, ego.y, ego.yaw, ego.half_length, ego.half_width)
        b = box_corners(ov.x, ov.y, ov.yaw, ov.half_length, ov.half_width)
        self.min_distance = min(self.min_distance, box_distance(a, b))
        radius = disc_radius(2 * ego.half_length, 2 * ego.half_width) + disc_radius(
            2 * ov.half_length, 2 * ov.half_width
        )
        ttc = time_to_collision(ov.x - ego.x, ov.y - ego.y, ov.vx - ego.vx, ov.vy - ego.vy, radius)
        if ttc is not None:
            self.min_ttc = ttc if self.min_ttc is None else min(self.min_ttc, ttc)
        if ttc is not None and ttc > 0.0:
            drac = math.hypot(ov.vx - ego.vx, ov.vy - ego.vy) / (2.0 * ttc)
            self.max_drac = drac if self.max_drac is None else max(self.max_drac, drac)
        zone = self._zones(ego, ov)
        s_e, zone[4] = zone[0].track(ego.x, ego.y, zone[4])
        s_o, zone[5] = zone[1].track(ov.x, ov.y, zone[5])
        zone[2].update(t, s_e)
        zone[3].update(t, s_o)

    def pet(self, collided: bool) -> float | None:
        """Post-encroachment time [s] (:func:`sitcov.sim._metrics.post_encroachment_time`)."""
        if self._zone is None:
            return None
        return post_encroachment_time(self._zone[2], self._zone[3], collided)


def relative_speed(ego: VehicleState, ov: VehicleState) -> float:
    """Magnitude of the relative velocity [m/s] (the impact speed at a collision)."""
    return math.hypot(ov.vx - ego.vx, ov.vy - ego.vy)
