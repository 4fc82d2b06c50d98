"""The paper's SitCov generator: per element, prefer the bins used least, via a softmax.

For the counts ``c`` of an element's bins: ``m = softmax(c)``, ``w = 1 - m``,
``p = w / sum(w)``, one draw with probabilities ``p``; the chosen bin's count is
incremented at selection (before the run). Counts never reset and are part of the state.
"""

from __future__ import annotations

import math
from bisect import bisect_right
from collections.abc import Sequence

import numpy as np

from sitcov.generation._common import MAX_REDRAWS, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation


def sitcov_probabilities(counts: Sequence[int] | np.ndarray) -> np.ndarray:
    """The paper's selection probabilities for one element's bin counts.

    ``m = softmax(counts)`` (computed stably, shifted by the maximum), ``w = 1 - m``,
    ``p = w / sum(w)``. Since ``sum(w) = n - 1``, every ``p_i <= 1/(n - 1)``: a weak push
    towards the less-used bins. An element with a single bin gets ``p = [1]``.

    Args:
        counts: how often each bin has been chosen so far.

    Returns:
        Probabilities, one per bin, summing to 1.
    """
    c = np.asarray(counts, dtype=float)
    if c.size == 1:
        return np.ones(1)
    e = np.exp(c - c.max())
    w = 1.0 - e / e.sum()
    return w / w.sum()


#: exp(-k) for integer count gaps k (exp(-746) underflows to 0.0 anyway) [-]
_EXP = tuple(math.exp(-k) for k in range(746))


def _draw(counts: list[int], u: float) -> int:
    """Index drawn with the sitcov probabilities of ``counts`` for the uniform ``u``.

    Pure-Python twin of :func:`sitcov_probabilities` followed by an inverse-CDF draw on the
    unnormalised weights (``u * sum(w)`` against their running sum), which is the same draw.
    Counts are integers, so ``exp(c - max)`` is a table lookup.
    """
    n = len(counts)
    if n == 1:
        return 0
    top = max(counts)
    exps = [_EXP[top - c] if top - c < 746 else 0.0 for c in counts]
    total = sum(exps)
    acc = 0.0
    cum = []
    last = 0
    for i, x in enumerate(exps):
        w = 1.0 - x / total
        if w > 0.0:
            last = i
        acc += w
        cum.append(acc)
    i = bisect_right(cum, u * acc)
    return i if i <= last else last  # u * sum rounded up to the total


class SitCovGenerator(IndexedGenerator):
    """The paper's situation-coverage generator, exactly (see the module docstring).

    Each ask draws one uniform number per element (a single vectorised rng call) and
    picks bins by inverse CDF. A situation that breaks a constraint is redrawn whole with
    the same rng and the counts are only incremented for the accepted one.
    """

    name = "sitcov"

    def __init__(self, hyperspace: Hyperspace) -> None:
        super().__init__(hyperspace)
        self.counts: list[list[int]] = [[0] * n for n in self.sizes]

    def probabilities(self) -> dict[str, np.ndarray]:
        """Current selection probabilities per element."""
        return {
            name: sitcov_probabilities(c)
            for name, c in zip(self.hs.element_names, self.counts, strict=True)
        }

    def ask(self, rng: np.random.Generator) -> Situation:
        """Draw every element's bin with the sitcov probabilities, then count the bins."""
        counts = self.counts
        n = self.n_elements
        for _ in range(MAX_REDRAWS):
            us = rng.random(n).tolist()
            idx = [_draw(counts[e], us[e]) for e in range(n)]
            if self._allowed(idx):
                for e, i in enumerate(idx):
                    counts[e][i] += 1
                return self._emit(idx, rng)
        raise self._over_constrained()

    def _state_body(self) -> dict:
        return {"counts": self._dump_counts(self.counts)}

    def _load_body(self, body: dict) -> None:
        self.counts = self._load_counts(body["counts"])
