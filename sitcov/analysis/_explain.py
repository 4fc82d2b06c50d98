"""Which elements, and which pairs of elements, change the failure probability.

Method (docs/explain.md):

1. Judged runs only (pass = 0, fail = 1); error, timeout and pending runs are excluded and
   counted. A campaign with fewer than ``min_runs`` judged runs, or fewer than 5 failures
   or 5 passes, gets "not enough runs" instead of statistics.
2. A logistic model with one indicator per bin (treatment coding, the most-run bin of each
   element as reference, lightly ridge-penalised: see ``_logit``). Per element, a
   likelihood-ratio test of the main-effects model against the same model without that
   element; per pair of elements, a likelihood-ratio test of the main-effects model plus
   the pair's interaction cells against the main-effects model. Sparse cells are merged:
   only cells with at least ``min_cell`` judged runs get their own interaction column, the
   others stay with the main-effects prediction (and do not count as degrees of freedom).
   Because one deviating cell is diluted in a 25-55 df omnibus test, each pair also gets a
   focused test: its largest standardised cell residual under the main-effects fit.
3. Multiple comparisons, family-wise error rate ``alpha`` per family: Holm over the
   element tests, each LR statistic divided by its Bartlett factor measured by a
   parametric bootstrap (the chi-square alone is anti-conservative with tens of
   parameters and hundreds of runs); under ``MIN_RUNS_PER_PARAMETER`` judged runs per
   parameter, each element's smallest exact per-bin p (Bonferroni over its bins) instead,
   and no pair test; over the pair tests (the smaller of each pair's two p-values), the
   single-step min-p adjustment (Westfall-Young) calibrated by a parametric bootstrap
   under the main-effects fit, because the chi-square
   approximation of a 25-55 df test on cells of 5-20 runs is anti-conservative (a null
   simulation of 600 runs gave a Holm false alarm in 6 of 30 campaigns).
4. Effect sizes with the counts behind them: per bin, the failure rate in the bin vs the
   rest (Wilson intervals), the risk difference (Newcombe interval) and the odds ratio
   (Woolf interval); per significant pair, the cell furthest from the main-effects
   prediction and the risk difference of its bin inside vs outside the other bin.
5. Findings are ranked by the deviance the term explains beyond chance (LR - df), for
   pairs too: a cell with one failure where the main effects predict 0.1 % has a huge
   residual but explains little.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Mapping, Sequence
from itertools import combinations
from typing import Any

import numpy as np

from sitcov.analysis._logit import (
    fit_logit,
    holm,
    indicator_columns,
    newcombe_difference,
    odds_ratio,
    single_thread,
)
from sitcov.analysis._stats import wilson_interval
from sitcov.hyperspace import Hyperspace

#: fewest judged runs (pass + fail) for any statistics at all
MIN_RUNS = 50
#: fewest failures and fewest passes for any statistics at all
MIN_EACH = 5
#: fewest judged runs in a cell of two bins for it to get its own interaction column
MIN_CELL = 5
#: A progress callback: ``(stage, done, total)``.
Progress = Callable[[str, int, int], None]
#: parametric-bootstrap replicates calibrating the pair tests (adjusted p >= 1/(B+1))
BOOTSTRAP = 99
#: parametric-bootstrap replicates measuring the element tests' Bartlett factor (0: none)
ELEMENT_BOOTSTRAP = 39
#: fewest judged runs per main-effects parameter for the model-based tests: below it they
#: call null elements and pairs significant far more often than alpha (200 runs of the
#: default hyperspace's 52 parameters, before this rule: a null element in 49 %, a pair in
#: 73 % of simulated campaigns; docs/explain.md, "Calibration"), so the element tests fall
#: back on exact per-bin tests and the pair tests are not run
MIN_RUNS_PER_PARAMETER = 6
#: judged runs per main-effects parameter from which the element tests' Bartlett factor is
#: taken as 1 (not measured): it shrinks as parameters / runs (1.27 at 7.7 runs per
#: parameter, 1.08 at 19; docs/explain.md, "Calibration"), while its bootstrap's cost grows
#: with the runs (a 100,000-run report would spend minutes on it)
BARTLETT_RUNS_PER_PARAMETER = 40


def _field(run: Any, name: str) -> Any:
    return run[name] if isinstance(run, Mapping) else getattr(run, name)


def encode_runs(
    hyperspace: Hyperspace, runs: Iterable[Any]
) -> tuple[np.ndarray, np.ndarray, dict[str, int]]:
    """Bin indices (n x elements) and failure flags of the judged runs, and the counts
    of the runs left out (``error``, ``timeout``, ``pending``, ``unmatched``)."""
    names = hyperspace.element_names
    lookup = hyperspace._label_index
    left_out = {"error": 0, "timeout": 0, "pending": 0, "unmatched": 0}
    rows, ys = [], []
    for run in runs:
        status = _field(run, "status")
        if status not in ("pass", "fail"):
            left_out[status if status in left_out else "error"] += 1
            continue
        bins = _field(run, "bins")
        idx = [lookup[e].get(bins.get(name)) for e, name in enumerate(names)]
        if any(i is None for i in idx):
            left_out["unmatched"] += 1
            continue
        rows.append(idx)
        ys.append(1.0 if status == "fail" else 0.0)
    codes = np.array(rows, dtype=int).reshape(len(rows), len(names))
    return codes, np.array(ys), left_out


class _Design:
    """Main-effects design: intercept + one column per non-reference bin that has runs."""

    def __init__(self, codes: np.ndarray, sizes: Sequence[int]) -> None:
        self.codes = codes
        self.refs, self.levels = [], []
        for e, size in enumerate(sizes):
            counts = np.bincount(codes[:, e], minlength=size)
            ref = int(np.argmax(counts))
            self.refs.append(ref)
            self.levels.append([lv for lv in range(size) if lv != ref and counts[lv] > 0])
        self.blocks = [indicator_columns(codes[:, e], lv) for e, lv in enumerate(self.levels)]

    def matrix(self, drop: int | None = None, extra: np.ndarray | None = None) -> np.ndarray:
        cols = [np.ones((self.codes.shape[0], 1))]
        cols += [b for e, b in enumerate(self.blocks) if e != drop]
        if extra is not None:
            cols.append(extra)
        return np.hstack(cols)

    def interaction(self, a: int, b: int, min_cell: int) -> tuple[np.ndarray, int]:
        """Columns for the cells (bin of a, bin of b) off both references with enough runs."""
        ca, cb = self.codes[:, a], self.codes[:, b]
        cols = []
        for la in self.levels[a]:
            for lb in self.levels[b]:
                cell = (ca == la) & (cb == lb)
                if cell.sum() >= min_cell:
                    cols.append(cell.astype(float))
        if not cols:
            return np.zeros((len(ca), 0)), 0
        return np.stack(cols, axis=1), len(cols)


def _rate_row(k: int, n: int) -> dict[str, Any]:
    ci = wilson_interval(k, n)
    return {
        "failures": k,
        "judged": n,
        "rate": k / n if n else None,
        "ci95": list(ci) if ci else None,
    }


def _bin_effects(
    hs: Hyperspace, codes: np.ndarray, y: np.ndarray, e: int, alpha: float
) -> list[dict[str, Any]]:
    """Per bin of element ``e``: in-bin vs rest rates, risk difference, odds ratio, Fisher p."""
    from scipy.stats import fisher_exact

    rows = []
    total_k, total_n = int(y.sum()), len(y)
    for lv, label in enumerate(hs.elements[e].labels):
        mask = codes[:, e] == lv
        k, n = int(y[mask].sum()), int(mask.sum())
        rk, rn = total_k - k, total_n - n
        if n == 0 or rn == 0:
            continue
        rd = newcombe_difference(k, n, rk, rn)
        odds = odds_ratio(k, n, rk, rn)
        _, p = fisher_exact([[k, n - k], [rk, rn - rk]])
        rows.append(
            {
                "label": label,
                "bin": _rate_row(k, n),
                "rest": _rate_row(rk, rn),
                "risk_difference": rd[0],
                "risk_difference_ci95": [rd[1], rd[2]],
                "odds_ratio": odds[0],
                "odds_ratio_ci95": [odds[1], odds[2]],
                "p": float(p),
            }
        )
    for row, adj in zip(rows, holm([r["p"] for r in rows]), strict=True):
        row["p_adjusted"] = adj
        row["stands_out"] = adj < alpha
    return rows


def _pct(x: float | None) -> str:
    return "?" if x is None else f"{100 * x:.0f}%"


def _ci(ci: Sequence[float] | None) -> str:
    return "" if ci is None else f" [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]"


def _pval(p: float | None) -> str:
    if p is None:
        return "p = n/a"
    return "p < 1e-16" if p < 1e-16 else f"p = {p:.2g}"


def _element_text(name: str, test: dict[str, Any]) -> str:
    bins = test["bins"]
    out = [b for b in bins if b["stands_out"]]
    if not out:
        lo = min(bins, key=lambda b: b["bin"]["rate"])
        hi = max(bins, key=lambda b: b["bin"]["rate"])
        return (
            f"{name} matters ({_pval(test['p_adjusted'])}, Holm-adjusted): failure rate from "
            f"{_pct(lo['bin']['rate'])} at {lo['label']} to {_pct(hi['bin']['rate'])} at "
            f"{hi['label']}; no single bin differs from the rest on its own"
        )
    # where it fails more first (most to least), then where it fails less
    out.sort(key=lambda b: (b["risk_difference"] < 0, -abs(b["risk_difference"])))
    parts = []
    for b in out[:3]:
        parts.append(
            f"{name} {b['label']} fails {_pct(b['bin']['rate'])}{_ci(b['bin']['ci95'])} "
            f"({b['bin']['failures']}/{b['bin']['judged']}) vs {_pct(b['rest']['rate'])} "
            f"elsewhere ({b['rest']['failures']}/{b['rest']['judged']})"
        )
    more = f"; {len(out) - 3} more bins differ" if len(out) > 3 else ""
    return "; ".join(parts) + f" (element {_pval(test['p_adjusted'])}, Holm-adjusted){more}"


def _contrast(codes: np.ndarray, y: np.ndarray, a: int, la: int, b: int, lb: int) -> dict:
    """Risk difference of bin la of element a vs its other bins, inside and outside bin lb."""
    in_a = codes[:, a] == la
    out = {}
    for key, where in (("inside", codes[:, b] == lb), ("outside", codes[:, b] != lb)):
        k1, n1 = int(y[where & in_a].sum()), int((where & in_a).sum())
        k2, n2 = int(y[where & ~in_a].sum()), int((where & ~in_a).sum())
        rd = newcombe_difference(k1, n1, k2, n2)
        out[key] = {
            "with": _rate_row(k1, n1),
            "without": _rate_row(k2, n2),
            "risk_difference": None if rd is None else rd[0],
            "risk_difference_ci95": None if rd is None else [rd[1], rd[2]],
        }
    return out


def _top_cell(
    hs: Hyperspace, codes: np.ndarray, y: np.ndarray, prob: np.ndarray, a: int, b: int
) -> dict[str, Any] | None:
    """The cell of (a, b) furthest from the main-effects prediction (standardised)."""
    best, best_z = None, 0.0
    for la in range(hs.sizes[a]):
        for lb in range(hs.sizes[b]):
            cell = (codes[:, a] == la) & (codes[:, b] == lb)
            n = int(cell.sum())
            if n < MIN_CELL:
                continue
            k, expected = float(y[cell].sum()), float(prob[cell].sum())
            var = float((prob[cell] * (1 - prob[cell])).sum())
            z = (k - expected) / np.sqrt(max(var, 1e-9))
            if abs(z) > abs(best_z):
                best_z, best = z, (la, lb, int(k), n, expected / n)
    if best is None:
        return None
    la, lb, k, n, predicted = best
    # orient: the element whose bin's effect changes most between inside and outside
    options = []
    for (x, lx), (o, lo) in (((a, la), (b, lb)), ((b, lb), (a, la))):
        c = _contrast(codes, y, x, lx, o, lo)
        ins, outs = c["inside"]["risk_difference"], c["outside"]["risk_difference"]
        gap = abs((ins or 0.0) - (outs or 0.0))
        options.append((gap, x, lx, o, lo, c))
    _, x, lx, o, lo, contrast = max(options, key=lambda t: t[0])
    names = hs.element_names
    return {
        "cell": {names[a]: hs.elements[a].labels[la], names[b]: hs.elements[b].labels[lb]},
        **_rate_row(k, n),
        "predicted_main_effects": predicted,
        "z": float(best_z),
        "modifier": {"element": names[x], "label": hs.elements[x].labels[lx]},
        "context": {"element": names[o], "label": hs.elements[o].labels[lo]},
        "contrast": contrast,
    }


def _rd_text(side: dict[str, Any]) -> str:
    if side["risk_difference"] is None:
        return "n/a (no runs)"
    lo, hi = side["risk_difference_ci95"]
    return (
        f"{100 * side['risk_difference']:+.0f} pts [{100 * lo:+.0f}, {100 * hi:+.0f}] "
        f"({side['with']['failures']}/{side['with']['judged']} vs "
        f"{side['without']['failures']}/{side['without']['judged']})"
    )


def _pair_text(test: dict[str, Any]) -> str:
    cell = test["top_cell"]
    m, c = cell["modifier"], cell["context"]
    ctr = cell["contrast"]
    return (
        f"{m['element']}={m['label']} changes the failure rate by {_rd_text(ctr['inside'])} "
        f"when {c['element']}={c['label']}, by {_rd_text(ctr['outside'])} otherwise; the cell "
        f"fails {_pct(cell['rate'])}{_ci(cell['ci95'])} ({cell['failures']}/{cell['judged']}) "
        f"where main effects predict {_pct(cell['predicted_main_effects'])} "
        f"(interaction {_pval(test['p_adjusted'])}, bootstrap-adjusted, df {test['df']})"
    )


def _method_text(exact_params: int | None, element_bootstrap: int, bootstrap: int) -> str:
    """How the findings were tested, as the output's header says it; ``exact_params``: the
    main-effects model's parameters when the runs were too few for the model-based tests
    (None: they were run)."""
    if exact_params is not None:
        return (
            f"too few runs for the model-based tests (>= {MIN_RUNS_PER_PARAMETER} judged runs "
            f"per parameter of the main-effects model: "
            f"{MIN_RUNS_PER_PARAMETER * exact_params} here; docs/explain.md, Calibration); "
            "elements: the smallest Fisher exact p of their bins, Bonferroni over the bins, "
            "Holm over elements; pairs not tested"
        )
    scaled = (
        f" divided by its Bartlett factor from a {element_bootstrap}-replicate parametric "
        "bootstrap" if element_bootstrap > 0 else ""
    )  # fmt: skip
    pairs = (
        "likelihood-ratio test of the interaction cells and a largest-cell-residual test, "
        f"family-wise min-p adjusted over pairs by a {bootstrap}-replicate parametric "
        "bootstrap under the main-effects model" if bootstrap > 0 else "not tested"
    )  # fmt: skip
    return (
        "ridge logistic regression on bin indicators; elements: likelihood-ratio test vs "
        f"the model without the element{scaled}, Holm over elements; pairs: {pairs}"
    )


def _not_enough(n: int, k: int, min_runs: int) -> str | None:
    if n < min_runs or k < MIN_EACH or n - k < MIN_EACH:
        return (
            f"not enough runs: {n} judged runs with {k} failures and {n - k} passes "
            f"(need >= {min_runs} judged runs with >= {MIN_EACH} failures and >= "
            f"{MIN_EACH} passes)"
        )
    return None


def interaction_analysis(
    hyperspace: Hyperspace,
    runs: Iterable[Any],
    *,
    alpha: float = 0.05,
    min_runs: int = MIN_RUNS,
    min_cell: int = MIN_CELL,
    bootstrap: int = BOOTSTRAP,
    element_bootstrap: int = ELEMENT_BOOTSTRAP,
    seed: int = 0,
    progress: Progress | None = None,
) -> dict[str, Any]:
    """Main-effect and pairwise-interaction tests with effect sizes and ranked findings.

    Args:
        hyperspace: the hyperspace the runs were generated in.
        runs: stored runs (``.bins`` and ``.status``) or mappings with those keys.
        alpha: family-wise error rate, separately for the element tests (Holm) and for
            the pair tests (bootstrap min-p).
        min_runs: fewest judged runs for any statistics.
        min_cell: fewest judged runs for a cell to get its own interaction column.
        bootstrap: parametric-bootstrap replicates calibrating the pair tests; 0 skips
            the pair tests (the report does: they take most of the time).
        element_bootstrap: parametric-bootstrap replicates measuring the element tests'
            Bartlett factor (:func:`_bartlett_factor`); 0 uses the chi-square as it is.
        seed: seed of the bootstrap's numpy Generator.
        progress: called as ``progress(stage, done, total)`` (e.g. after each bootstrap
            replicate: the pair tests take most of the time).

    Returns:
        JSON-ready dict: ``judged``, ``failures``, ``excluded`` (counts per status),
        ``message`` (None, or why there are no statistics), ``elements`` and ``pairs``
        (tests), ``findings`` (ranked, most important first, each with ``text``).
    """
    codes, y, excluded = encode_runs(hyperspace, runs)
    n, k = len(y), int(y.sum())
    out: dict[str, Any] = {
        "judged": n,
        "failures": k,
        "excluded": excluded,
        "alpha": alpha,
        "method": _method_text(None, element_bootstrap, bootstrap),
        "bootstrap": bootstrap,
        "element_bootstrap": element_bootstrap,
        "element_lr_scale": None,
        "seed": seed,
        "message": _not_enough(n, k, min_runs),
        "elements": [],
        "pairs": [],
        "findings": [],
    }
    if out["message"]:
        return out
    tick = progress or (lambda _stage, _done, _total: None)
    with single_thread():
        tick("element tests", 0, 1)
        design = _Design(codes, hyperspace.sizes)
        x_main = design.matrix()
        main = fit_logit(x_main, y)
        reduced = _reduced_models(design, y)
        params = x_main.shape[1]
        exact = n < MIN_RUNS_PER_PARAMETER * params
        replicates = element_bootstrap if n < BARTLETT_RUNS_PER_PARAMETER * params else 0
        scale = 1.0 if exact else _bartlett_factor(x_main, main, reduced, replicates, seed)
        out["element_lr_scale"] = None if exact else round(scale, 4)
        out["method"] = _method_text(None if not exact else params, replicates, bootstrap)
        out["elements"] = _element_tests(
            hyperspace, design, codes, y, main, reduced, alpha, scale, exact
        )
        tick("element tests", 1, 1)
        if bootstrap > 0 and not exact:
            out["pairs"] = _pair_tests(
                hyperspace, design, y, main, min_cell, bootstrap, seed, alpha, tick
            )
    for t in out["pairs"]:
        a, b = t.pop("ab")
        if t["significant"]:
            t["top_cell"] = _top_cell(hyperspace, codes, y, main.prob, a, b)
    out["findings"] = _findings(out["elements"], out["pairs"])
    return out


def _element_tests(
    hs: Hyperspace, design: _Design, codes: np.ndarray, y: np.ndarray, main: Any,
    reduced: Sequence[tuple[np.ndarray, Any]], alpha: float, scale: float = 1.0,
    exact: bool = False,
) -> list[dict[str, Any]]:  # fmt: skip
    """Per element, the LR test against the model without it (``reduced``,
    :func:`_reduced_models`),
    the statistic divided by ``scale`` (:func:`_bartlett_factor`), Holm over elements;
    ``exact``: the element's p is its smallest per-bin Fisher exact p times its number of
    bins instead (valid at any size; the LR still ranks the findings)."""
    from scipy.stats import chi2

    tests = []
    for e, name in enumerate(hs.element_names):
        df = len(design.levels[e])
        lr = max(0.0, reduced[e][1].deviance - main.deviance)
        bins = _bin_effects(hs, codes, y, e, alpha)
        if exact:  # the smallest exact bin p, Bonferroni over the bins
            p = min(1.0, len(bins) * min(b["p"] for b in bins)) if df > 0 else None
        else:
            p = float(chi2.sf(lr / scale, df)) if df > 0 else None
        tests.append({"element": name, "df": df, "lr": lr, "p": p, "bins": bins})
    tested = [t for t in tests if t["p"] is not None]
    for t, adj in zip(tested, holm([t["p"] for t in tested]), strict=True):
        t["p_adjusted"] = adj
    for t in tests:
        _mark(t, t.get("p_adjusted"), alpha)
    return tests


def _reduced_models(design: _Design, y: np.ndarray) -> list[tuple[np.ndarray, Any]]:
    """The main-effects model without each element in turn: (its design, its fit to ``y``)."""
    models = []
    for e in range(len(design.levels)):
        x = design.matrix(drop=e)
        models.append((x, fit_logit(x, y)))
    return models


def _bartlett_factor(
    x_main: np.ndarray,
    main: Any,
    reduced: Sequence[tuple[np.ndarray, Any]],
    replicates: int,
    seed: int,
) -> float:
    """How much the element LR statistics exceed their degrees of freedom under the null:
    per replicate and element, outcomes are drawn from the fit without the element, both
    models refitted and the LR recomputed; the factor is the sum of those LRs over the sum
    of their df (1 without replicates). With tens of bins per element and a few hundred
    runs the chi-square approximation is anti-conservative (docs/explain.md, "Calibration":
    the null LR statistics average 1.08 times their df at 1,000 runs), and dividing
    by the measured factor (a bootstrap Bartlett correction, Rocke 1989) gives it back its
    nominal level; pooled over elements, a few tens of replicates measure it to a few %."""
    if replicates <= 0:
        return 1.0
    rng = np.random.default_rng([seed, 1])  # not the pair tests' stream
    total_lr = total_df = 0.0
    for _ in range(replicates):
        for x_small, fit in reduced:
            df = x_main.shape[1] - x_small.shape[1]  # the element's columns
            if not df:
                continue
            y_star = (rng.random(len(fit.prob)) < fit.prob).astype(float)
            small = fit_logit(x_small, y_star, start=fit.coef)
            big = fit_logit(x_main, y_star, start=main.coef)
            total_lr += max(0.0, small.deviance - big.deviance)
            total_df += df
    return total_lr / total_df if total_df else 1.0


def _pair_lr(x_main: np.ndarray, cols: np.ndarray, y: np.ndarray, main: Any) -> float:
    start = np.concatenate([main.coef, np.zeros(cols.shape[1])])
    dev = fit_logit(np.hstack([x_main, cols]), y, start=start).deviance
    return max(0.0, main.deviance - dev)


def _cell_matrix(codes: np.ndarray, a: int, b: int, min_cell: int) -> np.ndarray:
    """0/1 columns, one per cell (bin of a, bin of b) with at least ``min_cell`` runs."""
    keys = codes[:, a] * (codes[:, b].max() + 1) + codes[:, b]
    levels, counts = np.unique(keys, return_counts=True)
    return indicator_columns(keys, [int(lv) for lv in levels[counts >= min_cell]])


def _max_cell(cells: np.ndarray, y: np.ndarray, prob: np.ndarray) -> tuple[float, float]:
    """Largest squared standardised cell residual under ``prob``, and its p-value made
    Bonferroni over the pair's cells (a 1-df focused test of one deviating cell)."""
    from scipy.stats import chi2

    if not cells.shape[1]:
        return 0.0, 1.0
    z = cells.T @ (y - prob) / np.sqrt(np.maximum(cells.T @ (prob * (1 - prob)), 1e-12))
    z2 = float(np.max(z * z))
    return z2, min(1.0, cells.shape[1] * float(chi2.sf(z2, 1)))


def _pair_stats(
    tests: list[dict[str, Any]], x_main: np.ndarray, y: np.ndarray, main: Any
) -> list[tuple[float, float, float]]:
    """(LR, LR p, cell p) per pair under the outcomes ``y``."""
    from scipy.stats import chi2

    out = []
    for t in tests:
        lr = _pair_lr(x_main, t["cols"], y, main) if t["df"] else 0.0
        p_lr = float(chi2.sf(lr, t["df"])) if t["df"] else 1.0
        out.append((lr, p_lr, _max_cell(t["cells"], y, main.prob)[1]))
    return out


def _pair_tests(
    hs: Hyperspace,
    design: _Design,
    y: np.ndarray,
    main: Any,
    min_cell: int,
    bootstrap: int,
    seed: int,
    alpha: float,
    tick: Progress,
) -> list[dict[str, Any]]:
    """Two tests per pair: the omnibus LR test of all its interaction cells, and a focused
    test of its most deviating cell (score residual); the pair's statistic is the smaller
    of the two p-values. Adjusted by the single-step bootstrap min-p method (Westfall &
    Young): the share of replicates, simulated from the main-effects fit, whose smallest
    pair statistic is at most the observed one. The bootstrap calibrates both the sparse
    cells and the choice of the smaller p-value."""
    names = hs.element_names
    x_main = design.matrix()
    pairs = []
    for a, b in combinations(range(len(names)), 2):
        cols, df = design.interaction(a, b, min_cell)
        cells = _cell_matrix(design.codes, a, b, min_cell)
        pairs.append({"elements": [names[a], names[b]], "ab": (a, b), "df": df,
                      "cols": cols, "cells": cells})  # fmt: skip
    for t, (lr, p_lr, p_cell) in zip(pairs, _pair_stats(pairs, x_main, y, main), strict=True):
        t.update(lr=lr, p=p_lr if t["df"] else None, p_cell=p_cell, stat=min(p_lr, p_cell))
        t["cell_z2"] = _max_cell(t["cells"], y, main.prob)[0]
    rng = np.random.default_rng(seed)
    min_p = np.ones(bootstrap)
    tick("pair tests (bootstrap)", 0, bootstrap)
    for r in range(bootstrap):
        y_star = (rng.random(len(y)) < main.prob).astype(float)
        main_star = fit_logit(x_main, y_star, start=main.coef)
        stats = _pair_stats(pairs, x_main, y_star, main_star)
        min_p[r] = min((min(p1, p2) for _, p1, p2 in stats), default=1.0)
        tick("pair tests (bootstrap)", r + 1, bootstrap)
    for t in pairs:
        del t["cols"], t["cells"]
        adj = float((1 + np.sum(min_p <= t.pop("stat"))) / (bootstrap + 1))
        _mark(t, adj, alpha)
    return pairs


def _mark(test: dict[str, Any], adjusted: float | None, alpha: float) -> None:
    test["p_adjusted"] = adjusted
    test["significant"] = adjusted is not None and adjusted < alpha
    test["importance"] = test["lr"] - test["df"]


def _findings(elements: list[dict], pairs: list[dict]) -> list[dict[str, Any]]:
    found = []
    for t in elements:
        if t["significant"]:
            found.append({"kind": "element", "element": t["element"],
                          "importance": t["importance"], "p_adjusted": t["p_adjusted"],
                          "text": _element_text(t["element"], t)})  # fmt: skip
    for t in pairs:
        if t["significant"] and t.get("top_cell"):
            found.append({"kind": "interaction", "elements": t["elements"],
                          "importance": t["importance"], "p_adjusted": t["p_adjusted"],
                          "text": _pair_text(t)})  # fmt: skip
    found.sort(key=lambda f: -f["importance"])
    return found
