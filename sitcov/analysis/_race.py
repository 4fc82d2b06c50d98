"""Scoring a generator race: failure regions found, runs to find them, coverage, evenness.

**Failure region (operational definition).** A large *reference* campaign (uniform random
situations, its own seed) is partitioned by a CART tree over bins (``_tree``, Gini, depth
``max_depth``, at least ``min_leaf`` runs per leaf, no merging of leaves; elements encoded
as in ``sitcov explain``'s rules). Every leaf is a box of bins; a leaf whose reference
failure rate is at least 50 % *and* whose Wilson 95 % lower bound exceeds the reference
campaign's overall failure rate (so that a small leaf failing by chance is not a region)
is a *failure region*. A campaign *finds* a region at the
first of its runs that fails inside that box. Regions are disjoint, so "distinct failure
regions found" counts boxes with at least one failure, however many failures each holds.

Per campaign: failures, regions found (after each checkpoint and at the end), runs to the
first failure of each region (censored at the budget when never found), bins covered and
pairwise coverage after each checkpoint, and evenness (mean over elements of the
normalised entropy of the bin counts, 1 = perfectly even). Per generator: the mean over
seeds with a 95 % t-interval; versus ``random``: the paired difference (same seeds).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from itertools import combinations
from typing import Any

import numpy as np

from sitcov.analysis._explain import encode_runs
from sitcov.analysis._regions import _conditions, _features, _matches, _orders
from sitcov.analysis._stats import wilson_interval
from sitcov.analysis._tree import grow
from sitcov.hyperspace import Hyperspace

#: leaf failure rate from which a leaf is a failure region
REGION_RATE = 0.5
#: depth of the reference tree (up to 2**depth leaves)
REGION_DEPTH = 5


def reference_regions(
    hs: Hyperspace,
    runs: Iterable[Any],
    *,
    max_depth: int = REGION_DEPTH,
    min_leaf: int | None = None,
) -> list[dict[str, Any]]:
    """The failure regions of a reference campaign (see the module docstring).

    Args:
        hs: the hyperspace.
        runs: the reference campaign's runs (``.bins``/``.status`` or mappings).
        max_depth: tree depth.
        min_leaf: fewest reference runs per leaf (default: 1 % of the judged runs, >= 10).

    Returns:
        Regions, most failures first: ``text``, ``conditions``, reference ``support``,
        ``failures`` and ``rate``.
    """
    codes, y, _ = encode_runs(hs, runs)
    if len(y) == 0:
        return []
    leaf = min_leaf if min_leaf is not None else max(10, len(y) // 100)
    orders = _orders(hs, codes, y)
    leaves = grow(_features(codes, orders), y, max_depth=max_depth, min_leaf=leaf,
                  threshold=REGION_RATE, merge=False)  # fmt: skip
    regions = []
    overall = float(y.mean())
    for rows, lo, hi in leaves:
        rate = float(y[rows].mean())
        low = wilson_interval(int(y[rows].sum()), len(rows))
        if rate < REGION_RATE or low is None or low[0] <= overall:
            continue
        conds = _conditions(hs, orders, lo, hi)
        regions.append({
            "text": " and ".join(c["text"] for c in conds) or "everywhere",
            "conditions": conds,
            "support": int(len(rows)),
            "failures": int(y[rows].sum()),
            "rate": rate,
        })  # fmt: skip
    regions.sort(key=lambda r: (-r["failures"], r["text"]))
    return regions


def _entropy(counts: np.ndarray) -> float:
    total = counts.sum()
    if total == 0 or len(counts) < 2:
        return 1.0
    p = counts[counts > 0] / total
    return float(-(p * np.log(p)).sum() / math.log(len(counts)))


def campaign_metrics(
    hs: Hyperspace,
    runs: Sequence[Any],
    regions: Sequence[Mapping[str, Any]],
    checkpoints: Sequence[int] = (50, 100, 200, 300),
) -> dict[str, Any]:
    """Race metrics of one campaign's runs (in run-index order).

    Returns:
        ``runs``, ``failures``, ``errors``, ``regions_found``, ``regions_at`` /
        ``bins_at`` / ``pairs_at`` (checkpoint -> value, checkpoints beyond the runs are
        left out), ``first_failure`` (per region: 1-based run number of its first failure,
        or None), ``mean_runs_to_region`` (censored at the number of runs) and ``evenness``.
    """
    names = hs.element_names
    lookup = hs._label_index
    idx = np.array(
        [[lookup[e].get(r.bins.get(n), -1) for e, n in enumerate(names)] for r in runs],
        dtype=int,
    ).reshape(len(runs), len(names))
    fails = np.array([r.status == "fail" for r in runs], dtype=bool)
    n = len(runs)
    first: list[int | None] = []
    for region in regions:
        hit = np.flatnonzero(_matches(idx, hs, region["conditions"]) & fails)
        first.append(int(hit[0]) + 1 if hit.size else None)
    out: dict[str, Any] = {
        "runs": n,
        "failures": int(fails.sum()),
        "errors": sum(1 for r in runs if r.status in ("error", "timeout")),
        "regions_found": sum(f is not None for f in first),
        "first_failure": first,
        "mean_runs_to_region": (
            float(np.mean([f if f is not None else n for f in first])) if first else None
        ),
        "regions_at": {}, "bins_at": {}, "pairs_at": {},
    }  # fmt: skip
    total_pairs = sum(hs.sizes[a] * hs.sizes[b] for a, b in combinations(range(len(names)), 2))
    for c in checkpoints:
        if c > n:
            continue
        head = idx[:c]
        out["regions_at"][str(c)] = sum(f is not None and f <= c for f in first)
        out["bins_at"][str(c)] = sum(
            len(set(head[:, e].tolist()) - {-1}) for e in range(len(names))
        )
        pairs = {
            (a, b, int(i), int(j))
            for a, b in combinations(range(len(names)), 2)
            for i, j in zip(head[:, a], head[:, b], strict=True)
            if i >= 0 and j >= 0
        }
        out["pairs_at"][str(c)] = len(pairs) / total_pairs
    even = [
        _entropy(np.bincount(idx[:, e][idx[:, e] >= 0], minlength=size))
        for e, size in enumerate(hs.sizes)
    ]
    out["evenness"] = float(np.mean(even))
    return out


def mean_ci(values: Sequence[float]) -> dict[str, Any]:
    """Mean with a 95 % t-interval over seeds (None bounds with fewer than 2 values)."""
    from scipy.stats import t

    x = np.asarray([v for v in values if v is not None], dtype=float)
    if x.size == 0:
        return {"mean": None, "ci95": None, "n": 0}
    mean = float(x.mean())
    if x.size < 2:
        return {"mean": mean, "ci95": None, "n": 1}
    half = float(t.ppf(0.975, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    return {"mean": mean, "ci95": [mean - half, mean + half], "n": int(x.size)}


#: the metrics compared per generator (key in campaign_metrics, checkpoint or None)
RACE_METRICS: tuple[tuple[str, str, str | None], ...] = (
    ("failures", "failures", None),
    ("regions", "regions_found", None),
    ("regions_100", "regions_at", "100"),
    ("runs_to_region", "mean_runs_to_region", None),
    ("bins_50", "bins_at", "50"),
    ("pairs_end", "pairs_at", "end"),
    ("evenness", "evenness", None),
)


def _value(m: Mapping[str, Any], key: str, point: str | None) -> float | None:
    if point is None:
        return m.get(key)
    table = m.get(key) or {}
    if point == "end":
        return table[max(table, key=int)] if table else None
    return table.get(point)


def race_table(
    per_generator: Mapping[str, Sequence[Mapping[str, Any]]], baseline: str = "random"
) -> dict[str, Any]:
    """Per generator and metric: mean and 95 % t-interval over seeds; and the paired
    difference from ``baseline`` (campaigns matched by position, i.e. by seed)."""
    table: dict[str, Any] = {}
    base = per_generator.get(baseline)
    for gen, metrics in per_generator.items():
        row: dict[str, Any] = {"seeds": len(metrics)}
        for label, key, point in RACE_METRICS:
            values = [_value(m, key, point) for m in metrics]
            row[label] = mean_ci(values)
            if base is not None and gen != baseline and len(base) == len(metrics):
                diffs = [
                    None if v is None or b is None else v - b
                    for v, b in zip(values, (_value(m, key, point) for m in base), strict=True)
                ]
                row[label]["vs_" + baseline] = mean_ci(diffs)
        table[gen] = row
    return table
