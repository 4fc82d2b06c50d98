"""The report's criticality measures: the smallest over every road user of a run."""

from __future__ import annotations

from types import SimpleNamespace

from sitcov.report._criticality_section import NEAR_TTC, run_measures
from sitcov.sim import Outcome


def _run(metrics, **fields):
    return SimpleNamespace(
        outcome=Outcome(status="pass", end_reason="goal", metrics=metrics, **fields)
    )


def test_the_closest_road_user_decides_not_the_primary_one():
    run = _run(
        {
            "actors": {
                "ov": {"kind": "car", "min_ttc": 6.0, "pet": 4.0, "min_distance": 12.0},
                "actor2": {"kind": "pedestrian", "min_ttc": 0.4, "pet": None, "min_distance": 0.7},
            }
        },
        min_ttc=6.0,
        pet=4.0,
        min_distance=12.0,
    )
    m = run_measures(run)
    assert (m["min_ttc"], m["pet"], m["min_distance"]) == (0.4, 4.0, 0.7)
    assert m["actor"] == "actor2 (pedestrian)"
    assert m["min_ttc"] < NEAR_TTC  # a near miss although the OV stayed 12 m away


def test_a_two_car_run_without_actor_metrics_uses_the_outcome():
    m = run_measures(_run({}, min_ttc=2.5, pet=float("inf"), min_distance=3.0))
    assert (m["min_ttc"], m["pet"], m["min_distance"]) == (2.5, None, 3.0)
    assert m["actor"] == "ov (car)"


def test_drac_is_the_largest_over_the_road_users_and_the_run_fact_without_actors():
    run = _run(
        {
            "max_drac": 9.0,
            "actors": {
                "ov": {"kind": "car", "min_ttc": 6.0, "max_drac": 0.5},
                "actor2": {"kind": "cyclist", "min_ttc": 0.8, "max_drac": 9.0},
                "actor3": {"kind": "pedestrian", "max_drac": None},
            },
        }
    )
    assert run_measures(run)["max_drac"] == 9.0
    assert run_measures(_run({"max_drac": 2.5}, min_ttc=1.0))["max_drac"] == 2.5
    assert run_measures(_run({}, min_ttc=1.0))["max_drac"] is None  # stored before DRAC


def _collided(point, kind, status="fail", **metrics):
    outcome = Outcome(
        status=status,
        end_reason="collision",
        collision=True,
        metrics={"collision_point": point, "collision_kind": kind, **metrics},
    )
    return SimpleNamespace(outcome=outcome, status=status)


def test_collision_points_are_read_with_kind_and_verdict_and_old_runs_counted_apart(tmp_path):
    from sitcov.report._collision_map import (
        campaign_map,
        collision_figure,
        collision_map_section,
        collision_point,
    )

    assert campaign_map({}) == "t-junction"
    assert campaign_map({"backend_options": {"map": "roundabout"}}) == "roundabout"
    p = collision_point(_collided([1.5, -2.0], "pedestrian", status="pass"), "crossroads")
    assert (p.map, p.x, p.y, p.kind, p.failed) == ("crossroads", 1.5, -2.0, "pedestrian", False)
    assert collision_point(_collided([0.0, 1.0], None), "cross").kind == "car"  # two-car run
    assert collision_point(_collided(None, "car"), "cross") is False  # stored before schema 5
    no_hit = SimpleNamespace(outcome=Outcome(status="pass", end_reason="goal"), status="pass")
    assert collision_point(no_hit, "cross") is None

    rng = __import__("numpy").random.default_rng(0)
    points = [
        collision_point(
            _collided([float(x), float(y)], kind, status="fail" if i % 5 else "pass"), m
        )
        for i, (x, y, kind, m) in enumerate(
            (*rng.uniform(-15, 15, 2), k, m)
            for k in ("car", "cyclist", "pedestrian")
            for m in ("crossroads", "roundabout")
            for _ in range(20)
        )
    ]
    figure = collision_figure(points)
    panels = [ax for ax in figure.axes if ax.get_visible()]
    assert [ax.get_title().split(":")[0] for ax in panels] == ["crossroads", "roundabout"]
    assert all(len(ax.collections) == 6 for ax in panels)  # 3 kinds x failed / not
    legend = [t.get_text() for t in figure.legends[0].get_texts()]
    assert "car, failure (32)" in legend and "pedestrian, not a failure (8)" in legend
    __import__("matplotlib.pyplot").pyplot.close(figure)
    page = collision_map_section(points, 3, tmp_path)["collision_map"]
    assert page["png"] and (tmp_path / "collision_map.png").stat().st_size > 10_000
    assert page["caption"].startswith("120 collisions drawn (40 with a car")
    assert "96 count as failures" in page["caption"]
    assert "3 collisions were stored without a location" in page["caption"]
    assert collision_map_section([], 0, tmp_path) == {"collision_map": None}
