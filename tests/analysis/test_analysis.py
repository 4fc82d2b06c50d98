from __future__ import annotations

import json
import math
from dataclasses import dataclass

import pytest

from sitcov.analysis import (
    bin_stats,
    coverage,
    coverage_growth,
    summarize,
    uniformity,
    wilson_interval,
    worst_bins,
    worst_pairs,
)
from sitcov.hyperspace import Hyperspace, load_hyperspace


@dataclass
class Run:
    bins: dict
    status: str


TINY = {
    "name": "tiny",
    "axes": [
        {
            "name": "x",
            "elements": [
                {"name": "a", "bins": [{"value": "a0"}, {"value": "a1"}]},
                {"name": "b", "bins": [{"value": "b0"}, {"value": "b1"}]},
                {"name": "c", "bins": [{"value": "c0"}, {"value": "c1"}, {"value": "c2"}]},
            ],
        }
    ],
}


def run(a, b, c, status="pass"):
    return Run({"a": a, "b": b, "c": c}, status)


@pytest.mark.parametrize(
    ("k", "n", "lo", "hi"),
    [  # reference values of the Wilson score interval, z = 1.95996
        (0, 10, 0.0, 0.277532),
        (10, 10, 0.722468, 1.0),
        (5, 10, 0.236593, 0.763407),
        (1, 20, 0.008881, 0.236131),
        (30, 100, 0.218949, 0.395849),  # by hand: centre 0.307402, half-width 0.088453
    ],
)
def test_wilson_interval_known_values(k, n, lo, hi):
    got = wilson_interval(k, n)
    assert got == pytest.approx((lo, hi), abs=2e-6)


@pytest.mark.parametrize(("k", "n"), [(0, 1), (3, 7), (17, 40), (99, 100), (250, 1000)])
def test_wilson_interval_agrees_with_scipy(k, n):
    from scipy.stats import binomtest

    ref = binomtest(k, n).proportion_ci(confidence_level=0.95, method="wilson")
    assert wilson_interval(k, n) == pytest.approx((ref.low, ref.high), abs=1e-9)


def test_wilson_interval_edge_cases():
    assert wilson_interval(0, 0) is None
    with pytest.raises(ValueError):
        wilson_interval(3, 2)


def test_pairwise_coverage_by_hand():
    hs = Hyperspace.from_dict(TINY)
    runs = [run("a0", "b0", "c0"), run("a1", "b0", "c1"), run("a0", "b0", "c0", "fail")]
    cov = coverage(hs, runs)
    # pairs: ab 2x2 + ac 2x3 + bc 2x3 = 16; seen: (a0b0, a0c0, b0c0), (a1b0, a1c1, b0c1) = 6
    assert cov["pairs_total"] == 16 and cov["pairs_covered"] == 6
    assert cov["pairwise"] == pytest.approx(6 / 16)
    assert cov["bins_covered"] == 5 and cov["bins_total"] == 7


def test_forbidden_pairs_are_excluded_from_the_total():
    d = dict(TINY, constraints=[{"forbid": {"a": ["a1"], "c": ["c2"]}}])
    hs = Hyperspace.from_dict(d)
    assert coverage(hs, [])["pairs_total"] == 15


def test_bin_stats_counts_judged_runs_only():
    hs = Hyperspace.from_dict(TINY)
    runs = [
        run("a0", "b0", "c0", "fail"),
        run("a0", "b1", "c1", "pass"),
        run("a0", "b1", "c2", "error"),
        run("a0", "b1", "c2", "timeout"),
        run("a1", "b1", "c2", "pending"),
    ]
    a0 = bin_stats(hs, runs)["a"]["a0"]
    assert a0["generated"] == 4 and a0["failures"] == 1 and a0["judged"] == 2
    assert a0["failure_rate"] == 0.5 and a0["ci95"] == pytest.approx(list(wilson_interval(1, 2)))
    a1 = bin_stats(hs, runs)["a"]["a1"]
    assert a1["generated"] == 0 and a1["failure_rate"] is None and a1["ci95"] is None


def test_summary_has_the_design_shape_and_is_strict_json():
    hs = load_hyperspace()
    labels = {n: hs.labels(n)[0] for n in hs.element_names}
    runs = [
        Run(dict(labels), "fail"),
        Run(dict(labels), "pass"),
        Run(dict(labels), "error"),
        Run(dict(labels), "pending"),
        Run({**labels, "intsit": "nope"}, "pass"),
    ]
    s = json.loads(json.dumps(summarize(hs, runs), allow_nan=False))
    assert {"runs", "failures", "errors", "elements", "coverage"} <= set(s)
    assert (s["runs"], s["failures"], s["errors"], s["pending"], s["unmatched"]) == (4, 1, 1, 1, 1)
    assert set(s["elements"]) == set(hs.element_names)
    for name, per_bin in s["elements"].items():
        assert list(per_bin) == list(hs.labels(name))
        for stats in per_bin.values():
            assert {"generated", "failures", "failure_rate", "ci95"} <= set(stats)
    first = s["elements"]["intsit"]["IntSit-1"]
    assert first["generated"] == 3 and first["failure_rate"] == 0.5 and len(first["ci95"]) == 2
    assert s["coverage"]["bins_total"] == 60 and s["coverage"]["bins_covered"] == 9
    assert s["coverage"]["pairwise"] == pytest.approx(36 / 1584)
    assert s["uniformity"]["friction"]["max_min_ratio"] is None  # unused bins (min 0)
    assert s["uniformity"]["friction"]["min"] == 0


def test_uniformity():
    even = uniformity([5, 5, 5])
    assert even["max_min_ratio"] == 1.0 and even["entropy"] == pytest.approx(1.0)
    assert even["chi2_p"] == pytest.approx(1.0)
    assert uniformity([0, 5])["max_min_ratio"] == math.inf
    skewed = uniformity([100, 0, 0])
    assert skewed["entropy"] == pytest.approx(0.0) and skewed["chi2_p"] < 1e-10
    assert uniformity([0, 0])["entropy"] is None
    # entropy by hand: p = (1/4, 3/4) -> H / ln 2
    h = -(0.25 * math.log(0.25) + 0.75 * math.log(0.75)) / math.log(2)
    assert uniformity([1, 3])["entropy"] == pytest.approx(h)


def test_coverage_growth_is_monotone_and_ends_at_coverage():
    hs = Hyperspace.from_dict(TINY)
    runs = [
        run("a0", "b0", "c0"),
        run("a0", "b0", "c0"),
        run("a1", "b1", "c2"),
        run("a1", "b0", "c1"),
    ]
    growth = coverage_growth(hs, runs)
    assert [g["runs"] for g in growth] == [1, 2, 3, 4]
    assert [g["bins_covered"] for g in growth] == [3, 3, 6, 7]
    assert all(x["pairwise"] <= y["pairwise"] for x, y in zip(growth, growth[1:], strict=False))
    assert growth[-1]["pairwise"] == coverage(hs, runs)["pairwise"]


def test_worst_bins_rank_by_wilson_lower_bound():
    hs = Hyperspace.from_dict(TINY)
    runs = [run("a0", "b0", "c0", "fail") for _ in range(5)]  # 5/5 on a0, b0, c0
    runs += [run("a1", "b1", "c1", "fail") for _ in range(50)]
    runs += [run("a1", "b1", "c2", "pass") for _ in range(10)]  # a1: 50/60
    rows = worst_bins(hs, runs, min_judged=5, top=None)
    order = [(r["element"], r["label"]) for r in rows]
    # c1: 50/50 (lower 0.93) > a1, b1: 50/60 (0.72) > a0, b0, c0: 5/5 (0.57) > c2: 0/10
    assert order[0] == ("c", "c1")
    assert set(order[1:3]) == {("a", "a1"), ("b", "b1")}
    assert order[-1] == ("c", "c2")
    assert worst_bins(hs, runs, min_judged=6, top=None)[-1]["label"] == "c2"
    assert all(r["judged"] >= 6 for r in worst_bins(hs, runs, min_judged=6, top=None))
    pairs = worst_pairs(hs, runs, min_judged=5, top=2)
    assert pairs[0]["labels"] in {("a1", "c1"), ("b1", "c1")} and pairs[0]["failure_rate"] == 1.0
