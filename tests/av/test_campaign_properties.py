"""Campaign-level properties of the reference stack + PEM on the embedded backend (slow).

Over the same random situations and run seeds: the no-fault failure rate is moderate
(neither a pushover nor invincible), fog raises it, and every seeded fault raises it.
The measured rates are in docs/reference-stack.md.
"""

from __future__ import annotations

import pytest

from sitcov._seeding import ask_rng, run_seed
from sitcov.av import ReferenceStack
from sitcov.generation import make_generator
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim.embedded import EmbeddedBackend

N = 250  # situations per configuration
N_FOG = 150  # situations for the paired fog comparison
SEED = 2024


@pytest.fixture(scope="module")
def runs():
    hs = load_hyperspace()
    gen = make_generator("random", hs)
    situations = [gen.ask(ask_rng(SEED, i)) for i in range(N)]
    seeds = [run_seed(SEED, i) for i in range(N)]
    return situations, seeds, EmbeddedBackend()


def _rate(backend, situations, seeds, fault=None) -> float:
    stack = ReferenceStack(fault=fault)
    return sum(
        backend.run(s, stack, k).failed for s, k in zip(situations, seeds, strict=True)
    ) / len(situations)


def _with_fog(situation: Situation, label: str) -> Situation:
    bins, values = dict(situation.bins), dict(situation.values)
    bins["fog_density"], values["fog_density"] = label, float(label)
    return Situation(bins, values)


@pytest.mark.slow
def test_fault_free_rate_is_moderate_and_every_fault_raises_it(runs):
    situations, seeds, backend = runs
    base = _rate(backend, situations, seeds)
    assert 0.05 <= base <= 0.60, base
    for fault in ("f1", "f2", "f3"):
        rate = _rate(backend, situations, seeds, fault)
        assert rate >= base + 0.05, (fault, rate, base)


@pytest.mark.slow
def test_dense_fog_fails_more_often_than_clear_air(runs):
    situations, seeds, backend = runs
    sub, sub_seeds = situations[:N_FOG], seeds[:N_FOG]
    clear = _rate(backend, [_with_fog(s, "0") for s in sub], sub_seeds)
    foggy = _rate(backend, [_with_fog(s, "100") for s in sub], sub_seeds)
    assert foggy > clear, (foggy, clear)
