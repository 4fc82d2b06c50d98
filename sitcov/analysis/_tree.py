"""A shallow classification tree (CART, Gini) over ordered bin positions, for rules.

Small on purpose: the features are a handful of bin positions (at most a few dozen
distinct values each), the trees are depth <= 3, and what is needed is each leaf's box of
bounds (to turn into a readable rule), not predictions. Written here rather than taken
from scikit-learn, whose import alone costs more than fitting these trees.
"""

from __future__ import annotations

import numpy as np

#: a leaf: the row indices it holds, and lower/upper bounds of each feature (lo < x <= hi)
Leaf = tuple[np.ndarray, np.ndarray, np.ndarray]


def _gini_sum(fails: float, n: float) -> float:
    """n x Gini impurity of a node with ``fails`` failures among ``n`` rows."""
    return 0.0 if n == 0 else 2.0 * fails * (n - fails) / n


def best_split(
    x: np.ndarray, y: np.ndarray, rows: np.ndarray, min_leaf: int
) -> tuple[float, int, float] | None:
    """(impurity decrease, feature, threshold) of the best split ``x[:, f] <= t`` of
    ``rows`` with at least ``min_leaf`` rows per side; None if there is none. Ties go to
    the first feature and the lowest threshold, so the tree is deterministic."""
    yy = y[rows]
    n, k = len(rows), float(yy.sum())
    parent = _gini_sum(k, n)
    best = None
    for f in range(x.shape[1]):
        vals = x[rows, f]
        levels = np.unique(vals)
        if len(levels) < 2:
            continue
        counts = np.array([np.sum(vals == v) for v in levels])
        fails = np.array([yy[vals == v].sum() for v in levels])
        n_left, k_left = np.cumsum(counts)[:-1], np.cumsum(fails)[:-1]
        for i, (nl, kl) in enumerate(zip(n_left, k_left, strict=True)):
            if nl < min_leaf or n - nl < min_leaf:
                continue
            gain = parent - _gini_sum(kl, nl) - _gini_sum(k - kl, n - nl)
            if gain > 1e-9 and (best is None or gain > best[0] + 1e-9):
                best = (float(gain), f, float(levels[i]))
    return best


def grow(
    x: np.ndarray,
    y: np.ndarray,
    *,
    max_depth: int,
    min_leaf: int,
    threshold: float,
    merge: bool = True,
) -> list[Leaf]:
    """The leaves of a depth-``max_depth`` tree; a subtree whose leaves all fall on the same
    side of ``threshold`` (failure share) is returned as one leaf, since its splits would
    only make the rules longer without changing any verdict (``merge=False`` keeps every
    leaf, e.g. to partition the hyperspace into regions)."""
    n_features = x.shape[1]

    def node(rows: np.ndarray, lo: np.ndarray, hi: np.ndarray, depth: int) -> list[Leaf]:
        split = best_split(x, y, rows, min_leaf) if depth < max_depth else None
        if split is None:
            return [(rows, lo, hi)]
        _, f, t = split
        left = x[rows, f] <= t
        hi_left, lo_right = hi.copy(), lo.copy()
        hi_left[f], lo_right[f] = t, t
        leaves = node(rows[left], lo, hi_left, depth + 1)
        leaves += node(rows[~left], lo_right, hi, depth + 1)
        if merge and len({bool(y[r].mean() >= threshold) for r, _, _ in leaves}) == 1:
            return [(rows, lo, hi)]
        return leaves

    start = np.arange(len(y))
    return node(start, np.full(n_features, -np.inf), np.full(n_features, np.inf), 0)
