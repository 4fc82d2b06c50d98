"""Criticality metrics of a CARLA run, accumulated tick by tick (sitcov frame).

The same quantities as the embedded backend reports: minimum distance between the two
vehicle boxes, minimum constant-velocity time-to-collision, post-encroachment time at the
conflict point, the AEB's first firing, and the relative speed at a collision.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from sitcov.sim.carla._geometry import box_corners, box_distance

#: A vehicle "occupies" the conflict point while its centre is within this radius [m].
CONFLICT_RADIUS = 2.5
#: Closing speeds below this do not define a time-to-collision [m/s].
MIN_CLOSING_SPEED = 0.1


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
    """Accumulates the run's metrics; call :meth:`update` once per tick."""

    conflict: tuple[float, float]
    min_distance: float = math.inf
    min_ttc: float | None = None
    aeb_time: float | None = None
    # time intervals [s] each vehicle's centre spent inside the conflict radius
    _ego_in: list[float] = field(default_factory=list)
    _ov_in: list[float] = field(default_factory=list)

    def update(self, t: float, ego: VehicleState, ov: VehicleState) -> None:
        """Add the tick at time ``t`` [s] (the AEB time is set by the caller)."""
        a = box_corners(ego.x, ego.y, ego.yaw, ego.half_length, ego.half_width)
        b = box_corners(ov.x, ov.y, ov.yaw, ov.half_length, ov.half_width)
        gap = box_distance(a, b)
        self.min_distance = min(self.min_distance, gap)
        dx, dy = ov.x - ego.x, ov.y - ego.y
        centre = math.hypot(dx, dy)
        if centre > 0:
            closing = -((dx * (ov.vx - ego.vx) + dy * (ov.vy - ego.vy)) / centre)
            if closing > MIN_CLOSING_SPEED:
                ttc = gap / closing
                self.min_ttc = ttc if self.min_ttc is None else min(self.min_ttc, ttc)
        cx, cy = self.conflict
        if math.hypot(ego.x - cx, ego.y - cy) <= CONFLICT_RADIUS:
            self._ego_in.append(t)
        if math.hypot(ov.x - cx, ov.y - cy) <= CONFLICT_RADIUS:
            self._ov_in.append(t)

    @property
    def pet(self) -> float | None:
        """Post-encroachment time [s]: from the first vehicle leaving the conflict point to
        the second reaching it (0 if they were there together); None unless both passed."""
        if not self._ego_in or not self._ov_in:
            return None
        first, second = sorted((self._ego_in, self._ov_in), key=lambda ts: ts[0])
        return max(0.0, second[0] - first[-1])


def relative_speed(ego: VehicleState, ov: VehicleState) -> float:
    """Magnitude of the relative velocity [m/s] (the impact speed at a collision)."""
    return math.hypot(ov.vx - ego.vx, ov.vy - ego.vy)
