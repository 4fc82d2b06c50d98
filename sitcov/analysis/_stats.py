"""Small statistics used by the analysis: Wilson intervals and uniformity of counts."""

from __future__ import annotations

import math
from collections.abc import Sequence

#: two-sided 95% standard-normal quantile [-]
Z95 = 1.959963984540054


def wilson_interval(k: int, n: int, z: float = Z95) -> tuple[float, float] | None:
    """Wilson score interval for a binomial proportion ``k / n`` (95% by default).

    Unlike the normal approximation it stays inside [0, 1] and is sensible for ``k = 0``
    or ``k = n`` with small ``n`` (the usual case for per-bin failure rates).

    Returns:
        (lower, upper), or None when ``n == 0`` (nothing judged, nothing to say).
    """
    if n <= 0:
        return None
    if not 0 <= k <= n:
        raise ValueError(f"wilson_interval: need 0 <= k <= n, got k={k}, n={n}")
    p = k / n
    z2 = z * z
    denom = 1.0 + z2 / n
    centre = (p + z2 / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / denom
    # the bounds are exactly 0 / 1 at k = 0 / n; rounding must not move them inside
    lo = 0.0 if k == 0 else max(0.0, centre - half)
    hi = 1.0 if k == n else min(1.0, centre + half)
    return lo, hi


def uniformity(counts: Sequence[int]) -> dict[str, float | int | None]:
    """How evenly one element's bins were exercised.

    Returns:
        ``min``/``max`` counts; ``max_min_ratio`` (inf if a bin is unused, None if nothing
        was generated); ``entropy`` normalised to [0, 1] (1 = perfectly even; 1.0 for a
        single bin; None if nothing was generated); ``chi2`` statistic and ``chi2_p``
        p-value of Pearson's test against the uniform distribution (None without data or
        with a single bin).
    """
    from scipy.stats import chisquare

    counts = [int(c) for c in counts]
    total = sum(counts)
    lo, hi = (min(counts), max(counts)) if counts else (0, 0)
    out: dict[str, float | int | None] = {
        "min": lo,
        "max": hi,
        "max_min_ratio": None,
        "entropy": None,
        "chi2": None,
        "chi2_p": None,
    }
    if total == 0:
        return out
    out["max_min_ratio"] = math.inf if lo == 0 else hi / lo
    n = len(counts)
    if n == 1:
        out["entropy"] = 1.0
        return out
    h = -sum(c / total * math.log(c / total) for c in counts if c > 0)
    out["entropy"] = h / math.log(n)
    stat, p = chisquare(counts)
    out["chi2"], out["chi2_p"] = float(stat), float(p)
    return out
