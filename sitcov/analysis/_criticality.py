"""DRAC (deceleration rate to avoid a crash) from a run's recorded trajectories.

Definition, consistent with ``min_ttc`` (``sitcov/sim/_metrics.py``, docs/metrics.md): at
each step where both vehicles are recorded, each is a disc with its footprint's area moving
with its current velocity; if the discs would touch after ``TTC > 0`` seconds, the relative
motion covers ``s = |v_rel| * TTC`` metres before contact, and the constant deceleration of
the relative velocity that stops it just in time is

    DRAC = |v_rel|^2 / (2 s) = |v_rel| / (2 TTC)   [m/s^2]

(Archer 2005's rear-end DRAC, ``(v_f - v_l)^2 / (2 gap)``, is the one-dimensional case).
Steps at which the discs would never touch give no value, nor do steps where they already
overlap (a collision, where no deceleration avoids anything). ``max_drac`` is the largest
value over the run, None without any; a common criticality threshold is 3.35 m/s^2.

Why here and not through CommonRoad-CriMe: ``commonroad-crime`` 0.4.5 needs 17 more
packages here (casadi, opencv-python, commonroad-io/-reach/-clcs/-drivability-checker,
pandas, ...) and pins ``protobuf`` 3.20.2, a downgrade from the 7.x that ``ray`` and the
camera extra use; it also needs the run converted into a CommonRoad scenario with a lanelet
network. A dozen lines on our own traces, using our TTC, are checked by hand instead.
"""

from __future__ import annotations

import math
from typing import Any

from sitcov.sim._metrics import disc_radius, time_to_collision


def _velocity(row: tuple[float, ...]) -> tuple[float, float]:
    _, _, _, yaw, speed = row[:5]
    return speed * math.cos(yaw), speed * math.sin(yaw)


def drac_series(
    trace: Any, length: float | None = None, width: float | None = None
) -> list[tuple[float, float]]:
    """(t, DRAC) at every step with a finite, positive TTC.

    Args:
        trace: a ``Trace`` (``ego``/``ov`` rows of (t, x, y, yaw, speed); rows matched by t).
        length, width: vehicle footprint [m]; default the trace's ``meta`` values.
    """
    meta = getattr(trace, "meta", {}) or {}
    length = float(length if length is not None else meta.get("length", 4.5))
    width = float(width if width is not None else meta.get("width", 1.8))
    radius = 2.0 * disc_radius(length, width)
    ov = {round(row[0], 6): row for row in trace.ov}
    out = []
    for row in trace.ego:
        other = ov.get(round(row[0], 6))
        if other is None:
            continue
        (evx, evy), (ovx, ovy) = _velocity(row), _velocity(other)
        vx, vy = ovx - evx, ovy - evy
        ttc = time_to_collision(other[1] - row[1], other[2] - row[2], vx, vy, radius)
        if ttc is None or ttc <= 0.0:
            continue
        out.append((float(row[0]), math.hypot(vx, vy) / (2.0 * ttc)))
    return out


def max_drac(trace: Any, length: float | None = None, width: float | None = None) -> float | None:
    """The largest DRAC of a run [m/s^2], None if the discs never closed in."""
    series = drac_series(trace, length, width)
    return max((d for _, d in series), default=None)
