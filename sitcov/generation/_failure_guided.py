"""failure-guided: Thompson sampling towards failing bins, with a coverage floor.

Per element, each bin has a Beta(1 + failures, 1 + passes) posterior over its failure
rate, updated by ``tell`` (``error``/``timeout`` runs are not judged and leave it alone).
Each ask, per element: if some bin has been generated fewer than ``floor`` times, or with
probability ``epsilon``, the least-generated bin is taken (seeded random tie-break);
otherwise one sample is drawn from every bin's posterior and the largest wins. The floor
keeps every bin exercised, so the per-bin failure rates stay estimable.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.generation._common import MAX_REDRAWS, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation


class FailureGuidedGenerator(IndexedGenerator):
    """Thompson sampling on per-bin Beta posteriors, with a coverage floor.

    Args:
        hyperspace: the hyperspace.
        epsilon: probability, per element and ask, of taking the least-used bin instead.
        floor: until every bin of an element has been generated this many times, that
            element takes its least-used bin.
    """

    name = "failure-guided"
    learns = True

    def __init__(self, hyperspace: Hyperspace, *, epsilon: float = 0.1, floor: int = 2) -> None:
        if not 0.0 <= float(epsilon) <= 1.0:
            raise ConfigError(
                field="generator 'failure-guided' option epsilon", value=epsilon, expected="0..1"
            )
        if int(floor) < 0:
            raise ConfigError(
                field="generator 'failure-guided' option floor", value=floor, expected=">= 0"
            )
        super().__init__(hyperspace, epsilon=float(epsilon), floor=int(floor))
        self.epsilon = float(epsilon)
        self.floor = int(floor)
        self.counts: list[list[int]] = [[0] * n for n in self.sizes]
        self.fails: list[list[int]] = [[0] * n for n in self.sizes]
        self.passes: list[list[int]] = [[0] * n for n in self.sizes]

    def _pick(self, e: int, rng: np.random.Generator) -> int:
        counts = self.counts[e]
        n = len(counts)
        low = min(counts)
        explore = rng.random() < self.epsilon
        if low < self.floor or explore:
            keys = rng.random(n).tolist()
            return min((b for b in range(n) if counts[b] == low), key=lambda b: keys[b])
        theta = rng.beta(
            1.0 + np.asarray(self.fails[e], dtype=float),
            1.0 + np.asarray(self.passes[e], dtype=float),
        )
        return int(np.argmax(theta))

    def ask(self, rng: np.random.Generator) -> Situation:
        """Per element: floor / epsilon exploration, else Thompson sampling."""
        for _ in range(MAX_REDRAWS):
            idx = [self._pick(e, rng) for e in range(self.n_elements)]
            if self._allowed(idx):
                for e, i in enumerate(idx):
                    self.counts[e][i] += 1
                return self._emit(idx, rng)
        raise self._over_constrained()

    def tell(self, situation: Situation, outcome: Any) -> None:
        """Update the posteriors of the situation's bins from a ``pass`` or ``fail``."""
        status = getattr(outcome, "status", outcome)
        if status not in ("pass", "fail"):
            return
        table = self.fails if status == "fail" else self.passes
        for e, i in enumerate(self._bin_index(situation)):
            table[e][i] += 1

    def _state_body(self) -> dict[str, Any]:
        return {
            "counts": self._dump_counts(self.counts),
            "fails": self._dump_counts(self.fails),
            "passes": self._dump_counts(self.passes),
        }

    def _load_body(self, body: dict[str, Any]) -> None:
        self.counts = self._load_counts(body["counts"])
        self.fails = self._load_counts(body["fails"])
        self.passes = self._load_counts(body["passes"])
