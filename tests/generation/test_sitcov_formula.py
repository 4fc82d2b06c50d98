"""The `sitcov` generator follows the paper's formula: checked with our own arithmetic."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy import stats

from sitcov.generation import generate, make_generator, sitcov_probabilities
from sitcov.generation._sitcov import _draw


def paper_probabilities(counts):
    """softmax -> 1 - m -> normalise, written out independently (no numpy, no shift)."""
    shift = max(counts)  # only to avoid overflow; softmax is shift-invariant
    z = [math.exp(c - shift) for c in counts]
    m = [x / sum(z) for x in z]
    w = [1 - x for x in m]
    return [x / sum(w) for x in w]


@pytest.mark.parametrize(
    "counts",
    [[0] * 6, [0, 1, 2, 3, 4, 5], [7, 7, 8, 7, 7, 9], [1000, 1001, 999], [3, 0], list(range(12))],
)
def test_probabilities_match_independent_computation(counts):
    p = sitcov_probabilities(counts)
    assert np.allclose(p, paper_probabilities(counts), rtol=0, atol=1e-12)
    assert p.sum() == pytest.approx(1.0)
    assert (p <= 1 / (len(counts) - 1) + 1e-12).all()  # the weak push: p_i <= 1/(n-1)


def test_single_bin_and_hopeless_bin():
    assert sitcov_probabilities([5]).tolist() == [1.0]
    rng = np.random.default_rng(0)
    # counts 0 vs 1000: m = (0, 1) up to 1e-434, so the used bin has p == 0 exactly
    assert all(_draw([0, 1000], u) == 0 for u in rng.random(2000).tolist())
    assert _draw([0, 1000], 0.999999999999) == 0


def test_draws_from_fixed_counts_follow_the_formula():
    counts = [0, 1, 2, 3, 0, 5]
    rng = np.random.default_rng(7)
    n = 30_000
    picks = np.bincount([_draw(counts, u) for u in rng.random(n).tolist()], minlength=6)
    expected = np.asarray(paper_probabilities(counts)) * n
    assert stats.chisquare(picks, expected).pvalue > 1e-3
    assert picks[5] == picks.min() and picks[5] / n < 0.05  # the most-used bin: p = 0.036


def test_replayed_draws_are_calibrated(default_hs):
    """Replay `sitcov generate`: recompute each draw's probabilities from the counts so far
    (our code), then check (a) observed vs expected picks per bin, (b) randomised PIT ~ U(0,1)."""
    gen = make_generator("sitcov", default_hs)
    situations = list(generate(gen, 600, seed=11))
    names = default_hs.element_names
    counts = {n: dict.fromkeys(default_hs.labels(n), 0) for n in names}
    observed = {n: dict.fromkeys(default_hs.labels(n), 0) for n in names}
    expected = {n: dict.fromkeys(default_hs.labels(n), 0.0) for n in names}
    variance = {n: dict.fromkeys(default_hs.labels(n), 0.0) for n in names}
    pit = []
    jitter = np.random.default_rng(99)
    for s in situations:
        for name in names:
            labels = default_hs.labels(name)
            p = paper_probabilities([counts[name][x] for x in labels])
            chosen = labels.index(s.bins[name])
            assert p[chosen] > 0
            for x, px in zip(labels, p, strict=False):
                expected[name][x] += px
                variance[name][x] += px * (1 - px)
            observed[name][s.bins[name]] += 1
            pit.append(sum(p[:chosen]) + jitter.random() * p[chosen])
            counts[name][s.bins[name]] += 1  # incremented at selection
    assert gen.counts == [list(counts[n].values()) for n in names]  # never reset
    z = [
        (observed[n][x] - expected[n][x]) / math.sqrt(variance[n][x])
        for n in names
        for x in default_hs.labels(n)
    ]
    assert max(abs(v) for v in z) < 4.5
    assert stats.kstest(pit, "uniform").pvalue > 1e-3


def test_counts_stay_within_a_few_of_each_other(default_hs):
    gen = make_generator("sitcov", default_hs)
    list(generate(gen, 1200, seed=2))
    for c in gen.counts:
        assert sum(c) == 1200
        assert max(c) - min(c) <= 12
