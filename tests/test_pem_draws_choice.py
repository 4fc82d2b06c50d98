"""``benchmarks/pem_draws_choice.py``: the reproducibility of a K-draw majority that
docs/pem.md ("Perception draws") chooses K by."""

from __future__ import annotations

import numpy as np
import pytest
from benchmark_modules import load_benchmark


def test_two_majorities_of_disjoint_draws_are_compared() -> None:
    """Situations that always fail or always pass agree at every K; one that fails in
    exactly the first half of its draws agrees at no K; the failure rate is the first
    majority's."""
    verdicts = np.array(
        [
            [1] * 10,  # always fails
            [0] * 10,  # always passes
            [1] * 5 + [0] * 5,  # K=1: draw 0 vs draw 1 agree (1, 1); K=3: 1 vs (1,1,0) -> 1
            [1, 0, 1, 0, 1, 0, 1, 0, 1, 0],  # K=1: 1 vs 0; K=3: (1,0,1) vs (0,1,0)
        ]
    )
    table = load_benchmark("pem_draws_choice").choice_table(verdicts, 5)
    assert [r["draws"] for r in table] == [1, 3, 5]
    assert table[0]["agreement"] == pytest.approx(3 / 4)  # the alternating one disagrees
    assert table[1]["agreement"] == pytest.approx(3 / 4)  # (1,1,1)|(1,1,0) agree; alt not
    assert table[2]["agreement"] == pytest.approx(2 / 4)  # 5 fails | 5 passes; alt too
    assert table[0]["failure_rate"] == pytest.approx(3 / 4)
    assert table[2]["failure_rate"] == pytest.approx(3 / 4)
    lo, hi = table[2]["ci95"]
    assert lo < 0.5 < hi


def test_noisier_worlds_need_more_draws() -> None:
    """Worlds with a failure probability near one half: a 15-draw majority is more
    reproducible than one draw (the property the choice of K rests on)."""
    rng = np.random.default_rng(4)
    p = rng.uniform(0.3, 0.7, size=(2000, 1))
    verdicts = (rng.random((2000, 30)) < p).astype(int)
    table = load_benchmark("pem_draws_choice").choice_table(verdicts, 15)
    assert table[-1]["agreement"] > table[0]["agreement"] + 0.1
