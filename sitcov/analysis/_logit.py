"""A small ridge-penalised logistic regression over bins, and the tests built on it.

Why here and not statsmodels: the models are tiny (tens of indicator columns), the only
things needed are the deviance of nested fits and their difference, and a light ridge
penalty keeps the fit finite when a bin never fails (complete separation is the rule, not
the exception, in failure data). Newton-Raphson (IRLS) with step halving converges in a
handful of iterations.
"""

from __future__ import annotations

import contextlib
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

#: ridge penalty on every non-intercept coefficient [-]; small enough that the deviance of
#: a well-determined fit moves by < 0.1, large enough to keep separated bins finite.
RIDGE = 0.01


@dataclass(frozen=True)
class LogitFit:
    """A fitted model.

    Attributes:
        coef: coefficients (the first is the intercept).
        deviance: -2 log-likelihood of the data at ``coef`` (penalty excluded).
        prob: fitted failure probability per run.
    """

    coef: np.ndarray
    deviance: float
    prob: np.ndarray


def _deviance(y: np.ndarray, p: np.ndarray) -> float:
    p = np.clip(p, 1e-12, 1 - 1e-12)
    return float(-2.0 * np.sum(y * np.log(p) + (1 - y) * np.log1p(-p)))


def _sigmoid(eta: np.ndarray) -> np.ndarray:
    return 1.0 / (1.0 + np.exp(-np.clip(eta, -30.0, 30.0)))


def fit_logit(
    x: np.ndarray,
    y: np.ndarray,
    ridge: float = RIDGE,
    iters: int = 100,
    start: np.ndarray | None = None,
) -> LogitFit:
    """Fit ``P(fail) = sigmoid(x @ coef)`` by penalised Newton-Raphson.

    Args:
        x: design matrix (n runs x p columns), first column all ones (not penalised).
        y: 1 for a failure, 0 for a pass.
        ridge: L2 penalty on the other columns.
        iters: iteration cap (convergence usually takes < 15).
        start: initial coefficients (e.g. a nested model's, padded with zeros).
    """
    n, p = x.shape
    penalty = np.full(p, ridge)
    penalty[0] = 0.0
    if start is not None:
        coef = np.array(start, dtype=float)
    else:
        coef = np.zeros(p)
        mean = float(np.clip(y.mean(), 1e-3, 1 - 1e-3)) if n else 0.5
        coef[0] = math.log(mean / (1 - mean))

    def objective(c: np.ndarray) -> float:
        return _deviance(y, _sigmoid(x @ c)) / 2 + 0.5 * float(np.sum(penalty * c * c))

    current = objective(coef)
    for _ in range(iters):
        prob = _sigmoid(x @ coef)
        w = prob * (1 - prob)
        grad = x.T @ (prob - y) + penalty * coef
        hess = (x.T * w) @ x + np.diag(penalty + 1e-9)
        step = np.linalg.solve(hess, grad)
        scale = 1.0
        while scale > 1e-6:
            trial = coef - scale * step
            value = objective(trial)
            if value <= current + 1e-12:
                break
            scale /= 2
        if value > current + 1e-12:
            break  # no step improves the penalised likelihood: at the optimum
        converged = current - value < 1e-9
        coef, current = trial, value
        if converged:
            break
    prob = _sigmoid(x @ coef)
    return LogitFit(coef, _deviance(y, prob), prob)


def single_thread() -> Any:
    """A context limiting BLAS to one thread: these matrices are tiny, and on a shared
    machine a threaded BLAS makes each fit ~30x slower. threadpoolctl is a core dependency
    (without it, as before issue 26, ``sitcov explain`` took 60-130 CPU-s on 600 runs);
    an install that lacks it still works, slowly."""
    try:
        from threadpoolctl import threadpool_limits
    except ImportError:
        return contextlib.nullcontext()
    return threadpool_limits(1)


def indicator_columns(codes: np.ndarray, levels: Sequence[int]) -> np.ndarray:
    """One 0/1 column per level in ``levels`` (``codes == level``)."""
    if not levels:
        return np.zeros((codes.shape[0], 0))
    return np.stack([(codes == lv).astype(float) for lv in levels], axis=1)


def holm(pvalues: Sequence[float]) -> list[float]:
    """Holm's step-down adjusted p-values (family-wise error control, any dependence)."""
    m = len(pvalues)
    order = sorted(range(m), key=lambda i: pvalues[i])
    out = [1.0] * m
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * pvalues[i]))
        out[i] = running
    return out


def newcombe_difference(
    k1: int, n1: int, k2: int, n2: int, z: float = 1.959963984540054
) -> tuple[float, float, float] | None:
    """Risk difference ``k1/n1 - k2/n2`` with Newcombe's hybrid score 95% interval.

    Built from the two Wilson intervals (Newcombe 1998, method 10): stays in [-1, 1] and
    behaves at 0 and 100 %. None when either group is empty.
    """
    from sitcov.analysis._stats import wilson_interval

    a, b = wilson_interval(k1, n1, z), wilson_interval(k2, n2, z)
    if a is None or b is None:
        return None
    p1, p2 = k1 / n1, k2 / n2
    d = p1 - p2
    lo = d - math.sqrt((p1 - a[0]) ** 2 + (b[1] - p2) ** 2)
    hi = d + math.sqrt((a[1] - p1) ** 2 + (p2 - b[0]) ** 2)
    return d, max(-1.0, lo), min(1.0, hi)


def odds_ratio(
    k1: int, n1: int, k2: int, n2: int, z: float = 1.959963984540054
) -> tuple[float, float, float]:
    """Odds ratio of failing in group 1 vs group 2, Woolf (log) 95% interval, with 0.5
    added to every cell (Haldane-Anscombe) so that empty cells give finite numbers."""
    a, b, c, d = k1 + 0.5, n1 - k1 + 0.5, k2 + 0.5, n2 - k2 + 0.5
    log_or = math.log(a * d / (b * c))
    se = math.sqrt(1 / a + 1 / b + 1 / c + 1 / d)
    return math.exp(log_or), math.exp(log_or - z * se), math.exp(log_or + z * se)
