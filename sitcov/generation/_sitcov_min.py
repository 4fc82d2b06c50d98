"""sitcov-min: least-used bin first for every element, pairs balanced among the ties.

Design (see docs/generators.md): the paper's softmax push is weak (``p_i <= 1/(n-1)``), so a
bin can stay behind for many runs. Here, for each element in a random order, the candidates
are the bins with the smallest count; among them the bin whose pairs with the bins already
chosen in this situation have been used least wins; remaining ties go to a seeded random key.
Without constraints every element's counts therefore differ by at most one at all times,
and 2-way combinations fill in far faster than by chance.
"""

from __future__ import annotations

import numpy as np

from sitcov.generation._common import MAX_REDRAWS, ComboCounts, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation


class SitCovMinGenerator(IndexedGenerator):
    """Deterministic-given-rng least-used-first coverage generator with pair balancing."""

    name = "sitcov-min"

    def __init__(self, hyperspace: Hyperspace) -> None:
        super().__init__(hyperspace)
        self.counts: list[list[int]] = [[0] * n for n in self.sizes]
        self.pairs = ComboCounts(self.sizes, 2)
        self._max = max(self.sizes)

    def _pair_use(self, e: int, b: int, idx: list[int]) -> int:
        table = self.pairs.table
        sizes = self.sizes
        total = 0
        for f, j in enumerate(idx):
            if j < 0 or f == e:
                continue
            if e < f:
                total += table[(e, f)][b * sizes[f] + j]
            else:
                total += table[(f, e)][j * sizes[e] + b]
        return total

    def _attempt(self, rng: np.random.Generator) -> list[int] | None:
        n = self.n_elements
        order = rng.permutation(n).tolist()
        keys = rng.random((n, self._max)).tolist()
        idx = [-1] * n
        constrained = bool(self.hs._constraints)
        for e in order:
            best = None
            best_score = None
            counts = self.counts[e]
            for b in range(self.sizes[e]):
                if constrained:
                    idx[e] = b
                    ok = self._allowed(idx)
                    idx[e] = -1
                    if not ok:
                        continue
                score = (counts[b], self._pair_use(e, b, idx), keys[e][b])
                if best_score is None or score < best_score:
                    best, best_score = b, score
            if best is None:
                return None
            idx[e] = best
        return idx

    def ask(self, rng: np.random.Generator) -> Situation:
        """Build the situation element by element (random order), least-used bins first."""
        for _ in range(MAX_REDRAWS):
            idx = self._attempt(rng)
            if idx is not None and self._allowed(idx):
                for e, i in enumerate(idx):
                    self.counts[e][i] += 1
                self.pairs.add(idx)
                return self._emit(idx, rng)
        raise self._over_constrained()

    def _state_body(self) -> dict:
        return {"counts": self._dump_counts(self.counts), "pairs": self.pairs.dump()}

    def _load_body(self, body: dict) -> None:
        self.counts = self._load_counts(body["counts"])
        self.pairs.load(body["pairs"])
