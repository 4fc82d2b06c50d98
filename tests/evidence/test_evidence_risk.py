"""Residual risk: the exact bounds against the binomial distribution itself."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import binom

from sitcov.errors import ConfigError
from sitcov.evidence import Criterion, lower_bound, residual_risk, runs_to_meet, upper_bound
from sitcov.evidence._risk import MET, NOT_MET, UNDECIDED, zero_failure_runs

counts = st.integers(1, 400).flatmap(lambda n: st.tuples(st.integers(0, n), st.just(n)))
confidences = st.sampled_from([0.8, 0.9, 0.95, 0.99])


@settings(max_examples=200, deadline=None)
@given(counts, confidences)
def test_upper_bound_is_where_k_or_fewer_failures_become_improbable(kn, conf):
    k, n = kn
    p = upper_bound(k, n, conf)
    if k == n:
        assert p == 1.0
        return
    # Clopper-Pearson: P(X <= k | n, p_upper) = 1 - confidence
    assert binom.cdf(k, n, p) == pytest.approx(1.0 - conf, abs=1e-9)


@settings(max_examples=200, deadline=None)
@given(counts, confidences)
def test_lower_bound_is_where_k_or_more_failures_become_improbable(kn, conf):
    k, n = kn
    p = lower_bound(k, n, conf)
    if k == 0:
        assert p == 0.0
        return
    assert binom.sf(k - 1, n, p) == pytest.approx(1.0 - conf, abs=1e-9)
    assert p <= k / n <= upper_bound(k, n, conf)


@settings(max_examples=150, deadline=None)
@given(counts, st.sampled_from([0.001, 0.01, 0.05, 0.1, 0.3]), confidences)
def test_verdict_follows_the_bounds(kn, target, conf):
    k, n = kn
    crit = Criterion(target, conf)
    v = residual_risk("r", k, n, crit)
    if v.verdict == MET:
        assert upper_bound(k, n, conf) < target and v.runs_needed == 0
    elif v.verdict == NOT_MET:
        assert lower_bound(k, n, conf) > target and v.runs_needed is None
    else:
        assert v.verdict == UNDECIDED
        assert lower_bound(k, n, conf) <= target <= upper_bound(k, n, conf)
        m = v.runs_needed
        # minimal: m more failure-free runs meet the criterion, m - 1 do not
        assert upper_bound(k, n + m, conf) < target
        assert upper_bound(k, n + m - 1, conf) >= target


@pytest.mark.parametrize("target,conf", [(0.01, 0.95), (0.05, 0.95), (0.001, 0.99)])
def test_zero_failures_need_the_rule_of_three_count(target, conf):
    crit = Criterion(target, conf)
    # (1 - target)^m <= 1 - confidence, the classic zero-failure demonstration
    m = runs_to_meet(0, 0, crit)
    assert m in (zero_failure_runs(crit), zero_failure_runs(crit) + 1)
    assert (1 - target) ** m <= 1 - conf + 1e-12
    if target == 0.01:
        assert m in (299, 300)  # ~ 3 / 0.01


@pytest.mark.parametrize("text", ["rate<2", "rate>0.1", "0.01", "rate<0.01@1.5", "rate<x"])
def test_bad_criteria_are_one_clear_error(text):
    with pytest.raises(ConfigError, match="--criterion"):
        Criterion.parse(text)


def test_criterion_text_round_trip():
    crit = Criterion.parse(" rate < 1e-2 @ 0.99 ")
    assert (crit.target, crit.confidence) == (0.01, 0.99)
    assert Criterion.parse("rate<0.05").confidence == 0.95
