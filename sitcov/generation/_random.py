"""The baseline: every element's bin drawn uniformly and independently."""

from __future__ import annotations

import numpy as np

from sitcov.generation._common import MAX_REDRAWS, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation


class RandomGenerator(IndexedGenerator):
    """Uniform and independent per element (the paper's random baseline).

    A situation that breaks a constraint is redrawn whole with the same rng, so the result
    is uniform over the allowed situations.
    """

    name = "random"

    def __init__(self, hyperspace: Hyperspace) -> None:
        super().__init__(hyperspace)
        self._sizes = np.asarray(self.sizes)

    def ask(self, rng: np.random.Generator) -> Situation:
        """One uniform draw per element (one vectorised rng call per attempt)."""
        for _ in range(MAX_REDRAWS):
            idx = rng.integers(0, self._sizes).tolist()
            if self._allowed(idx):
                return self._emit(idx, rng)
        raise self._over_constrained()
