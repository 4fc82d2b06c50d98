"""Plane geometry shared by the map builder and the renderer."""

from __future__ import annotations

from collections.abc import Sequence


def convex_hull(points: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """Convex hull (Andrew's monotone chain), counter-clockwise, no repeated end point.

    Collinear points are dropped. The cross product is written out in the loops (no
    helper call per point): the renderer takes a few dozen hulls per pedestrian per frame.
    """
    pts = sorted(set(points))
    if len(pts) <= 2:
        return list(pts)
    return _chain(pts)[:-1] + _chain(pts[::-1])[:-1]


def _chain(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """One half of the monotone chain: the points kept turning left, in order."""
    out: list[tuple[float, float]] = []
    for p in pts:
        px, py = p
        while len(out) >= 2:
            (ox, oy), (ax, ay) = out[-2], out[-1]
            if (ax - ox) * (py - oy) - (ay - oy) * (px - ox) > 0:
                break
            out.pop()
        out.append(p)
    return out
