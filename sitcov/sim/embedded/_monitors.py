"""Run monitors: small objects the run loop calls each step, each recording one fact.

A monitor watches the ego and records the first time [s] its event happens; it never ends
the run nor decides a verdict (that is the campaign's judge, ``sitcov.sim.Judge``), so the
simulated facts are the same whatever counts as a failure.

- :class:`LaneDepartureMonitor`: the ego's lateral offset from its route exceeds a stated
  tolerance (the box reaches :data:`LANE_TOLERANCE` beyond its lane's edge).
- :class:`RoadDepartureMonitor`: a corner of the ego's box is outside the map's drivable
  area (:class:`DrivableArea`: the road surface of every leg plus the junction area). The
  exact corner test runs only when the box can reach the area's edge at all: each route
  point knows how far the road extends to its left and right (:func:`route_clearance`),
  and the box's lateral reach is bounded by its offset, its half width and its heading
  error, so on an ordinary lap the exact test never runs.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

#: How far the ego's box may reach beyond its lane's edge before it counts as a lane
#: departure [m] (a wheel over the marking is normal driving; half a metre is not).
LANE_TOLERANCE = 0.5
#: Slack on the cheap pre-test of the road monitor [m]: covers the route frame turning
#: under a box that is up to ~2.5 m long (curve radius >= 10 m: < 0.35 m) and the route's
#: 1 m point spacing.
CLEARANCE_SLACK = 0.5
#: Lateral search range and resolution of :func:`route_clearance` [m].
_REACH, _STEP = 10.0, 0.05
#: Arc length either side of a route point over which its clearance is the minimum [m]:
#: half a car's length and width plus one route segment (the ego lies between two points).
WINDOW = 4.0

Polygon = Sequence[tuple[float, float]]


class DrivableArea:
    """A union of convex counter-clockwise polygons (leg road surfaces, junction area).

    Args:
        polygons: each a list of (x, y) corners [m], counter-clockwise, convex.
    """

    def __init__(self, polygons: Sequence[Polygon]) -> None:
        self.polygons = [tuple((float(x), float(y)) for x, y in p) for p in polygons]
        # edges as (ax, ay, ex, ey): inside iff ex * (py - ay) - ey * (px - ax) >= 0
        self._edges = [
            [(a[0], a[1], b[0] - a[0], b[1] - a[1]) for a, b in zip(p, p[1:] + p[:1], strict=True)]
            for p in self.polygons
        ]

    def contains(self, x: float, y: float, eps: float = 1e-6) -> bool:
        """Whether (x, y) lies on the drivable area (edges included)."""
        for edges in self._edges:
            for ax, ay, ex, ey in edges:
                if ex * (y - ay) - ey * (x - ax) < -eps:
                    break
            else:
                return True
        return False

    def contains_box(self, x: float, y: float, yaw: float, half_l: float, half_w: float) -> bool:
        """Whether all four corners of a box (centre, heading, half sizes) are on the area."""
        c, s = math.cos(yaw), math.sin(yaw)
        for a, b in ((half_l, half_w), (half_l, -half_w), (-half_l, -half_w), (-half_l, half_w)):
            if not self.contains(x + a * c - b * s, y + a * s + b * c):
                return False
        return True

    def contains_many(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`contains` for arrays of points."""
        inside = np.zeros(np.shape(xs), dtype=bool)
        for edges in self._edges:
            ok = np.ones(np.shape(xs), dtype=bool)
            for ax, ay, ex, ey in edges:
                ok &= ex * (ys - ay) - ey * (xs - ax) >= -1e-6
            inside |= ok
        return inside


def route_clearance(area: DrivableArea, route: Any) -> tuple[list[float], list[float]]:
    """How far the drivable area extends left and right of each point of ``route`` [m].

    ``route`` is a ``Path`` (``xs``, ``ys``, ``hs``, ``ss``). Measured along each point's
    normal (to :data:`_REACH` at :data:`_STEP` resolution), then the minimum over
    :data:`WINDOW` metres of arc length either side, so that a box near point i but
    reaching along the route meets the nearest edge of its whole length. A point off the
    area has clearance 0 on both sides (the box is then always tested exactly).
    """
    x, y = np.asarray(route.xs)[:, None], np.asarray(route.ys)[:, None]
    h, ss = np.asarray(route.hs)[:, None], np.asarray(route.ss)
    t = np.arange(0.0, _REACH + _STEP, _STEP)[None, :]
    nx, ny = -np.sin(h), np.cos(h)
    out = []
    for side in (1.0, -1.0):
        inside = area.contains_many(x + side * t * nx, y + side * t * ny)
        first_out = np.where(inside.all(axis=1), inside.shape[1], np.argmin(inside, axis=1))
        clear = np.maximum(first_out - 1, 0) * _STEP
        lo = np.searchsorted(ss, ss - WINDOW, side="left")
        hi = np.searchsorted(ss, ss + WINDOW, side="right")
        out.append([float(clear[a:b].min()) for a, b in zip(lo, hi, strict=True)])
    # near an end of the route the box may reach beyond it: unless the road goes on
    # there, such points get no clearance (always the exact test)
    for end, sign, near in ((0, -1.0, ss < WINDOW), (-1, 1.0, ss > ss[-1] - WINDOW)):
        hx = float(x[end, 0] + sign * WINDOW * np.cos(h[end, 0]))
        hy = float(y[end, 0] + sign * WINDOW * np.sin(h[end, 0]))
        if not area.contains(hx, hy):
            for side in out:
                for i in np.flatnonzero(near):
                    side[i] = 0.0
    return out[0], out[1]


class LaneDepartureMonitor:
    """Records when the ego's lateral offset from its route first exceeds ``limit`` [m]."""

    __slots__ = ("limit", "time")

    def __init__(self, limit: float) -> None:
        self.limit = float(limit)
        self.time: float | None = None

    def update(self, t: float, x: float, y: float, yaw: float, i: int, lat: float) -> None:
        """One step: ego pose, its route segment ``i`` and signed lateral offset ``lat``."""
        if self.time is None and (lat > self.limit or -lat > self.limit):
            self.time = t


class RoadDepartureMonitor:
    """Records when a corner of the ego's box first leaves the drivable area.

    Args:
        area: the map's drivable area.
        hs: route headings per point [rad]; ``left``/``right``: :func:`route_clearance`.
        half_l, half_w: half the ego's length and width [m].
    """

    __slots__ = ("area", "half_l", "half_w", "hs", "left", "right", "time")

    def __init__(
        self,
        area: DrivableArea,
        hs: Sequence[float],
        left: Sequence[float],
        right: Sequence[float],
        half_l: float,
        half_w: float,
    ) -> None:
        self.area, self.hs, self.left, self.right = area, hs, left, right
        self.half_l, self.half_w = half_l, half_w
        self.time: float | None = None

    def update(self, t: float, x: float, y: float, yaw: float, i: int, lat: float) -> None:
        """One step (same arguments as :meth:`LaneDepartureMonitor.update`)."""
        if self.time is not None:
            return
        # lateral reach of the box in the route frame: <= half_w + half_l * |sin(yaw - h)|
        reach = self.half_w + self.half_l * abs(math.sin(yaw - self.hs[i])) + CLEARANCE_SLACK
        if lat + reach < self.left[i] and reach - lat < self.right[i]:
            return
        if not self.area.contains_box(x, y, yaw, self.half_l, self.half_w):
            self.time = t
