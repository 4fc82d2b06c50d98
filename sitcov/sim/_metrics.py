"""Criticality metrics: ONE definition of ``min_ttc`` and ``pet`` for every backend.

Both the embedded and the CARLA backend compute :class:`~sitcov.sim.Outcome`'s
``min_ttc`` and ``pet`` with the functions here, so the two numbers mean the same thing
whichever simulator produced a run (docs/metrics.md):

- ``min_ttc`` [s]: the smallest, over the run's steps, constant-velocity time-to-collision
  of two discs with the vehicles' footprint areas (radius ``sqrt(length * width / pi)``
  each), centred on the vehicles and moving with their current velocities
  (:func:`time_to_collision`); 0 while the discs overlap, None if they never close in.
- ``pet`` [s]: post-encroachment time at the conflict zone. The conflict zone on each
  route is where the two routes' swept paths (centre lines closer than the sum of the
  half-widths) overlap, cut to its first :data:`PET_ZONE` metres. A vehicle enters when
  its front reaches the start of its zone and leaves when its rear passes the end (arc
  lengths along its own route). PET = the second vehicle's entry minus the first's exit,
  0 if they overlapped in time or collided, None unless both entered (and the first left).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

#: Length of the conflict zone used for PET, from the start of the swept-path overlap [m].
PET_ZONE = 5.0


def disc_radius(length: float, width: float) -> float:
    """Radius [m] of the disc with a vehicle's footprint area."""
    return math.sqrt(length * width / math.pi)


def time_to_collision(px: float, py: float, vx: float, vy: float, radius: float) -> float | None:
    """Constant-velocity TTC of two discs [s].

    Args:
        px, py: position of the other vehicle relative to the ego [m].
        vx, vy: its velocity relative to the ego [m/s].
        radius: sum of the two discs' radii [m].

    Returns:
        The first time the discs touch, 0 if they already do, None if they never will.
    """
    c = px * px + py * py - radius * radius
    if c <= 0.0:
        return 0.0
    b = px * vx + py * vy
    if b >= 0.0:
        return None  # not closing in
    a = vx * vx + vy * vy
    disc = b * b - a * c
    if disc < 0.0:
        return None
    return (-b - math.sqrt(disc)) / a


@dataclass
class ZoneClock:
    """When one vehicle entered and left its conflict zone (arc lengths on its route).

    Args:
        start: arc length where the zone starts [m] (inf: the routes never meet).
        end: arc length where it ends [m].
        half_length: half the vehicle's length [m].
    """

    start: float
    end: float
    half_length: float
    entered: float | None = None
    left: float | None = None

    def update(self, t: float, s: float) -> None:
        """The vehicle's centre is at arc length ``s`` [m] at time ``t`` [s]."""
        if self.entered is None and s + self.half_length >= self.start:
            self.entered = t
        if self.left is None and s - self.half_length > self.end:
            self.left = t


def zone_clocks(
    conflict: object | None, half_ego: float, half_ov: float
) -> tuple[ZoneClock, ZoneClock]:
    """Clocks for the ego and the OV from a swept-path overlap with attributes ``s_ego``,
    ``s_ego_end``, ``s_ov``, ``s_ov_end`` (None: the routes never meet, PET stays None)."""
    if conflict is None:
        return ZoneClock(math.inf, math.inf, half_ego), ZoneClock(math.inf, math.inf, half_ov)
    s_e, s_o = conflict.s_ego, conflict.s_ov  # type: ignore[attr-defined]
    end_e = min(conflict.s_ego_end, s_e + PET_ZONE)  # type: ignore[attr-defined]
    end_o = min(conflict.s_ov_end, s_o + PET_ZONE)  # type: ignore[attr-defined]
    return ZoneClock(s_e, end_e, half_ego), ZoneClock(s_o, end_o, half_ov)


def post_encroachment_time(
    ego: ZoneClock | tuple[float | None, float | None],
    ov: ZoneClock | tuple[float | None, float | None],
    collided: bool,
) -> float | None:
    """PET [s] from the two vehicles' (entry, exit) times of their conflict zones."""
    enter_e, exit_e = (ego.entered, ego.left) if isinstance(ego, ZoneClock) else ego
    enter_o, exit_o = (ov.entered, ov.left) if isinstance(ov, ZoneClock) else ov
    if enter_e is None or enter_o is None:
        return None
    if collided:
        return 0.0
    if enter_e <= enter_o:
        return None if exit_e is None else max(0.0, enter_o - exit_e)
    return None if exit_o is None else max(0.0, enter_e - exit_o)
