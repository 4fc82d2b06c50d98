"""Oriented-box geometry: overlap (separating axes), distance and time-to-collision.

A box is (x, y, yaw, half_length, half_width) [m, rad]; plain floats, cheap enough to call
every control step.
"""

from __future__ import annotations

import math
from typing import Any

from sitcov.sim._metrics import time_to_collision  # noqa: F401  (shared definition)

Box = tuple[float, float, float, float, float]


def corners(box: Box) -> list[tuple[float, float]]:
    """The four corners [m], counter-clockwise starting at the front right."""
    x, y, yaw, hl, hw = box
    c, s = math.cos(yaw), math.sin(yaw)
    ax, ay = c * hl, s * hl
    bx, by = -s * hw, c * hw
    return [
        (x + ax - bx, y + ay - by),
        (x + ax + bx, y + ay + by),
        (x - ax + bx, y - ay + by),
        (x - ax - bx, y - ay - by),
    ]


def overlap(a: Box, b: Box) -> bool:
    """True if the two boxes intersect (separating axis theorem, bounding circles first)."""
    dx, dy = b[0] - a[0], b[1] - a[1]
    ra = math.hypot(a[3], a[4])
    rb = math.hypot(b[3], b[4])
    if dx * dx + dy * dy > (ra + rb) * (ra + rb):
        return False
    ca, sa, cb, sb = math.cos(a[2]), math.sin(a[2]), math.cos(b[2]), math.sin(b[2])
    for ux, uy in ((ca, sa), (-sa, ca), (cb, sb), (-sb, cb)):
        dist = abs(dx * ux + dy * uy)
        pa = a[3] * abs(ca * ux + sa * uy) + a[4] * abs(-sa * ux + ca * uy)
        pb = b[3] * abs(cb * ux + sb * uy) + b[4] * abs(-sb * ux + cb * uy)
        if dist > pa + pb:
            return False
    return True


def _point_box_distance(px: float, py: float, box: Box) -> float:
    x, y, yaw, hl, hw = box
    c, s = math.cos(yaw), math.sin(yaw)
    lx = (px - x) * c + (py - y) * s
    ly = -(px - x) * s + (py - y) * c
    ex = abs(lx) - hl
    ey = abs(ly) - hw
    ex = ex if ex > 0.0 else 0.0
    ey = ey if ey > 0.0 else 0.0
    return math.hypot(ex, ey)


def box_distance(a: Box, b: Box) -> float:
    """Distance between two boxes [m] (0 if they overlap).

    For two convex polygons that do not intersect, the closest pair of points involves a
    corner of one of them, so the minimum of the eight corner-to-box distances is exact.
    """
    if overlap(a, b):
        return 0.0
    best = math.inf
    for px, py in corners(a):
        d = _point_box_distance(px, py, b)
        if d < best:
            best = d
    for px, py in corners(b):
        d = _point_box_distance(px, py, a)
        if d < best:
            best = d
    return best


def corridor_gap(path: Any, s_from: float, box: Box) -> float:
    """Smallest distance [m] from ``box`` to the points of ``path`` beyond arc length ``s_from``.

    Used to decide whether a vehicle following ``path`` can still touch a standing box:
    it cannot if the gap exceeds its half-width plus a tracking margin. Points are ~1 m
    apart, so the true distance to the polyline is at most ~0.13 m smaller.
    """
    best = math.inf
    for x, y, s in zip(path.xs, path.ys, path.ss, strict=True):
        if s >= s_from:
            d = _point_box_distance(x, y, box)
            if d < best:
                best = d
    return best
