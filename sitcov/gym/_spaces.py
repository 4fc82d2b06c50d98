"""What a policy sees and does: the observation and action spaces of :mod:`sitcov.gym`.

:class:`ObservationEncoder` turns the stack-side :class:`~sitcov.av.Observation` of a run
into the fixed-size arrays of :func:`observation_space`; :func:`action_to_control` clips an
action of :func:`action_space` into a :class:`~sitcov.av.Control`. The environment and
:class:`~sitcov.gym.PolicyStack` share both, so a policy trained in one runs in the other.
The layout is described in :mod:`sitcov.gym`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from gymnasium import spaces

from sitcov.av import Control, Observation, RunInfo
from sitcov.errors import ConfigError

#: Bound of the positions, angles [rad], speeds [m/s] and times [s] in an observation [m].
MAP_EXTENT = 1.0e4
#: Detections kept in an observation [-].
MAX_DETECTIONS = 8
#: Route points in an observation [-].
N_WAYPOINTS = 10
#: Spacing of the route points in an observation [m].
WAYPOINT_SPACING = 2.0

#: A policy: the observation dict -> ``[throttle, brake, steer]``.
Policy = Callable[[dict[str, np.ndarray]], Any]


def observation_space() -> spaces.Dict:
    """The observation space shared by the environment and :class:`PolicyStack`."""
    big = MAP_EXTENT
    return spaces.Dict(
        {
            "ego": spaces.Box(-big, big, shape=(5,), dtype=np.float32),
            "route": spaces.Box(-big, big, shape=(N_WAYPOINTS, 2), dtype=np.float32),
            "detections": spaces.Box(0.0, 1.0, shape=(MAX_DETECTIONS, 6), dtype=np.float32),
        }
    )


def action_space() -> spaces.Box:
    """Throttle [0, 1], brake [0, 1], steer [-1, 1]."""
    return spaces.Box(
        np.array([0.0, 0.0, -1.0], dtype=np.float32),
        np.array([1.0, 1.0, 1.0], dtype=np.float32),
        dtype=np.float32,
    )


class ObservationEncoder:
    """Turns the stack-side :class:`Observation` of a run into the fixed-size arrays.

    It tracks the ego's progress along the route (arc length of its projection) and
    holds the last frame's detections on steps without a new frame.
    """

    def __init__(self, info: RunInfo) -> None:
        route = [tuple(map(float, p)) for p in info.route] or [tuple(map(float, info.goal))]
        self.route = route
        self.cum = [0.0]
        for (x0, y0), (x1, y1) in zip(route, route[1:], strict=False):
            self.cum.append(self.cum[-1] + math.hypot(x1 - x0, y1 - y0))
        self.width = float(info.camera.width)
        self.height = float(info.camera.height)
        self.segment = 0
        self.progress = 0.0
        self.detections = np.zeros((MAX_DETECTIONS, 6), dtype=np.float32)

    def _project(self, x: float, y: float) -> float:
        """Advance along the route to the nearest segment ahead; return the arc length."""
        route, best, best_d, best_s = self.route, self.segment, math.inf, self.progress
        for i in range(self.segment, min(self.segment + 20, len(route) - 1)):
            (ax, ay), (bx, by) = route[i], route[i + 1]
            dx, dy = bx - ax, by - ay
            length2 = dx * dx + dy * dy
            u = ((x - ax) * dx + (y - ay) * dy) / length2 if length2 > 0.0 else 0.0
            u = 0.0 if u < 0.0 else (1.0 if u > 1.0 else u)
            px, py = ax + u * dx, ay + u * dy
            d = math.hypot(x - px, y - py)
            if d < best_d:
                best, best_d, best_s = i, d, self.cum[i] + u * math.sqrt(length2)
        self.segment = best
        return max(best_s, self.progress)

    def _point_at(self, s: float) -> tuple[float, float]:
        cum, route = self.cum, self.route
        if s >= cum[-1]:
            return route[-1]
        i = self.segment
        while i < len(cum) - 2 and cum[i + 1] < s:
            i += 1
        span = cum[i + 1] - cum[i]
        u = 0.0 if span == 0.0 else (s - cum[i]) / span
        (ax, ay), (bx, by) = route[i], route[i + 1]
        return ax + u * (bx - ax), ay + u * (by - ay)

    def encode(self, observation: Observation) -> tuple[dict[str, np.ndarray], float]:
        """The observation arrays and the progress made since the previous call [m]."""
        ego = observation.ego
        s = self._project(ego.x, ego.y)
        gained, self.progress = s - self.progress, s
        c, sn = math.cos(ego.yaw), math.sin(ego.yaw)
        route = np.empty((N_WAYPOINTS, 2), dtype=np.float32)
        for k in range(N_WAYPOINTS):
            px, py = self._point_at(s + (k + 1) * WAYPOINT_SPACING)
            dx, dy = px - ego.x, py - ego.y
            route[k] = (c * dx + sn * dy, -sn * dx + c * dy)
        if observation.detections is not None:
            rows = sorted(observation.detections, key=lambda d: d.box[2] - d.box[0], reverse=True)[
                :MAX_DETECTIONS
            ]
            det = np.zeros((MAX_DETECTIONS, 6), dtype=np.float32)
            for k, d in enumerate(rows):
                x0, y0, x1, y1 = d.box
                det[k] = (
                    x0 / self.width,
                    y0 / self.height,
                    x1 / self.width,
                    y1 / self.height,
                    d.score,
                    1.0,
                )
            self.detections = np.clip(det, 0.0, 1.0)
        obs = {
            "ego": np.array([ego.x, ego.y, ego.yaw, ego.speed, observation.t], dtype=np.float32),
            "route": route,
            "detections": self.detections.copy(),
        }
        return obs, gained


def action_to_control(action: Any) -> Control:
    """Clip an action (throttle, brake, steer) into a :class:`Control`."""
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ConfigError(
            field="action", value=action, expected="3 finite numbers (throttle, brake, steer)"
        )
    return Control(
        throttle=float(min(1.0, max(0.0, a[0]))),
        brake=float(min(1.0, max(0.0, a[1]))),
        steer=float(min(1.0, max(-1.0, a[2]))),
    )
