"""The OpenDRIVE writer: arc splines through the given points, valid files, a clean layer."""

from __future__ import annotations

import math

import numpy as np
from layering import SITCOV, imported_names

from sitcov.roads import LaneSpec, NetworkSpec, RoadSpec, arc_spline, piece_end, xodr_text


def _raw_ends(points, heading=None):
    pieces = arc_spline(points, heading)
    ends = [piece_end(p) for p in pieces]
    return pieces, ends


def test_arc_spline_reproduces_lines_and_arcs_exactly():
    # 20 m straight, a quarter circle of radius 10 m to the left, 15 m straight
    pts = [(float(x), 0.0) for x in range(21)]
    pts += [
        (20 + 10 * math.sin(a), 10 - 10 * math.cos(a)) for a in np.linspace(0, math.pi / 2, 17)[1:]
    ]
    pts += [(30.0, 10.0 + y) for y in range(1, 16)]
    pieces, ends = _raw_ends(pts)
    assert [round(p.curvature, 6) for p in pieces] == [0.0, 0.1, 0.0]
    assert math.isclose(pieces[0].length, 20.0, abs_tol=1e-9)
    assert math.isclose(pieces[1].length, 0.5 * math.pi * 10.0, rel_tol=1e-9)
    x, y, h = ends[-1]
    assert math.dist((x, y), (30.0, 25.0)) < 1e-6 and math.isclose(h, math.pi / 2, abs_tol=1e-9)


def test_arc_spline_is_tangent_continuous_and_hits_every_point(rng):
    # a random wiggly polyline: without merging, piece k ends on point k+1
    pts = [(0.0, 0.0)]
    h = 0.0
    for _ in range(40):
        h += float(rng.uniform(-0.3, 0.3))
        pts.append((pts[-1][0] + math.cos(h), pts[-1][1] + math.sin(h)))
    pieces = arc_spline(pts, 0.0)
    for a, b in zip(pieces, pieces[1:], strict=False):
        x, y, hh = piece_end(a)
        assert math.dist((x, y), (b.x, b.y)) < 1e-6
        assert abs(math.atan2(math.sin(hh - b.hdg), math.cos(hh - b.hdg))) < 1e-6
        assert math.isclose(a.s + a.length, b.s, abs_tol=1e-9)
    assert math.dist(piece_end(pieces[-1])[:2], pts[-1]) < 1e-3


def test_document_lists_roads_lanes_and_offsets():
    road = RoadSpec(7, ((0.0, 0.0), (10.0, 0.0)), (LaneSpec(-1, 3.5), LaneSpec(2, 2.0, "sidewalk")),
                lane_offset=1.75)  # fmt: skip
    text = xodr_text(NetworkSpec("n", (road,)))
    assert '<road name="7" length="10" id="7" junction="-1">' in text
    assert '<laneOffset s="0" a="1.75"' in text
    assert 'lane id="2" type="sidewalk"' in text and 'lane id="-1" type="driving"' in text
    assert xodr_text(NetworkSpec("n", (road,))) == text  # deterministic


def test_road_layer_imports_nothing_from_above():
    layers = [
        "sim",
        "av",
        "campaign",
        "analysis",
        "report",
        "generation",
        "hyperspace",
        "perception",
        "cli",
    ]
    above = tuple(f"sitcov.{name}" for name in layers)
    for path in (SITCOV / "roads").glob("*.py"):
        bad = [n for n in imported_names(path) if n.startswith(above) or n == "sitcov"]
        assert bad == [], f"{path.name} imports {bad}"
