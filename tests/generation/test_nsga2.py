"""The NSGA-II baseline (pymoo): deterministic, resumable, and it searches towards failures."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pytest

from sitcov._seeding import ask_rng
from sitcov.errors import ConfigError
from sitcov.generation import make_generator, restore_generator
from tests.needs import need_module

need_module("pymoo", "search")

from sitcov.generation._nsga2 import WORST, objectives  # noqa: E402


def oracle(situation, seed: int, i: int):
    """Low friction fails; otherwise the distance grows with the friction bin."""
    f = float(situation.bins["friction"])
    rng = np.random.default_rng([seed, i, 3])
    fails = f <= 0.2 and rng.random() < 0.8
    return SimpleNamespace(
        status="fail" if fails else "pass", min_distance=0.0 if fails else 5 * f, min_ttc=None
    )


def campaign(gen, n: int, seed: int, batch: int = 16, start: int = 0):
    out = []
    for first in range(start, start + n, batch):
        asked = [gen.ask(ask_rng(seed, i)) for i in range(first, min(first + batch, start + n))]
        for i, s in enumerate(asked, start=first):
            gen.tell(s, oracle(s, seed, i))
        out += asked
    return out


def test_objectives():
    assert objectives(SimpleNamespace(status="fail", min_distance=0.0, min_ttc=0.4)) == (0, 0.4)
    assert objectives(SimpleNamespace(status="pass", min_distance=3.0, min_ttc=None)) == (4, 10)
    assert objectives(SimpleNamespace(status="error")) == WORST


def test_deterministic_and_resumable(default_hs):
    make = lambda: make_generator("nsga2", default_hs, pop_size=16)  # noqa: E731
    a = [s.id for s in campaign(make(), 96, seed=1)]
    assert a == [s.id for s in campaign(make(), 96, seed=1)]
    assert a != [s.id for s in campaign(make(), 96, seed=2)]
    gen = make()
    first = campaign(gen, 48, seed=1)
    again = restore_generator("nsga2", default_hs, json.loads(json.dumps(gen.state())))
    second = campaign(again, 48, seed=1, start=48)
    assert [s.id for s in first + second] == a


def test_search_moves_towards_the_failing_bins(default_hs):
    gen = make_generator("nsga2", default_hs, pop_size=16)
    situations = campaign(gen, 160, seed=4)
    low = [s.bins["friction"] in ("0.1", "0.2") for s in situations]
    # uniform: 1/3 of runs at low friction; the last generations should be well above it
    assert np.mean(low[:16]) < 0.6 and np.mean(low[-48:]) > 0.6


def test_bad_pop_size(default_hs):
    with pytest.raises(ConfigError, match="pop_size"):
        make_generator("nsga2", default_hs, pop_size=1)


def test_missing_pymoo_says_which_extra(default_hs, monkeypatch):
    import sys

    from sitcov.errors import MissingExtraError

    monkeypatch.setitem(sys.modules, "pymoo", None)
    with pytest.raises(MissingExtraError, match=r"pip install 'sitcov\[search\]'"):
        make_generator("nsga2", default_hs)
