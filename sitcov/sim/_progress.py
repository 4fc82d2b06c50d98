"""Route progress of the ego for backends that only see poses: completion, goal, standstill.

The embedded world tracks the ego's arc length itself and also says when the ego is
``blocked`` (``sitcov.sim.embedded._progress``). A backend that reads the ego's pose each
tick from another simulator (CARLA) uses :class:`RouteProgress`: it projects the pose on
the ego's route polyline near the last match (a window of route segments, so a route that
passes near itself is not confused), keeps the largest arc length reached, and reports the
same facts as the embedded world, except ``blocked_time`` (None: who occupies the ego's
path is not derived from such a backend's actors; docs/carla.md).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

from sitcov.sim._judge import STATIONARY_SPEED

#: Route segments searched ahead of the last match per tick (20 Hz, ~1 m segments).
WINDOW = 12


class RouteProgress:
    """Tracks the ego along its route from poses.

    Args:
        route: the ego's route points (x, y) [m], in the frame of the poses.
        goal_tolerance: the goal is reached within this distance of the route's end [m].
        budget: the run's time limit [s].
    """

    def __init__(
        self, route: Sequence[tuple[float, float]], goal_tolerance: float, budget: float
    ) -> None:
        pts = [(float(x), float(y)) for x, y in route] or [(0.0, 0.0)]
        self.pts = pts
        self.ss = [0.0]
        for (ax, ay), (bx, by) in zip(pts, pts[1:], strict=False):
            self.ss.append(self.ss[-1] + math.hypot(bx - ax, by - ay))
        self.goal_s = max(self.ss[-1] - float(goal_tolerance), 1e-9)
        self.budget = float(budget)
        self.i = 0
        self.best = 0.0
        self.goal_time: float | None = None
        self.still_time = 0.0
        self.speed = 0.0

    def update(self, t: float, x: float, y: float, speed: float, dt: float) -> None:
        """One tick: the ego's position [m] and speed [m/s]; ``dt`` the tick [s]."""
        pts, ss = self.pts, self.ss
        best_d, best_s, best_i = math.inf, self.best, self.i
        for i in range(self.i, min(self.i + WINDOW, len(pts) - 1)):
            (ax, ay), (bx, by) = pts[i], pts[i + 1]
            ex, ey = bx - ax, by - ay
            seg = ex * ex + ey * ey
            u = 0.0 if seg == 0.0 else max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / seg))
            d = math.hypot(ax + u * ex - x, ay + u * ey - y)
            if d < best_d:
                best_d, best_s, best_i = d, ss[i] + u * math.sqrt(seg), i
        self.i = best_i
        if best_s > self.best:
            self.best = best_s
        if self.goal_time is None and self.best >= self.goal_s:
            self.goal_time = t
        self.speed = speed
        if speed < STATIONARY_SPEED:
            self.still_time += dt

    def facts(self, end_reason: str, latched: bool) -> dict[str, Any]:
        """The route progress metrics of the run (``latched``: the ego's AEB latched)."""
        reached = self.goal_time is not None or end_reason == "goal"
        standing = self.speed < STATIONARY_SPEED
        stopped = standing and not reached
        incomplete = not reached and end_reason in ("sim_timeout", "stopped")
        return {
            "route_length": round(self.goal_s, 6),
            "route_completion": 1.0 if reached else round(min(1.0, self.best / self.goal_s), 6),
            "time_to_goal": self.goal_time if reached else None,
            "time_budget": self.budget,
            "standstill_time": round(self.still_time, 10),
            "blocked_time": None,
            "route_incomplete_time": self.budget if incomplete else None,
            "ego_stopped": bool(stopped),
            "stop_reason": "aeb_latched" if stopped and latched else None,
        }
