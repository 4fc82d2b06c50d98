"""The report's drawing of an OpenDRIVE road (esmini campaigns), without esmini: the lanes
and lines sampled from sitcov's own reader, drawn in the right colours at the right
places, cropped to the view, parsed once per file; which road a stored run used."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from sitcov.errors import ConfigError
from sitcov.report._road import (
    GRASS,
    OTHER_LANE,
    ROAD,
    SIDEWALK,
    EmbeddedDrawing,
    OpenDriveDrawing,
    road_drawing,
    run_road,
    run_view,
)
from sitcov.roads import lane_outlines, read_opendrive
from sitcov.sim import Outcome, Trace

ROOT = Path(__file__).resolve().parents[2]

_LANE = (
    '<lane id="{id}" type="{type}" level="false">'
    '<width sOffset="0" a="{w}" b="0" c="0" d="0"/></lane>'
)


def _road(rid: str, x: float, y: float) -> str:
    right = "".join(
        _LANE.format(id=i, type=t, w=w)
        for i, t, w in ((-1, "driving", 3.5), (-2, "driving", 3.0), (-3, "sidewalk", 2.0))
    )
    left = "".join(
        _LANE.format(id=i, type=t, w=w) for i, t, w in ((2, "shoulder", 1.0), (1, "driving", 3.5))
    )
    return (
        f'<road name="r{rid}" length="100" id="{rid}" junction="-1"><planView>'
        f'<geometry s="0" x="{x}" y="{y}" hdg="0" length="100"><line/></geometry></planView>'
        f'<lanes><laneSection s="0"><left>{left}</left><center><lane id="0" type="none"/>'
        f"</center><right>{right}</right></laneSection></lanes></road>"
    )


@pytest.fixture
def xodr(tmp_path: Path) -> Path:
    """Two 100 m straight roads along x: one from (0, 0), one far away from (1000, 1000).
    Right of the reference line: driving 3.5 m, driving 3.0 m, sidewalk 2.0 m; left:
    driving 3.5 m, shoulder 1.0 m."""
    path = tmp_path / "two.xodr"
    path.write_text(
        '<?xml version="1.0"?><OpenDRIVE><header revMajor="1" revMinor="5"/>'
        + _road("1", 0.0, 0.0)
        + _road("2", 1000.0, 1000.0)
        + "</OpenDRIVE>"
    )
    return path


def _area(poly: np.ndarray) -> float:
    x, y = poly[:, 0], poly[:, 1]
    return 0.5 * abs(float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))))


def test_every_lane_is_a_polygon_of_its_width_and_the_lines_sit_between_lanes(xodr) -> None:
    lanes, borders = lane_outlines(read_opendrive(xodr))
    mine = {x.lane: x for x in lanes if x.road == "1"}
    assert {k: mine[k].type for k in mine} == {
        -1: "driving",
        -2: "driving",
        -3: "sidewalk",
        1: "driving",
        2: "shoulder",
    }
    widths = {-1: 3.5, -2: 3.0, -3: 2.0, 1: 3.5, 2: 1.0}
    for lid, lane in mine.items():
        assert _area(lane.polygon) == pytest.approx(100.0 * widths[lid], rel=1e-6)
    assert mine[-3].bbox == pytest.approx((0.0, -8.5, 100.0, -6.5))
    lines = {(b.kind, round(float(b.points[:, 1].mean()), 6)) for b in borders if b.road == "1"}
    # centre between the directions, a lane line between -1 and -2, the driving edges
    assert lines == {("centre", 0.0), ("lane", -3.5), ("edge", -6.5), ("edge", 3.5)}


def _pixels(drawing: OpenDriveDrawing, limits) -> np.ndarray:
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig = plt.figure(figsize=(4, 4), dpi=100)
    try:
        ax = fig.add_axes((0, 0, 1, 1))
        drawing.draw(ax, limits)
        ax.grid(False)  # another test's style may turn the grid on
        ax.set_xlim(*limits[0])
        ax.set_ylim(*limits[1])
        fig.canvas.draw()
        return np.asarray(fig.canvas.buffer_rgba())[:, :, :3].copy()
    finally:
        plt.close(fig)


def _rgb(colour: str) -> tuple[int, int, int]:
    return tuple(int(colour[i : i + 2], 16) for i in (1, 3, 5))


def test_the_drawing_puts_each_lane_type_in_its_colour_where_the_lane_is(xodr) -> None:
    """A 100 m x 100 m view on 400 px: pixel (row, col) of (x, y) is ((50 - y) * 4, 4x)."""
    image = _pixels(road_drawing(str(xodr)), ((0.0, 100.0), (-50.0, 50.0)))

    def at(x: float, y: float) -> tuple[int, int, int]:
        return tuple(int(v) for v in image[round((50 - y) * 4), round(x * 4)])

    assert at(50, -1.75) == _rgb(ROAD)  # driving lane -1
    assert at(50, -5.0) == _rgb(ROAD)  # driving lane -2
    assert at(50, 1.75) == _rgb(ROAD)  # driving lane 1
    assert at(50, -7.5) == _rgb(SIDEWALK)
    assert at(50, 4.0) == _rgb(OTHER_LANE)  # the shoulder
    assert at(50, 13.0) == _rgb(GRASS)
    assert at(50, -12.0) == _rgb(GRASS)


def test_only_the_lanes_near_the_view_are_drawn_and_a_file_is_parsed_once(xodr) -> None:
    drawing = road_drawing(str(xodr))
    assert isinstance(drawing, OpenDriveDrawing) and drawing.name == "two.xodr"
    lanes, borders = drawing.visible(((0.0, 100.0), (-50.0, 50.0)))
    assert {x.road for x in lanes} == {"1"} and {b.road for b in borders} == {"1"}
    lanes, _ = drawing.visible(((1040.0, 1060.0), (990.0, 1010.0)))
    assert {x.road for x in lanes} == {"2"}
    assert drawing.visible(((500.0, 520.0), (500.0, 520.0))) == ([], [])
    assert road_drawing(str(xodr)) is drawing  # cached per file
    os.utime(xodr, (1, 1))  # a new version of the file is read again
    assert road_drawing(str(xodr)) is not drawing


def test_a_missing_road_file_is_one_error_naming_it(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="gone.xodr"):
        road_drawing(str(tmp_path / "gone.xodr"))


def test_an_embedded_map_keeps_its_own_drawing() -> None:
    assert isinstance(road_drawing("t-junction"), EmbeddedDrawing)


def _trace(far: bool) -> Trace:
    ego = [(0.1 * k, 10.0 + k, -1.75, 0.0, 10.0) for k in range(60)]
    near = [(0.1 * k, 50.0, -20.0 + 0.3 * k, 1.57, 3.0) for k in range(60)]
    away = [(0.1 * k, 95.0 + (300.0 if far else 0.0), 1.75, 3.14, 14.0) for k in range(60)]
    return Trace(
        ego=ego,
        ov=near,
        actors={"Crossing": near, "Oncoming": away},
        meta={"ego_route": [[10.0, -1.75], [90.0, -1.75]], "length": 4.5, "width": 1.8},
    )


def test_the_view_holds_the_ego_and_who_came_near_not_a_car_far_away() -> None:
    (x0, x1), (y0, y1) = run_view(_trace(far=True))
    assert x0 <= 10.0 and x1 >= 90.0 and y0 <= -20.0  # the ego's path, the crossing car
    assert x1 < 150.0  # the oncoming car 300 m on is left out
    (x0, x1), (y0, y1) = run_view(_trace(far=False))
    assert x1 >= 95.0  # ... and in when it comes near
    assert x1 - x0 == pytest.approx(y1 - y0)


def test_a_picture_of_a_run_on_an_opendrive_road(xodr, tmp_path: Path) -> None:
    from PIL import Image

    from sitcov.sim.embedded._render import drawn_actors, render_topdown

    trace = _trace(far=True)
    # the primary OV is one of esmini's named entities: drawn once, under its name
    assert [a["name"] for a in drawn_actors(trace, trace.meta)] == ["ego", "Crossing", "Oncoming"]
    outcome = Outcome(
        status="fail",
        end_reason="collision",
        collision=True,
        metrics={"collision_point": [50.0, -1.0]},
        trace=trace,
    )
    out = render_topdown(outcome, tmp_path / "run.png", road_drawing(str(xodr)))
    image = np.asarray(Image.open(out).convert("RGB")).reshape(-1, 3)
    share = {c: float(np.mean(np.all(image == _rgb(c), axis=1))) for c in (ROAD, SIDEWALK)}
    assert share[ROAD] > 0.02 and share[SIDEWALK] > 0.005


def test_which_road_a_stored_run_used(tmp_path: Path) -> None:
    crossing = ROOT / "examples" / "esmini" / "crossing.xosc"
    straight = (ROOT / "examples" / "esmini" / "straight.xodr").resolve()
    own = {"backend": "esmini", "backend_options": {"scenario": str(crossing)}}
    assert Path(run_road(own)).resolve() == straight  # the scenario's LogicFile
    given = {"backend": "esmini", "backend_options": {"scenario": str(crossing), "road": "/r.xodr"}}
    assert run_road(given) == "/r.xodr"
    folder = {"backend": "esmini", "backend_options": {"scenario": str(crossing.parent)}}
    assert Path(run_road(folder, None, {"scenario": "crossing"})).resolve() == straight
    # sitcov's own situations without --road: the embedded map whose export esmini played
    export = {"map": "/tmp/gone/t-junction.xodr"}
    assert run_road({"backend": "esmini", "backend_options": {"map": "x-junction"}}, export) == (
        "x-junction"
    )
    assert run_road({"backend": "esmini"}, export) == "t-junction"
    assert run_road({"backend": "embedded"}, {"map": "x-junction"}) == "x-junction"
    assert run_road({"backend_options": {"map": "y-junction"}}) == "y-junction"
