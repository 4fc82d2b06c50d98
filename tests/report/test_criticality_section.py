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
