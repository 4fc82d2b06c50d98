"""The adversarial other vehicle (OV): arrive at the conflict point when the ego does.

The paper's controller, backend-neutral (the embedded and the CARLA backends both use it):

1. ``wait``: the OV holds still until the ego starts moving;
2. ``regulate``: every tick ``u = gain * (t_OV - t_ego)`` with ``t = distance to the
   conflict point / current speed`` (speeds below ``min_speed`` count as ``min_speed`` so
   a standing vehicle has a large but finite time); ``u > 0`` -> throttle ``min(u, 1)``,
   ``u < 0`` -> brake ``min(-u, 1)``;
3. ``cruise``: once the ego is within ``switch_distance`` of the conflict point (or the OV
   has reached it), the OV drives on to its goal at ``cruise_speed`` under a speed
   P-controller and ignores the ego.

Lateral control is pure pursuit on the OV's route.
"""

from __future__ import annotations

import math
from dataclasses import dataclass


@dataclass(frozen=True)
class AdversaryParams:
    """Tuning of the adversary (documented in ``docs/embedded.md``).

    Attributes:
        gain: the paper's timing gain on ``t_OV - t_ego`` [1/s].
        switch_distance: the ego's remaining distance to the conflict point at which the
            OV stops regulating and cruises [m].
        cruise_speed: speed after the switch, 15 km/h [m/s].
        cruise_gain: P gain of the cruise speed control [1/(m/s)].
        min_speed: speed floor in the arrival-time estimate [m/s].
        start_speed: ego speed that counts as "started" [m/s].
        lookahead_time: pure-pursuit look-ahead per unit speed [s].
        lookahead_min: minimum look-ahead distance [m].
    """

    gain: float = 3.0
    switch_distance: float = 8.0
    cruise_speed: float = 15.0 / 3.6
    cruise_gain: float = 0.5
    min_speed: float = 0.5
    start_speed: float = 0.1
    lookahead_time: float = 0.8
    lookahead_min: float = 4.0


def arrival_time(distance: float, speed: float, min_speed: float) -> float:
    """Time to cover ``distance`` [m] at the current ``speed`` [m/s] (floored at ``min_speed``)."""
    return max(distance, 0.0) / max(speed, min_speed)


class AdversaryController:
    """Longitudinal phases of the OV. One instance per run.

    Args:
        params: tuning; the defaults follow the paper.
        has_conflict: False if the routes never meet; the OV then cruises once the ego starts.
    """

    def __init__(self, params: AdversaryParams | None = None, has_conflict: bool = True) -> None:
        self.params = params or AdversaryParams()
        self.has_conflict = has_conflict
        self.phase = "wait"

    def command(self, d_ego: float, v_ego: float, d_ov: float, v_ov: float) -> tuple[float, float]:
        """(throttle, brake) for this tick.

        Args:
            d_ego, d_ov: remaining distance along each route to the conflict point [m]
                (negative once past it).
            v_ego, v_ov: current speeds [m/s].
        """
        p = self.params
        if self.phase == "wait":
            if v_ego <= p.start_speed:
                return 0.0, 1.0
            self.phase = "regulate" if self.has_conflict else "cruise"
        if self.phase == "regulate" and (d_ego <= p.switch_distance or d_ov <= 0.0):
            self.phase = "cruise"
        if self.phase == "regulate":
            u = p.gain * (
                arrival_time(d_ov, v_ov, p.min_speed) - arrival_time(d_ego, v_ego, p.min_speed)
            )
        else:
            u = p.cruise_gain * (p.cruise_speed - v_ov)
        if u >= 0.0:
            return min(u, 1.0), 0.0
        return 0.0, min(-u, 1.0)

    def lookahead(self, speed: float) -> float:
        """Pure-pursuit look-ahead distance [m] at ``speed`` [m/s]."""
        return max(self.params.lookahead_min, self.params.lookahead_time * speed)


def pure_pursuit(
    x: float, y: float, yaw: float, target_x: float, target_y: float, wheelbase: float
) -> float:
    """Road-wheel angle [rad] that steers a rear-axle point at (x, y) onto the target point."""
    dx, dy = target_x - x, target_y - y
    alpha = math.atan2(dy, dx) - yaw
    dist = math.hypot(dx, dy)
    if dist < 1e-6:
        return 0.0
    return math.atan2(2.0 * wheelbase * math.sin(alpha), dist)
