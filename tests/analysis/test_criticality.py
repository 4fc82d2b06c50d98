"""DRAC by hand and against our TTC on a recorded embedded run."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest

from sitcov.analysis._criticality import drac_series, max_drac
from sitcov.sim._metrics import disc_radius


def trace(ego, ov, length=4.0, width=2.0):
    return SimpleNamespace(ego=ego, ov=ov, meta={"length": length, "width": width})


def test_head_on_by_hand():
    # ego at 0 heading +x at 10 m/s, OV at 50 m heading -x at 10 m/s; discs of radius
    # r = sqrt(4 * 2 / pi) each: gap s = 50 - 2r, closing 20 m/s, DRAC = 20^2 / (2 s)
    r = math.sqrt(8 / math.pi)
    t = trace([(0.0, 0.0, 0.0, 0.0, 10.0)], [(0.0, 50.0, 0.0, math.pi, 10.0)])
    assert max_drac(t) == pytest.approx(400 / (2 * (50 - 2 * r)))
    assert r == pytest.approx(disc_radius(4.0, 2.0))


def test_rear_end_matches_archers_formula():
    # follower 15 m/s, leader 5 m/s ahead by 30 m between centres, same heading
    r = math.sqrt(8 / math.pi)
    t = trace([(0.0, 0.0, 0.0, 0.0, 15.0)], [(0.0, 30.0, 0.0, 0.0, 5.0)])
    assert max_drac(t) == pytest.approx((15 - 5) ** 2 / (2 * (30 - 2 * r)))


def test_no_value_when_not_closing_overlapping_or_unmatched():
    apart = trace([(0.0, 0.0, 0.0, math.pi, 10.0)], [(0.0, 50.0, 0.0, 0.0, 10.0)])
    overlap = trace([(0.0, 0.0, 0.0, 0.0, 10.0)], [(0.0, 1.0, 0.0, math.pi, 10.0)])
    passing = trace([(0.0, 0.0, 0.0, 0.0, 10.0)], [(0.0, 50.0, 20.0, math.pi, 10.0)])
    unmatched = trace([(0.0, 0.0, 0.0, 0.0, 10.0)], [(0.1, 50.0, 0.0, math.pi, 10.0)])
    assert [max_drac(x) for x in (apart, overlap, passing, unmatched)] == [None] * 4


def test_the_maximum_over_steps_is_taken():
    ego = [(0.0, 0.0, 0.0, 0.0, 10.0), (1.0, 10.0, 0.0, 0.0, 10.0)]
    ov = [(0.0, 50.0, 0.0, math.pi, 10.0), (1.0, 40.0, 0.0, math.pi, 10.0)]
    series = drac_series(trace(ego, ov))
    assert len(series) == 2 and series[1][1] > series[0][1] == pytest.approx(max(
        d for _, d in series[:1]))  # fmt: skip
    assert max_drac(trace(ego, ov)) == series[1][1]


def test_recorded_embedded_runs_give_drac_exactly_when_they_give_a_ttc():
    import numpy as np

    from sitcov.av import make_stack
    from sitcov.generation import make_generator
    from sitcov.sim.embedded import EmbeddedBackend

    gen, backend = make_generator("random"), EmbeddedBackend()
    closing = 0
    for seed in range(10):
        situation = gen.ask(np.random.default_rng(seed))
        outcome = backend.run(situation, make_stack("reference"), seed, record=True)
        value = max_drac(outcome.trace)
        # our TTC is computed inside the physics step and DRAC from the recorded rows, so
        # only existence is compared (values: docs/metrics.md)
        assert (value is None) == (outcome.min_ttc is None)
        if value is not None:
            closing += 1
            assert value > 0 and math.isfinite(value)
    assert closing >= 5


def test_the_run_fact_max_drac_is_max_drac_of_the_trace(monkeypatch):
    """The monitor's ``max_drac`` (every step, in the proximity kernel) is :func:`max_drac`
    of the recorded rows: the same definition. A trace row's (yaw, speed) is the heading of
    the body, whose velocity also has a sideways part (slip), so the rows are recorded here
    with the velocity's own direction and size; then the two agree to rounding."""
    import numpy as np

    from sitcov.av import make_stack
    from sitcov.generation import make_generator
    from sitcov.sim.embedded import EmbeddedBackend
    from sitcov.sim.embedded._actors import Actor

    def record(self, t):
        b = self.body
        self.rows.append((t, b.x, b.y, b.yaw + math.atan2(b.vy, b.vx), math.hypot(b.vx, b.vy)))

    monkeypatch.setattr(Actor, "record", record)
    gen, backend = make_generator("random"), EmbeddedBackend()
    compared = 0
    for seed in range(12):
        situation = gen.ask(np.random.default_rng(seed))
        outcome = backend.run(situation, make_stack("reference"), seed, record=True)
        fact = outcome.metrics["max_drac"]
        traced = max_drac(outcome.trace)
        assert (fact is None) == (traced is None), (seed, fact, traced)
        if fact is not None:
            compared += 1
            assert fact == pytest.approx(traced, rel=1e-9), seed
    assert compared >= 5
