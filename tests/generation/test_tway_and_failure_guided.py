from __future__ import annotations

import numpy as np
import pytest

from sitcov.analysis import coverage, coverage_growth
from sitcov.generation import generate, make_generator
from sitcov.generation._tway import covering_array


def rows_of(situations):
    return [{"bins": s.bins, "status": "pass"} for s in situations]


def test_tway_reaches_full_pairwise_coverage_with_the_array(default_hs):
    gen = make_generator("tway", default_hs, seed=0)
    situations = list(generate(gen, 150, seed=0))
    size = gen.array_size
    growth = coverage_growth(default_hs, rows_of(situations))
    first_full = next(g["runs"] for g in growth if g["pairwise"] == 1.0)
    assert first_full == size
    assert 72 <= size <= 110  # lower bound 12 * 6; covertable's greedy lands in the 80s-90s


def test_tway_with_constraints_covers_every_allowed_pair(constrained_hs):
    gen = make_generator("tway", constrained_hs, seed=1)
    situations = list(generate(gen, 120, seed=1))
    cov = coverage(constrained_hs, rows_of(situations[: gen.array_size]))
    assert cov["pairwise"] == 1.0 and cov["pairs_total"] < 1584


def test_covering_array_is_deterministic_for_a_salt(default_hs):
    assert covering_array(default_hs, 2, "7") == covering_array(default_hs, 2, "7")
    assert covering_array(default_hs, 2, "7") != covering_array(default_hs, 2, "8")


def test_tway_continues_with_least_covered_pairs(default_hs):
    """After the array, each new situation should hit far more of the least-seen pairs than
    a random situation would."""
    gen = make_generator("tway", default_hs, seed=2)
    rng = np.random.default_rng(5)
    for _ in range(120):
        gen.ask(rng)
    random_gen = make_generator("random", default_hs)
    combos = gen.combos
    hits_greedy, hits_random = [], []
    for _ in range(30):
        level = gen._level()
        for source, out in ((random_gen, hits_random), (gen, hits_greedy)):
            before = {k: list(v) for k, v in combos.table.items()}
            idx = default_hs._indices(source.ask(rng).bins)
            out.append(
                sum(1 for sub in combos.subsets if before[sub][combos.flat(sub, idx)] == level)
            )
    assert np.mean(hits_greedy) > 1.5 * np.mean(hits_random)


def test_failure_guided_prefers_failing_bins_but_keeps_a_floor(default_hs):
    gen = make_generator("failure-guided", default_hs, epsilon=0.1, floor=3)
    assert gen.learns
    rng = np.random.default_rng(0)
    for _ in range(600):
        s = gen.ask(rng)
        fail = s.bins["friction"] == "0.1" and rng.random() < 0.8
        gen.tell(s, "fail" if fail else "pass")
    friction = gen.counts[default_hs.element_names.index("friction")]
    counts = dict(zip(default_hs.labels("friction"), friction, strict=True))
    assert counts["0.1"] == max(counts.values()) and counts["0.1"] > 300
    assert min(min(c) for c in gen.counts) >= 3


def test_failure_guided_ignores_unjudged_runs(default_hs):
    gen = make_generator("failure-guided", default_hs)
    s = gen.ask(np.random.default_rng(0))
    gen.tell(s, "error")
    gen.tell(s, "timeout")
    assert sum(map(sum, gen.fails)) == 0 and sum(map(sum, gen.passes)) == 0
    gen.tell(s, "fail")
    assert sum(map(sum, gen.fails)) == len(default_hs.elements)


@pytest.mark.parametrize("bad", [{"epsilon": 2.0}, {"floor": -1}])
def test_failure_guided_rejects_bad_options(default_hs, bad):
    from sitcov.errors import ConfigError

    with pytest.raises(ConfigError):
        make_generator("failure-guided", default_hs, **bad)


@pytest.mark.parametrize("t", [4, 9])
def test_tway_refuses_a_strength_it_cannot_build_in_reasonable_time(t):
    from sitcov.errors import ConfigError
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace

    with pytest.raises(ConfigError, match=rf"t={t}: the hyperspace has [\d,]+ {t}-way"):
        make_generator("tway", load_hyperspace(), t=t)
