"""A tiny kinematic bicycle loop for testing stacks without the embedded backend."""

from __future__ import annotations

import math

from sitcov.av import AVStack, EgoState, Observation, RunInfo
from sitcov.perception import CameraSpec

WHEELBASE = 2.7  # [m]
MAX_STEER = 1.0  # front-wheel angle at steer 1 [rad]
MAX_ACCEL = 3.5  # at throttle 1 [m/s^2]
MAX_DECEL = 9.0  # at brake 1 [m/s^2]
DT = 0.05  # [s]


def drive(
    stack: AVStack,
    route: list[tuple[float, float]],
    start: tuple[float, float, float],
    steps: int,
    detections=None,
) -> list[tuple[float, float, float, float, object]]:
    """Run ``stack`` on a kinematic bicycle; returns (x, y, yaw, speed, control) per step.

    ``detections(step)`` (optional) gives the Observation's detections for that step.
    """
    x, y, yaw = start
    v = 0.0
    stack.reset(RunInfo(DT, tuple(route), route[-1], "test", CameraSpec(), seed=0, situation=None))
    rows = []
    for i in range(steps):
        t = i * DT
        dets = detections(i) if detections else ()
        control = stack.step(Observation(t, EgoState(x, y, yaw, v, t), detections=dets))
        accel = MAX_ACCEL * control.throttle - MAX_DECEL * control.brake
        v = max(0.0, v + accel * DT)
        delta = MAX_STEER * control.steer
        x += v * math.cos(yaw) * DT
        y += v * math.sin(yaw) * DT
        yaw += v / WHEELBASE * math.tan(delta) * DT
        rows.append((x, y, yaw, v, control))
    return rows


def cross_track(route: list[tuple[float, float]], x: float, y: float) -> float:
    """Distance [m] from (x, y) to the nearest route point (route ~1 m apart, so +-0.5 m)."""
    return min(math.hypot(px - x, py - y) for px, py in route)
