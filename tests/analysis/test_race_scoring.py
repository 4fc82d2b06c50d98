"""Scoring the generator race: regions from a reference campaign, per-campaign metrics."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from sitcov.analysis._race import campaign_metrics, mean_ci, race_table, reference_regions
from sitcov.hyperspace import load_hyperspace

HS = load_hyperspace(None)


def run(status: str, **bins: str) -> SimpleNamespace:
    full = {el.name: el.labels[-1] for el in HS.elements}
    full.update(bins)
    return SimpleNamespace(status=status, bins=full)


def planted_reference(n: int = 3000, seed: int = 0) -> list[SimpleNamespace]:
    """Uniform situations; fails 95 % at friction 0.1, 90 % at IntSit-5, 3 % elsewhere."""
    rng = np.random.default_rng(seed)
    runs = []
    for _ in range(n):
        bins = {el.name: el.labels[rng.integers(len(el.labels))] for el in HS.elements}
        p = 0.95 if bins["friction"] == "0.1" else 0.9 if bins["intsit"] == "IntSit-5" else 0.03
        runs.append(SimpleNamespace(status="fail" if rng.random() < p else "pass", bins=bins))
    return runs


def test_reference_regions_are_the_planted_boxes():
    regions = reference_regions(HS, planted_reference())
    assert regions and all(r["rate"] >= 0.5 for r in regions)
    for r in regions:  # every region lies inside one of the two planted weaknesses
        conds = {c["element"]: c["bins"] for c in r["conditions"]}
        assert conds.get("friction") == ["0.1"] or conds.get("intsit") == ["IntSit-5"]
    covered = sum(r["failures"] for r in regions)
    # the planted failures: 1/6 * 0.95 + 5/6 * 1/12 * 0.9 of 3000 ~ 663; regions hold most
    assert covered >= 0.85 * 663


def test_campaign_metrics_by_hand():
    region = {"conditions": [{"element": "friction", "bins": ["0.1"]}]}
    other = {"conditions": [{"element": "intsit", "bins": ["IntSit-5"]}]}
    runs = [
        run("pass", friction="0.1"),
        run("fail", friction="0.2"),  # a failure outside both regions
        run("fail", friction="0.1"),  # first failure of region 1: run 3
        run("error", intsit="IntSit-5"),
        run("fail", friction="0.1"),
    ]
    m = campaign_metrics(HS, runs, [region, other], checkpoints=(2, 4, 10))
    assert m["failures"] == 3 and m["errors"] == 1 and m["regions_found"] == 1
    assert m["first_failure"] == [3, None]
    assert m["mean_runs_to_region"] == pytest.approx((3 + 5) / 2)  # censored at 5 runs
    assert m["regions_at"] == {"2": 0, "4": 1}
    # after 2 runs: 8 elements with one bin each, friction with two
    assert m["bins_at"]["2"] == 10
    total_pairs = sum(HS.sizes[a] * HS.sizes[b] for a in range(9) for b in range(a + 1, 9))
    assert m["pairs_at"]["2"] == pytest.approx((28 + 2 * 8) / total_pairs)


def test_evenness_is_one_for_even_counts_and_lower_otherwise():
    even = [run("pass", friction=f) for f in HS.element("friction").labels]
    skew = [run("pass", friction="0.1")] * 6
    m_even = campaign_metrics(HS, even, [])
    m_skew = campaign_metrics(HS, skew, [])
    # friction even (1.0), the other 8 elements a single bin (0.0): mean 1/9
    assert m_even["evenness"] == pytest.approx(1 / 9)
    assert m_skew["evenness"] == pytest.approx(0.0)


def test_mean_ci_and_paired_difference():
    ci = mean_ci([1.0, 2.0, 6.0])
    half = 4.302652729911275 * np.std([1, 2, 6], ddof=1) / np.sqrt(3)  # t(0.975, 2)
    assert ci["mean"] == pytest.approx(3.0) and ci["ci95"] == pytest.approx([3 - half, 3 + half])
    assert mean_ci([2.0])["ci95"] is None and mean_ci([])["mean"] is None
    per = {
        "random": [{"regions_found": 2}, {"regions_found": 3}],
        "x": [{"regions_found": 4}, {"regions_found": 6}],
    }
    table = race_table(per)
    assert table["x"]["regions"]["mean"] == 5.0
    assert table["x"]["regions"]["vs_random"]["mean"] == pytest.approx(2.5)
    assert "vs_random" not in table["random"]["regions"]
