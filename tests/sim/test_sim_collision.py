"""Oriented boxes: overlap and distance against shapely; time-to-collision golden values."""

from __future__ import annotations

import math

import numpy as np
import pytest
from shapely.geometry import Polygon

from sitcov.sim.embedded import box_distance, overlap, time_to_collision
from sitcov.sim.embedded._collision import contact_point, corners


def test_overlap_and_distance_agree_with_shapely() -> None:
    rng = np.random.default_rng(7)
    hits = 0
    for _ in range(400):
        a = (0.0, 0.0, float(rng.uniform(-math.pi, math.pi)), 2.25, 0.8)
        b = (
            float(rng.uniform(-8, 8)),
            float(rng.uniform(-8, 8)),
            float(rng.uniform(-math.pi, math.pi)),
            2.25,
            0.8,
        )
        pa, pb = Polygon(corners(a)), Polygon(corners(b))
        assert pa.area == pytest.approx(4.5 * 1.6)
        expected = pa.intersects(pb)
        assert overlap(a, b) == expected
        hits += expected
        assert box_distance(a, b) == pytest.approx(pa.distance(pb), abs=1e-9)
    assert 10 < hits < 390  # both cases were exercised


def test_time_to_collision() -> None:
    # head-on: 20 m apart, closing at 10 m/s, discs of total radius 4 m -> 1.6 s
    assert time_to_collision(20.0, 0.0, -10.0, 0.0, 4.0) == pytest.approx(1.6)
    assert time_to_collision(20.0, 0.0, 10.0, 0.0, 4.0) is None  # moving apart
    assert time_to_collision(20.0, 10.0, -10.0, 0.0, 4.0) is None  # passes by
    assert time_to_collision(3.0, 0.0, 0.0, 0.0, 4.0) == 0.0  # already touching


def test_contact_point_is_the_centroid_of_the_overlap_as_shapely_finds_it() -> None:
    """The collision map's point: the centroid of the two boxes' intersection."""
    rng = np.random.default_rng(8)
    checked = 0
    for _ in range(600):
        a = (0.0, 0.0, float(rng.uniform(-math.pi, math.pi)), 2.25, 0.8)
        b = (
            float(rng.uniform(-4, 4)),
            float(rng.uniform(-4, 4)),
            float(rng.uniform(-math.pi, math.pi)),
            float(rng.choice([2.25, 0.9, 0.25])),
            float(rng.choice([0.8, 0.3, 0.25])),
        )
        common = Polygon(corners(a)).intersection(Polygon(corners(b)))
        if common.area < 1e-6:
            continue
        x, y = contact_point(a, b)
        assert (x, y) == pytest.approx((common.centroid.x, common.centroid.y), abs=1e-9)
        checked += 1
    assert checked > 100
    # apart: the midpoint of the centres
    assert contact_point((0.0, 0.0, 0.0, 1.0, 1.0), (10.0, 4.0, 0.0, 1.0, 1.0)) == (5.0, 2.0)
