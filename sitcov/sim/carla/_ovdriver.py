"""Drives the OV in CARLA with the shared adversary (``sitcov.sim._adversary``).

The timing law and its phases are the embedded backend's: this module only measures what
the controller needs on CARLA's routes (remaining distance along each route to the
conflict point) and steers the OV along its route by pure pursuit. Sitcov frame
throughout; steer positive = left.
"""

from __future__ import annotations

import math

from sitcov.sim._adversary import (
    AdversaryController,
    AdversaryParams,
    pure_pursuit,
    with_switch_distance,
)

#: Wheelbase used by pure pursuit [m] (a mid-size car; CARLA does not report it).
WHEELBASE = 2.8
#: The OV stops (full brake) within this distance of its goal [m].
GOAL_RADIUS = 2.0
#: How far ahead along the route the nearest-point search looks per tick [points].
SEARCH_WINDOW = 40


class RouteProgress:
    """Arc-length progress of a vehicle along a polyline route, and the distance left to
    a point on it.

    Args:
        route: (x, y) [m] points, start to goal.
        target: a point near the route (the conflict point); its arc length is that of
            the nearest route point.
    """

    def __init__(self, route: list[tuple[float, float]], target: tuple[float, float]) -> None:
        self.route = route
        s = [0.0]
        for (x0, y0), (x1, y1) in zip(route, route[1:], strict=False):
            s.append(s[-1] + math.hypot(x1 - x0, y1 - y0))
        self.s = s
        tx, ty = target
        gaps = [math.hypot(px - tx, py - ty) for px, py in route]
        nearest = gaps.index(min(gaps))
        self.target_s = s[nearest]
        self.index = 0

    def update(self, x: float, y: float) -> int:
        """Advance to the route point nearest (x, y) (never backwards); its index."""
        route, best, best_d = self.route, self.index, math.inf
        for i in range(self.index, min(len(route), self.index + SEARCH_WINDOW)):
            d = math.hypot(route[i][0] - x, route[i][1] - y)
            if d < best_d:
                best, best_d = i, d
        self.index = best
        return best

    def remaining(self) -> float:
        """Distance [m] along the route from the current point to the target (< 0 past it)."""
        return self.target_s - self.s[self.index]


class OVDriver:
    """Per-run OV controller: the shared adversary + pure pursuit.

    Args:
        ego_route, ov_route: routes (x, y) [m], sitcov frame.
        conflict: conflict point (x, y) [m].
        max_steer: the OV's maximum road-wheel angle [rad] (steer 1.0).
        params: adversary tuning (default: the shared defaults).
        switch_distance: the situation's switch distance [m] (the map file's
            ``switch_distances`` entry: where the paper's Town03 trigger box ended the
            synchronisation); used unless ``params`` fix their own.
        targets: arc lengths [m] of the conflict on the ego's and the OV's route, when
            known (e.g. where their swept paths start to overlap); default: each route's
            point nearest to ``conflict``.
    """

    def __init__(
        self,
        ego_route: list[tuple[float, float]],
        ov_route: list[tuple[float, float]],
        conflict: tuple[float, float],
        max_steer: float = math.radians(70.0),
        params: AdversaryParams | None = None,
        switch_distance: float | None = None,
        targets: tuple[float, float] | None = None,
    ) -> None:
        self.ego = RouteProgress(ego_route, conflict)
        self.ov = RouteProgress(ov_route, conflict)
        if targets is not None:  # the conflict's arc lengths on each route, known already
            self.ego.target_s, self.ov.target_s = targets
        self.controller = AdversaryController(
            with_switch_distance(params or AdversaryParams(), switch_distance)
        )
        self.max_steer = max_steer
        self.released_at: float | None = None

    def at_goal(self, x: float, y: float) -> bool:
        """Whether the OV is within GOAL_RADIUS of its goal."""
        gx, gy = self.ov.route[-1]
        return math.hypot(x - gx, y - gy) < GOAL_RADIUS

    def command(
        self,
        t: float,
        ego_xy: tuple[float, float],
        ego_speed: float,
        ov_pose: tuple[float, float, float],
        ov_speed: float,
    ) -> tuple[float, float, float]:
        """(throttle, brake, steer) for this tick at time ``t`` [s]."""
        x, y, yaw = ov_pose
        self.ego.update(*ego_xy)
        i = self.ov.update(x, y)
        throttle, brake = self.controller.command(
            self.ego.remaining(), ego_speed, self.ov.remaining(), ov_speed
        )
        if self.released_at is None and self.controller.phase == "cruise":
            self.released_at = t
        if self.at_goal(x, y):
            throttle, brake = 0.0, 1.0
        route = self.ov.route
        reach = self.controller.lookahead(ov_speed)
        rx, ry = x - 0.5 * WHEELBASE * math.cos(yaw), y - 0.5 * WHEELBASE * math.sin(yaw)
        j = i
        while j < len(route) - 1 and math.hypot(route[j][0] - rx, route[j][1] - ry) < reach:
            j += 1
        delta = pure_pursuit(rx, ry, yaw, route[j][0], route[j][1], WHEELBASE)
        return throttle, brake, max(-1.0, min(1.0, delta / self.max_steer))
