"""PID controllers in the style of CARLA's ``agents.navigation.controller``.

Both keep the last ``window`` errors (CARLA uses a deque of 10): the derivative is the
difference of the last two errors over ``dt``, the integral the sum of the window times
``dt`` (a leaky integral, so it cannot wind up). Plain Python floats: these run every
control step of every run.

Sign convention: our frame is right-handed (x east, y north, yaw counter-clockwise), and a
positive steer turns left. CARLA's frame is left-handed with positive steer to the right;
measuring the heading error counter-clockwise gives the same behaviour with the same gains.
"""

from __future__ import annotations

import math
from typing import Any


class _WindowPID:
    """Shared error window, derivative and integral terms."""

    __slots__ = ("kp", "kd", "ki", "dt", "window", "_errors", "_sum")

    def __init__(self, kp: float, kd: float, ki: float, dt: float, window: int = 10) -> None:
        self.kp, self.kd, self.ki, self.dt = float(kp), float(kd), float(ki), float(dt)
        self.window = int(window)
        self._errors: list[float] = []
        self._sum = 0.0

    def reset(self) -> None:
        """Forget all past errors."""
        self._errors = []
        self._sum = 0.0

    def update(self, error: float) -> float:
        """Push ``error`` and return the unclipped PID output."""
        errors = self._errors
        errors.append(error)
        self._sum += error
        if len(errors) > self.window:
            self._sum -= errors.pop(0)
        if len(errors) < 2:
            return self.kp * error
        de = (error - errors[-2]) / self.dt
        ie = self._sum * self.dt
        return self.kp * error + self.kd * de + self.ki * ie


class LongitudinalPID(_WindowPID):
    """Speed controller: error in km/h, output an acceleration command in [-1, 1].

    CARLA's stock gains: K_P 0.15, K_D 0.05, K_I 0.07 at dt 0.05 s.
    """

    __slots__ = ()

    def step(self, target_kmh: float, speed_kmh: float) -> float:
        """Command in [-1, 1]: positive means throttle, negative brake."""
        u = self.update(target_kmh - speed_kmh)
        return 1.0 if u > 1.0 else (-1.0 if u < -1.0 else u)


class LateralPID(_WindowPID):
    """Heading controller: error = signed angle [rad] from the heading to a target point.

    CARLA's stock gains: K_P 0.58, K_D 0.02, K_I 0.5 at dt 0.05 s. Positive output steers
    left (counter-clockwise).
    """

    __slots__ = ()

    def step(self, x: float, y: float, yaw: float, tx: float, ty: float) -> float:
        """Steer command in [-1, 1] towards target (tx, ty) from pose (x, y, yaw)."""
        wx, wy = tx - x, ty - y  # heading_error(), inlined: this runs every step
        if wx == 0.0 and wy == 0.0:
            error = 0.0
        else:
            hx, hy = math.cos(yaw), math.sin(yaw)
            error = math.atan2(hx * wy - hy * wx, hx * wx + hy * wy)
        u = self.update(error)
        return 1.0 if u > 1.0 else (-1.0 if u < -1.0 else u)


def heading_error(x: float, y: float, yaw: float, tx: float, ty: float) -> float:
    """Signed angle [rad] from heading ``yaw`` to the vector (x, y) -> (tx, ty).

    Positive when the target lies to the left (counter-clockwise); 0 when the target
    coincides with the position (as CARLA does).
    """
    wx, wy = tx - x, ty - y
    if wx == 0.0 and wy == 0.0:
        return 0.0
    hx, hy = math.cos(yaw), math.sin(yaw)
    return math.atan2(hx * wy - hy * wx, hx * wx + hy * wy)


def window_pid(
    st: Any, at: int, ring: int, error: float, gains: Any, g: int, full: bool, head: int, n: int
) -> float:
    """:meth:`_WindowPID.update` on a flat state, for the compiled route step
    (``_reference._route_step``): the same operations in the same order, so the same bits.

    ``st[at]`` is the running sum, ``st[at + 1]`` the last error and ``st[ring:ring + w]``
    the window as a ring buffer whose oldest entry sits at ``head`` once ``full``; ``n`` is
    the window's length after this push. ``gains[g:g + 3]`` are kp, kd, ki; ``gains[9]``
    is dt. Plain floats and indexing only, so numba compiles it (``_jit.py``).
    """
    total = st[at] + error
    if full:
        total -= st[ring + head]  # the error that leaves the window
    st[ring + head] = error
    st[at] = total
    last = st[at + 1]
    st[at + 1] = error
    kp = gains[g]
    if n < 2:
        return kp * error
    dt = gains[9]
    de = (error - last) / dt
    ie = total * dt
    return kp * error + gains[g + 1] * de + gains[g + 2] * ie
