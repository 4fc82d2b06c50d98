"""sitcov._geometry: the convex hull shared by the map builder and the renderer."""

from __future__ import annotations

import numpy as np

from sitcov._geometry import convex_hull


def _is_left_turn_chain(hull: list[tuple[float, float]]) -> bool:
    n = len(hull)
    for i in range(n):
        (ox, oy), (ax, ay), (bx, by) = hull[i], hull[(i + 1) % n], hull[(i + 2) % n]
        if (ax - ox) * (by - oy) - (ay - oy) * (bx - ox) <= 0:
            return False
    return True


def test_square_with_interior_duplicate_and_collinear_points() -> None:
    pts = [(0.0, 0.0), (2.0, 0.0), (1.0, 0.0), (2.0, 2.0), (0.0, 2.0), (1.0, 1.0), (2.0, 2.0)]
    assert convex_hull(pts) == [(0.0, 0.0), (2.0, 0.0), (2.0, 2.0), (0.0, 2.0)]


def test_degenerate_inputs() -> None:
    assert convex_hull([]) == []
    assert convex_hull([(1.0, 1.0), (1.0, 1.0)]) == [(1.0, 1.0)]
    assert convex_hull([(0.0, 0.0), (1.0, 1.0), (2.0, 2.0)]) == [(0.0, 0.0), (2.0, 2.0)]


def test_random_hulls_are_convex_and_contain_every_point() -> None:
    rng = np.random.default_rng(0)
    for _ in range(200):
        pts = [tuple(p) for p in rng.uniform(-5, 5, (rng.integers(3, 40), 2)).tolist()]
        hull = convex_hull(pts)
        assert hull[0] == min(pts) and _is_left_turn_chain(hull)
        for px, py in pts:  # every point on the inner side of (or on) every edge
            for (ox, oy), (ax, ay) in zip(hull, hull[1:] + hull[:1], strict=True):
                assert (ax - ox) * (py - oy) - (ay - oy) * (px - ox) >= -1e-9
