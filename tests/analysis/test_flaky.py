"""Runs-needed sizing and flip probabilities, checked against independent computations."""

from __future__ import annotations

import math
from itertools import product

import pytest

from sitcov.analysis._flaky import flakiness, flip_probability, runs_needed, zero_failure_runs
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace

Z95 = 1.959963984540054


def _reach_by_scan(p: float, z: float, margin: float) -> int:
    """Smallest n by brute force, from the Wilson bounds written as the roots of the
    quadratic (n + z^2) P^2 - (2 n p + z^2) P + n p^2 = 0 (a different formula): both
    bounds within ``margin`` of ``p``."""
    n = 1
    while True:
        a, b, c = n + z * z, -(2 * n * p + z * z), n * p * p
        disc = math.sqrt(max(0.0, b * b - 4 * a * c))
        lo, hi = max(0.0, (-b - disc) / (2 * a)), min(1.0, (-b + disc) / (2 * a))
        if max(p - lo, hi - p) <= margin + 1e-12:
            return n
        n += 1


@pytest.mark.parametrize(
    ("margin", "rate"),
    [(0.05, None), (0.1, None), (0.03, None), (0.05, 0.1), (0.1, 0.02), (0.05, 0.0), (0.02, 0.97)],
)
def test_runs_needed_matches_a_brute_force_scan(margin, rate):
    expected = _reach_by_scan(0.5 if rate is None else rate, Z95, margin)
    assert runs_needed(margin, rate) == expected


def test_a_zero_rate_needs_the_upper_bound_below_the_margin():
    # 0 failures in n runs: Wilson's upper bound is z^2 / (n + z^2); below 5 % from n = 73
    n = runs_needed(0.05, 0.0)
    assert n == 73
    assert Z95**2 / (n + Z95**2) <= 0.05 < Z95**2 / (n - 1 + Z95**2)


@pytest.mark.parametrize(("below", "conf"), [(0.05, 0.95), (0.01, 0.95), (0.1, 0.9), (0.001, 0.99)])
def test_zero_failure_runs_is_the_exact_binomial_minimum(below, conf):
    n = zero_failure_runs(below, conf)
    assert (1 - below) ** n <= 1 - conf < (1 - below) ** (n - 1)
    assert zero_failure_runs(0.05) == 59


def test_runs_needed_worst_case_closed_form():
    # at p = 0.5 the half-width is z / (2 sqrt(n + z^2)): n >= z^2 / (4 m^2) - z^2
    for margin in (0.2, 0.1, 0.05, 0.02):
        assert runs_needed(margin) == math.ceil(Z95**2 / (4 * margin**2) - Z95**2)
    assert runs_needed(0.05) == 381  # the number quoted in docs/generators.md


def test_runs_needed_grows_with_confidence_and_shrinks_with_rare_rates():
    assert runs_needed(0.05, confidence=0.99) > runs_needed(0.05) > runs_needed(0.05, 0.05)


@pytest.mark.parametrize(
    ("kwargs", "field"),
    [
        ({"margin": 0.0}, "--margin"),
        ({"margin": 0.05, "rate": 1.5}, "--rate"),
        ({"margin": 0.05, "confidence": 1.0}, "--confidence"),
    ],  # fmt: skip
)
def test_runs_needed_rejects_bad_input_naming_the_option(kwargs, field):
    with pytest.raises(ConfigError, match=field):
        runs_needed(**kwargs)


def test_flip_probability_is_unbiased_for_two_seeds_disagreeing():
    # E[2k(m-k)/(m(m-1))] over k ~ Binomial(m, p) equals 2p(1-p): exact enumeration
    for m, p in product((2, 3, 5), (0.1, 0.5, 0.8)):
        mean = sum(
            math.comb(m, k) * p**k * (1 - p) ** (m - k) * flip_probability(k, m)
            for k in range(m + 1)
        )
        assert mean == pytest.approx(2 * p * (1 - p))


def test_flakiness_groups_by_bin_and_ranks_situations():
    hs = load_hyperspace(None)
    stable = {el.name: el.labels[0] for el in hs.elements}
    flaky = {**stable, "friction": hs.element("friction").labels[-1]}
    data = [(stable, ["fail"] * 4)] * 5 + [(flaky, ["fail", "pass", "pass", "error"])] * 3
    table = flakiness(hs, data)
    assert table["overall"]["situations"] == 8 and table["overall"]["flaky"] == 3
    assert table["elements"]["friction"][flaky["friction"]]["flip"] == pytest.approx(2 / 3)
    assert table["elements"]["friction"][stable["friction"]]["flip"] == 0.0
    assert table["elements"]["friction"]["0.4"]["situations"] == 0
    assert [f["position"] for f in table["flakiest"]] == [5, 6, 7]
    assert table["repeats"] == 4


def test_explain_md_table_matches_the_calculator():
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "docs" / "explain.md").read_text()
    for margin, row in ((0.1, "| ±0.10 |"), (0.05, "| ±0.05 |"), (0.02, "| ±0.02 |")):
        line = next(x for x in text.splitlines() if x.startswith(row))
        cells = [int(c) for c in line.strip("|").split("|")[1:]]
        expected = [runs_needed(margin), runs_needed(margin, 0.1), runs_needed(margin, 0.02)]
        assert cells == [*expected, runs_needed(margin, 0.0)]
    assert "29 for 10 %, 59 for 5 %, 299 for 1 %" in " ".join(text.split())
    assert [zero_failure_runs(x) for x in (0.1, 0.05, 0.01)] == [29, 59, 299]
