"""The OpenDRIVE reader without esmini: geometry properties and error messages."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from sitcov.errors import ConfigError
from sitcov.roads import Arc, ParamPoly3, Spiral, poly3, read_opendrive
from tests.roads._shared import DATA


@pytest.mark.parametrize(
    "geometry",
    [
        Arc(0, 1, 2, 0.3, 40, curvature=-0.05),
        Spiral(0, 0, 0, 0, 60, curv_start=0.03, curv_end=-0.02),
        Spiral(0, 0, 0, 1, 30, curv_start=0.0, curv_end=0.04),
        poly3(0, 0, 0, 0, 30, 0.5, 0.1, 0.004, -0.0001),
        ParamPoly3(0, 0, 0, 0, 30, (0, 29, 1, 0), (0, 0, 4, -1), 1.0),
    ],
    ids=["arc", "spiral", "clothoid", "poly3", "paramPoly3"],
)
def test_records_are_arc_length_parametrised_with_tangent_headings(geometry) -> None:
    ds = np.linspace(0.0, geometry.length, 3001)
    x, y, h = geometry.evaluate(ds)
    step = np.hypot(np.diff(x), np.diff(y))
    # equal steps (a paramPoly3 whose own length differs from the record's is stretched)
    assert np.allclose(step, step.mean(), rtol=2e-3)
    assert step.mean() == pytest.approx(ds[1] - ds[0], rel=0.01)
    chord = np.arctan2(np.diff(y), np.diff(x))
    mid = 0.5 * (h[1:] + h[:-1])
    assert np.abs(np.angle(np.exp(1j * (chord - mid)))).max() < 1e-3


def test_spiral_curvature_changes_linearly() -> None:
    g = Spiral(0, 0, 0, 0, 50, curv_start=0.02, curv_end=-0.03)
    ds = np.linspace(0, 50, 501)
    _, _, h = g.evaluate(ds)
    k = np.gradient(h, ds)
    assert np.allclose(k[5:-5], 0.02 - 0.05 * ds[5:-5] / 50, atol=1e-6)


def test_lanes_junctions_and_crosswalks_are_read() -> None:
    net = read_opendrive(DATA / "t-junction.xodr")
    assert set(net.junctions) == {"100"}
    assert len(net.junctions["100"].connections) == 6
    east = net.roads["2"]
    assert east.predecessor is not None and east.predecessor.element_type == "junction"
    assert {lane.type for lane in east.sections[0].lanes.values()} >= {"driving", "sidewalk"}
    inner, outer = east.borders(0, -2, np.array([5.0]))
    assert inner[0] == pytest.approx(-3.5) and outer[0] == pytest.approx(-5.5)
    outlines = [cw.outline for road in net.roads.values() for cw in road.crosswalks]
    assert len(outlines) == 3
    for outline in outlines:  # 3 m along the road, 11 m across it
        sides = sorted(
            round(float(np.hypot(b[0] - a[0], b[1] - a[1])), 6)
            for a, b in zip(outline, outline[1:] + outline[:1], strict=True)
        )
        assert sides == pytest.approx([3.0, 3.0, 11.0, 11.0])


def test_lane_types_of_the_geometry_file() -> None:
    road = read_opendrive(DATA / "geometries.xodr").roads["1"]
    types = {lane.type for sec in road.sections for lane in sec.lanes.values()}
    assert types >= {"driving", "biking", "shoulder", "sidewalk"}


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            "<OpenDRIVE><road id='7' length='x'/></OpenDRIVE>",
            "road[id=7]@length: expected a finite number",
        ),
        (
            "<OpenDRIVE><road id='7' length='10'><planView/></road></OpenDRIVE>",
            "road[id=7]/planView",
        ),
        (
            "<OpenDRIVE><road id='7' length='10'><planView><geometry s='0' x='0' y='0' hdg='0' "
            "length='10'><clothoid/></geometry></planView></road></OpenDRIVE>",
            "road[id=7]/planView/geometry[0]/clothoid",
        ),
        ("<notOpenDRIVE/>", "(root element)"),
        ("<OpenDRIVE>", "not valid XML"),
    ],
)
def test_bad_files_name_the_file_and_the_element(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "bad.xodr"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        read_opendrive(path)
    assert str(err.value).startswith(str(path))
    assert message in str(err.value)
    assert "\n" not in str(err.value)


def test_missing_file_is_one_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="readable file"):
        read_opendrive(tmp_path / "nope.xodr")
