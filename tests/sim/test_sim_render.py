"""Top-down pictures draw every actor: its trajectory, an outline by kind and a legend entry."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitcov.sim import Trace
from sitcov.sim.embedded._render import (
    EGO_COLOR,
    KIND_COLORS,
    drawn_actors,
    outline,
    render_topdown,
)


def _rows(x0: float, y0: float, heading: float, n: int = 20) -> list[tuple]:
    return [
        (0.1 * i, x0 + i * math.cos(heading), y0 + i * math.sin(heading), heading, 1.0)
        for i in range(n)
    ]


def _trace() -> Trace:
    actors = {
        "ov": _rows(20.0, 2.0, math.pi),
        "actor2": _rows(-3.0, -8.0, math.pi / 2),
        "actor3": _rows(8.0, -10.0, math.pi / 2),
        "actor10": _rows(-20.0, -2.0, 0.0),
    }
    meta = {
        "map": "crossroads",
        "length": 4.5,
        "width": 1.6,
        "actors": {
            "ov": {"kind": "car", "length": 4.5, "width": 1.6, "route": [[20, 2], [-20, 2]]},
            "actor2": {"kind": "pedestrian", "length": 0.5, "width": 0.5, "route": []},
            "actor3": {"kind": "cyclist", "length": 1.8, "width": 0.6, "route": []},
            "actor10": {"kind": "car", "length": 4.5, "width": 1.6, "route": []},
        },
    }
    return Trace(ego=_rows(0.0, -30.0, math.pi / 2), ov=actors["ov"], meta=meta, actors=actors)


def test_every_actor_is_drawn_in_slot_order_with_its_kind():
    drawn = drawn_actors(_trace(), _trace().meta)
    assert [a["name"] for a in drawn] == ["ego", "ov", "actor2", "actor3", "actor10"]
    assert [a["label"] for a in drawn] == [
        "ego (car)",
        "OV (car)",
        "actor2 (pedestrian)",
        "actor3 (cyclist)",
        "actor10 (car)",
    ]
    colors = [a["color"] for a in drawn]
    assert colors[0] == EGO_COLOR and len(set(colors)) == len(colors)
    assert colors[2] in KIND_COLORS["pedestrian"] and colors[3] in KIND_COLORS["cyclist"]
    assert all(len(a["rows"]) == 20 for a in drawn)


def test_an_old_trace_without_actors_draws_ego_and_ov():
    old = Trace(ego=_rows(0, 0, 0), ov=_rows(5, 5, 1), meta={})
    assert [a["label"] for a in drawn_actors(old, {})] == ["ego (car)", "OV (car)"]


@pytest.mark.parametrize(
    ("kind", "length", "width", "corners"), [("car", 4.5, 1.6, 4), ("cyclist", 1.8, 0.6, 5)]
)
def test_outlines_fit_the_body_and_point_forward(kind, length, width, corners):
    row = (0.0, 3.0, -2.0, 0.7, 1.0)
    pts = np.array(outline(kind, row, length, width))
    assert len(pts) == corners
    local = (pts - [3.0, -2.0]) @ np.array(
        [[math.cos(0.7), -math.sin(0.7)], [math.sin(0.7), math.cos(0.7)]]
    )
    assert np.abs(local[:, 0]).max() == pytest.approx(0.5 * length)
    assert np.abs(local[:, 1]).max() == pytest.approx(0.5 * width)
    if kind == "cyclist":  # a single point at the front: the heading is visible
        assert np.sum(np.isclose(local[:, 0], 0.5 * length)) == 1


def test_a_pedestrian_is_a_disc():
    pts = np.array(outline("pedestrian", (0.0, 1.0, 1.0, 0.3, 1.0), 0.5, 0.5))
    assert len(pts) >= 12
    assert np.hypot(pts[:, 0] - 1.0, pts[:, 1] - 1.0) == pytest.approx(np.full(len(pts), 0.25))


def test_the_picture_has_a_legend_entry_per_actor(tmp_path, monkeypatch):
    import matplotlib.figure

    seen: list[list[str]] = []
    save = matplotlib.figure.Figure.savefig

    def spy(fig, *args, **kwargs):
        legend = fig.axes[0].get_legend()
        seen.append([t.get_text() for t in legend.get_texts()])
        return save(fig, *args, **kwargs)

    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", spy)
    path = render_topdown(_trace(), tmp_path / "t.png")
    assert path.read_bytes()[:4] == b"\x89PNG"
    assert seen == [
        ["ego (car)", "OV (car)", "actor2 (pedestrian)", "actor3 (cyclist)", "actor10 (car)"]
    ]
