"""Oriented-box geometry: overlap (separating axes), distance and time-to-collision.

A box is (x, y, yaw, half_length, half_width) [m, rad]; plain floats, cheap enough to call
every control step.
"""

from __future__ import annotations

import math
from typing import Any

from sitcov.sim._metrics import time_to_collision  # noqa: F401  (shared definition)

Box = tuple[float, float, float, float, float]

#: ``math.hypot`` under the name :func:`box_distance` uses (``_jit.py`` compiles that code
#: with the name bound to its correctly rounded version: the same bits).
hypot = math.hypot


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
    return _axes_overlap(a, b, math.cos(a[2]), math.sin(a[2]), math.cos(b[2]), math.sin(b[2]))


def _axes_overlap(a: Box, b: Box, ca: float, sa: float, cb: float, sb: float) -> bool:
    """The separating-axis test of :func:`overlap` (True: no axis separates the boxes),
    given both headings' cos and sin."""
    dx, dy = b[0] - a[0], b[1] - a[1]
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


def _corners_to_box(
    x: float, y: float, c: float, s: float, hl: float, hw: float, box: Box, bc: float, bs: float
) -> float:
    """Smallest distance from the four corners of the box (x, y, c = cos yaw, s = sin yaw,
    hl, hw) to ``box`` (its heading's cos ``bc`` and sin ``bs``): :func:`corners` and
    :func:`_point_box_distance` with the trigonometry done once, the same operations."""
    ax, ay = c * hl, s * hl
    vx, vy = -s * hw, c * hw
    bx, by, _, bhl, bhw = box
    best = math.inf
    for px, py in (
        (x + ax - vx, y + ay - vy),
        (x + ax + vx, y + ay + vy),
        (x - ax + vx, y - ay + vy),
        (x - ax - vx, y - ay - vy),
    ):
        lx = (px - bx) * bc + (py - by) * bs
        ly = -(px - bx) * bs + (py - by) * bc
        ex = abs(lx) - bhl
        ey = abs(ly) - bhw
        d = hypot(ex if ex > 0.0 else 0.0, ey if ey > 0.0 else 0.0)
        if d < best:
            best = d
    return best


def box_distance(a: Box, b: Box) -> float:
    """Distance between two boxes [m] (0 if they overlap).

    For two convex polygons that do not intersect, the closest pair of points involves a
    corner of one of them, so the minimum of the eight corner-to-box distances is exact.
    """
    ca, sa = math.cos(a[2]), math.sin(a[2])
    cb, sb = math.cos(b[2]), math.sin(b[2])
    dx, dy = b[0] - a[0], b[1] - a[1]
    ra = hypot(a[3], a[4])
    rb = hypot(b[3], b[4])
    if dx * dx + dy * dy <= (ra + rb) * (ra + rb) and _axes_overlap(a, b, ca, sa, cb, sb):
        return 0.0  # they overlap (as :func:`overlap` decides)
    d_a = _corners_to_box(a[0], a[1], ca, sa, a[3], a[4], b, cb, sb)
    d_b = _corners_to_box(b[0], b[1], cb, sb, b[3], b[4], a, ca, sa)
    return d_b if d_b < d_a else d_a


def box_distance_flat(
    ax: float,
    ay: float,
    ayaw: float,
    ahl: float,
    ahw: float,
    bx: float,
    by: float,
    byaw: float,
    bhl: float,
    bhw: float,
) -> float:
    """:func:`box_distance` of the boxes ``(ax, ay, ayaw, ahl, ahw)`` and ``(bx, ...)``:
    numba checks ten floats' types several times faster than two tuples' (the distance
    monitor calls it every few steps)."""
    return box_distance((ax, ay, ayaw, ahl, ahw), (bx, by, byaw, bhl, bhw))


_FLAT: Any = None


def box_distance_flat_fn() -> Any:
    """:func:`box_distance_flat` compiled by numba when it is installed (the same bits),
    else itself. Loaded once per process, on first use."""
    global _FLAT
    if _FLAT is None:
        from sitcov._jit import compiled, typed_entry

        example = (0.0, 0.0, 0.3, 2.3, 0.9, 4.0, 1.0, 1.2, 2.3, 0.9)
        helpers = (_axes_overlap, _corners_to_box, box_distance)
        _FLAT = compiled(box_distance_flat, *example, helpers=helpers)
        _FLAT = typed_entry(_FLAT) or box_distance_flat
    return _FLAT


def contact_point(a: Box, b: Box) -> tuple[float, float]:
    """Where two overlapping boxes touch [m]: the centroid of their intersection (box
    ``a`` clipped by each edge of box ``b``, Sutherland-Hodgman; both are convex and
    counter-clockwise); the midpoint of the centres if they do not overlap. Called once
    per collision (the collision map of the report draws it)."""
    poly = corners(a)
    clip = corners(b)
    for (cx, cy), (dx, dy) in zip(clip, clip[1:] + clip[:1], strict=True):
        ex, ey = dx - cx, dy - cy
        # >= 0: inside (left of the edge c -> d)
        sides = [ex * (p[1] - cy) - ey * (p[0] - cx) for p in poly]
        out: list[tuple[float, float]] = []
        for i, p in enumerate(poly):
            q, sp, sq = poly[(i + 1) % len(poly)], sides[i], sides[(i + 1) % len(poly)]
            if sp >= 0.0:
                out.append(p)
            if (sp >= 0.0) != (sq >= 0.0):
                f = sp / (sp - sq)
                out.append((p[0] + f * (q[0] - p[0]), p[1] + f * (q[1] - p[1])))
        poly = out
        if not poly:
            return 0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1])
    area = cx_sum = cy_sum = 0.0
    for (px, py), (qx, qy) in zip(poly, poly[1:] + poly[:1], strict=True):
        cross = px * qy - qx * py
        area += cross
        cx_sum += (px + qx) * cross
        cy_sum += (py + qy) * cross
    if abs(area) < 1e-12:  # the boxes only touch: the mean of the touching points
        n = len(poly)
        return sum(p[0] for p in poly) / n, sum(p[1] for p in poly) / n
    return cx_sum / (3.0 * area), cy_sum / (3.0 * area)


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


def box_on_area(
    edges: Any, ends: Any, x: float, y: float, yaw: float, half_l: float, half_w: float
) -> bool:
    """Whether all four corners of the box (centre, heading, half sizes) lie on a union of
    convex polygons (``_monitors.DrivableArea.contains_box``: the same operations in the
    same order, so the same answer). ``edges``: every polygon's edges as a flat sequence
    ``ax, ay, ex, ey, ...`` (a corner is inside a polygon iff ``ex * (py - ay) - ey * (px -
    ax) >= -1e-6`` for each of its edges); ``ends``: where each polygon's edges end (edge
    counts, accumulated)."""
    c, s = math.cos(yaw), math.sin(yaw)
    for k in range(4):
        a = half_l if k < 2 else -half_l
        b = half_w if k == 0 or k == 3 else -half_w
        px = x + a * c - b * s
        py = y + a * s + b * c
        start = 0
        inside = False
        for end in ends:
            ok = True
            for j in range(start, end):
                o = 4 * j
                if edges[o + 2] * (py - edges[o + 1]) - edges[o + 3] * (px - edges[o]) < -1e-6:
                    ok = False
                    break
            if ok:
                inside = True
                break
            start = end
        if not inside:
            return False
    return True


_AREA: Any = None


def box_on_area_fn() -> Any:
    """:func:`box_on_area` compiled by numba when it is installed (the same answers), else
    itself. Loaded once per process, on first use."""
    global _AREA
    if _AREA is None:
        import numpy as np

        from sitcov._jit import compiled, typed_entry

        edges = np.array([0.0, 0.0, 1.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 1.0, -1.0, -1.0])
        ends = np.array([3], dtype=np.int64)
        fast = compiled(box_on_area, edges, ends, 0.3, 0.3, 0.0, 0.1, 0.1)
        _AREA = typed_entry(fast) or box_on_area
    return _AREA
