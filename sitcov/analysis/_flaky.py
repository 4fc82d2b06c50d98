"""Flakiness (verdicts that flip when only the run seed changes) and runs-needed sizing.

A situation run with ``m`` seeds, ``k`` of which fail, is *flaky* when ``0 < k < m``. Its
*flip probability* is the chance that two different seeds of it disagree, estimated without
bias by ``2 k (m - k) / (m (m - 1))``. Per bin the situations holding that bin are pooled:
the share of flaky situations (Wilson 95 % interval) and the mean flip probability (95 %
percentile-bootstrap interval over situations, seeded).

Runs-needed: the smallest ``n`` such that the Wilson interval of a failure rate observed
as ``p`` in ``n`` runs reaches at most ``margin`` from ``p`` on either side (the interval
is lopsided near 0 and 1: at ``p = 0`` its upper end is ``z^2 / (n + z^2)``, so claiming
"below 5 %" takes 73 runs, not the 35 a symmetric half-width suggests); with no rate given
the worst case ``p = 0.5`` is used, which bounds every other rate. ``zero_failure_runs``
answers the other question a safety engineer asks: how many runs, none failing, show the
rate is below ``x`` with a given confidence (exact binomial: ``(1 - x)^n <= 1 - c``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from statistics import NormalDist
from typing import Any

import numpy as np

from sitcov.analysis._stats import wilson_interval
from sitcov.errors import ConfigError
from sitcov.hyperspace import Hyperspace

#: bootstrap replicates of the mean flip probability
BOOTSTRAP = 999


def wilson_half_width(p: float, n: int, z: float) -> float:
    """Half-width of the Wilson interval of a rate ``p`` observed in ``n`` runs."""
    z2 = z * z
    return z * math.sqrt(p * (1 - p) / n + z2 / (4 * n * n)) / (1 + z2 / n)


def wilson_reach(p: float, n: int, z: float) -> float:
    """How far the Wilson interval of a rate ``p`` observed in ``n`` runs reaches from
    ``p``: the larger of ``p - lower`` and ``upper - p`` (the interval is lopsided near
    0 and 1, so its half-width understates the far side there)."""
    z2 = z * z
    centre = (p + z2 / (2 * n)) / (1 + z2 / n)
    half = wilson_half_width(p, n, z)
    lo, hi = max(0.0, centre - half), min(1.0, centre + half)
    return max(p - lo, hi - p)


def zero_failure_runs(below: float, confidence: float = 0.95) -> int:
    """Runs, none failing, that show a failure rate below ``below`` with ``confidence``
    (exact one-sided binomial bound: the smallest ``n`` with ``(1 - below)^n <= 1 - c``;
    about ``3 / below`` at 95 %, the "rule of three")."""
    if not 0 < below < 1:
        raise ConfigError(field="--below", value=below, expected="a rate in (0, 1)")
    if not 0 < confidence < 1:
        raise ConfigError(field="--confidence", value=confidence, expected="a number in (0, 1)")
    n = math.ceil(math.log(1.0 - confidence) / math.log(1.0 - below))
    while n > 1 and (1.0 - below) ** (n - 1) <= 1.0 - confidence:  # guard float rounding
        n -= 1
    while (1.0 - below) ** n > 1.0 - confidence:
        n += 1
    return n


def runs_needed(margin: float, rate: float | None = None, confidence: float = 0.95) -> int:
    """Runs per bin so that the Wilson interval of its failure rate reaches at most
    ``margin`` from the rate on either side.

    Args:
        margin: wanted half-width, in (0, 0.5].
        rate: expected failure rate in [0, 1]; None = 0.5, the worst case.
        confidence: two-sided confidence level in (0, 1).

    Returns:
        The smallest such ``n`` (the reach decreases with ``n`` for a fixed rate, so it is
        found by doubling and bisection).
    """
    if not 0 < margin <= 0.5:
        raise ConfigError(field="--margin", value=margin, expected="a number in (0, 0.5]")
    p = 0.5 if rate is None else rate
    if not 0 <= p <= 1:
        raise ConfigError(field="--rate", value=rate, expected="a number in [0, 1]")
    if not 0 < confidence < 1:
        raise ConfigError(field="--confidence", value=confidence, expected="a number in (0, 1)")
    z = NormalDist().inv_cdf(0.5 + confidence / 2)
    hi = 1
    while wilson_reach(p, hi, z) > margin:
        hi *= 2
    lo = hi // 2  # reach(lo) > margin unless lo == 0
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if wilson_reach(p, mid, z) > margin:
            lo = mid
        else:
            hi = mid
    return hi


def flip_probability(k: int, m: int) -> float:
    """Unbiased chance that two of the ``m`` seeds disagree, ``k`` of them failing."""
    return 2.0 * k * (m - k) / (m * (m - 1)) if m >= 2 else 0.0


def _group(cells: Sequence[tuple[int, int]], rng: np.random.Generator) -> dict[str, Any]:
    """Flakiness of a group of situations given as (failures, judged seeds)."""
    cells = [(k, m) for k, m in cells if m >= 2]
    n = len(cells)
    flaky = sum(1 for k, m in cells if 0 < k < m)
    flips = np.array([flip_probability(k, m) for k, m in cells])
    out: dict[str, Any] = {
        "situations": n,
        "flaky": flaky,
        "flaky_share": flaky / n if n else None,
        "flaky_ci95": list(wilson_interval(flaky, n)) if n else None,
        "flip": float(flips.mean()) if n else None,
        "flip_ci95": None,
        "runs": int(sum(m for _, m in cells)),
        "failures": int(sum(k for k, _ in cells)),
    }
    if n >= 2:
        boot = flips[rng.integers(0, n, size=(BOOTSTRAP, n))].mean(axis=1)
        out["flip_ci95"] = [float(np.quantile(boot, 0.025)), float(np.quantile(boot, 0.975))]
    elif n == 1:
        out["flip_ci95"] = [out["flip"], out["flip"]]
    return out


def flakiness(
    hs: Hyperspace,
    situations: Sequence[tuple[Mapping[str, str], Sequence[str]]],
    seed: int = 0,
) -> dict[str, Any]:
    """Flakiness overall, per bin, and the flakiest situations.

    Args:
        hs: the hyperspace (which elements and bins to report).
        situations: per situation, its bins and the statuses of its runs (one per seed);
            only ``pass``/``fail`` count.
        seed: seed of the bootstrap.

    Returns:
        ``overall`` and ``elements[element][bin]`` as from :func:`_group`, ``repeats``
        (most seeds per situation) and ``flakiest`` (up to 10 situations with the highest
        flip probability: their position, bins, failures and judged runs).
    """
    rng = np.random.default_rng(seed)
    cells = []
    for bins, statuses in situations:
        judged = [s for s in statuses if s in ("pass", "fail")]
        cells.append((dict(bins), sum(s == "fail" for s in judged), len(judged)))
    elements: dict[str, dict[str, Any]] = {}
    for el in hs.elements:
        elements[el.name] = {
            label: _group([(k, m) for b, k, m in cells if b.get(el.name) == label], rng)
            for label in el.labels
        }
    ranked = sorted(
        range(len(cells)), key=lambda i: (-flip_probability(cells[i][1], cells[i][2]), i)
    )
    flakiest = [
        {"position": i, "bins": cells[i][0], "failures": cells[i][1], "judged": cells[i][2]}
        for i in ranked[:10]
        if 0 < cells[i][1] < cells[i][2]
    ]
    return {
        "overall": _group([(k, m) for _, k, m in cells], rng),
        "repeats": max((m for _, _, m in cells), default=0),
        "elements": elements,
        "flakiest": flakiest,
    }
