"""Failure regions: readable rules over bins, measured on runs they were not fitted on.

The judged runs are split by a seeded permutation into a fitting part (2/3) and a held-out
part (1/3). A shallow decision tree (CART, Gini, depth <= 3; ``_tree``) is fitted on the fitting
part; subtrees whose leaves all give the same verdict are merged, and every leaf whose
fitted failure rate is at least 50 % and at least the overall rate becomes a rule, the
conjunction of the conditions on its path. Each rule's support,
precision (with a Wilson interval) and recall are then counted on the held-out runs only.

A rule is kept only when the lower end of its held-out precision's Wilson 95 % interval is
above the held-out base failure rate: a rule that merely matches the average, measured on
runs it was not fitted on, is dropped (listed under ``dropped``), not shown as a finding.

Encoding, so that rules read as bins: an element whose bins are numbers is ordinal (bin
index in hyperspace order; a split reads ``friction <= 0.2``); any other element (e.g.
``intsit``) is categorical, its bins ordered by their failure rate on the fitting part, so
that one split is a set of bins (``intsit in {IntSit-2, IntSit-11}``): for a binary outcome
this ordering contains the best subset split (Breiman et al. 1984, section 9.4).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np

from sitcov.analysis._explain import MIN_RUNS, _not_enough, encode_runs
from sitcov.analysis._stats import wilson_interval
from sitcov.analysis._tree import grow
from sitcov.hyperspace import Hyperspace

#: share of the judged runs held out to measure the rules
HOLDOUT = 1 / 3
#: depth of the tree (rules have at most this many conditions)
MAX_DEPTH = 3
#: a categorical condition with more bins than this is written grouped (by road-user kind
#: and conflict type where the bins carry them), the full list staying in ``bins``
MAX_LISTED = 6


def _is_ordinal(hs: Hyperspace, e: int) -> bool:
    return all(b.kind in ("point", "range") for b in hs.elements[e].bins)


def _orders(hs: Hyperspace, codes: np.ndarray, y: np.ndarray) -> list[list[int]]:
    """Per element, bin indices in feature order (hyperspace order, or by failure rate)."""
    base = float(y.mean())
    orders = []
    for e, size in enumerate(hs.sizes):
        if _is_ordinal(hs, e):
            orders.append(list(range(size)))
            continue
        rates = []
        for lv in range(size):
            mask = codes[:, e] == lv
            rates.append(float(y[mask].mean()) if mask.any() else base)
        orders.append(sorted(range(size), key=lambda lv: (rates[lv], lv)))
    return orders


def _features(codes: np.ndarray, orders: list[list[int]]) -> np.ndarray:
    x = np.empty(codes.shape, dtype=float)
    for e, order in enumerate(orders):
        position = np.empty(len(order), dtype=int)
        position[order] = np.arange(len(order))
        x[:, e] = position[codes[:, e]]
    return x


def _conditions(
    hs: Hyperspace, orders: list[list[int]], lo: np.ndarray, hi: np.ndarray
) -> list[dict[str, Any]]:
    """The path's bounds as conditions: element, the bins allowed, and a text."""
    conds = []
    for e, order in enumerate(orders):
        kept = [lv for pos, lv in enumerate(order) if lo[e] < pos <= hi[e]]
        if len(kept) == len(order):
            continue
        el = hs.elements[e]
        labels = [el.labels[lv] for lv in sorted(kept)]
        if _is_ordinal(hs, e):
            first, last = min(kept), max(kept)
            if first == last:
                text = f"{el.name} = {el.labels[first]}"
            elif first == 0:
                text = f"{el.name} <= {el.labels[last]}"
            elif last == len(order) - 1:
                text = f"{el.name} >= {el.labels[first]}"
            else:
                text = f"{el.labels[first]} <= {el.name} <= {el.labels[last]}"
        elif len(labels) > MAX_LISTED:
            text = grouped_text(el, labels)
        else:
            text = f"{el.name} in {{{', '.join(labels)}}}"
        conds.append({"element": el.name, "bins": labels, "text": text})
    return conds


def bin_group(value: Any) -> str:
    """The group of a categorical bin: its road-user kind and conflict type where its value
    carries them (``car crossing``, ``pedestrian crossing``), else ``other``."""
    if not isinstance(value, Mapping) or value.get("kind") is None:
        return "other"
    kind = str(value["kind"])
    kind_type = str(value.get("type") or "").replace("_", " ")
    if not kind_type:
        return kind
    return kind_type if kind_type.startswith(kind) else f"{kind} {kind_type}"


def grouped_text(el: Any, labels: list[str]) -> str:
    """A long set of categorical bins as counts per road-user kind and conflict type,
    naming a group whole when every bin of it is in the set (``intsit: every pedestrian
    pedestrian_crossing bin (24), 3 of 12 car crossing bins``)."""
    chosen = set(labels)
    groups: dict[str, list[str]] = {}
    for b in el.bins:
        groups.setdefault(bin_group(b.value), []).append(b.label)
    parts = []
    for group, members in sorted(groups.items(), key=lambda g: -len(g[1])):
        n = sum(m in chosen for m in members)
        if n == len(members):
            parts.append(f"every {group} bin ({n})")
        elif n:
            parts.append(f"{n} of {len(members)} {group} bins")
    return f"{el.name}: {len(labels)} of {len(el.bins)} bins: " + ", ".join(parts)


def _measure(mask: np.ndarray, y: np.ndarray) -> dict[str, Any]:
    k, n = int(y[mask].sum()), int(mask.sum())
    ci = wilson_interval(k, n)
    total = int(y.sum())
    return {
        "support": n,
        "support_share": n / len(y) if len(y) else None,
        "failures": k,
        "precision": k / n if n else None,
        "precision_ci95": list(ci) if ci else None,
        "recall": k / total if total else None,
    }


def _matches(codes: np.ndarray, hs: Hyperspace, conds: list[dict[str, Any]]) -> np.ndarray:
    mask = np.ones(len(codes), dtype=bool)
    for c in conds:
        e = hs.element_names.index(c["element"])
        allowed = [hs.elements[e].labels.index(lab) for lab in c["bins"]]
        mask &= np.isin(codes[:, e], allowed)
    return mask


def failure_regions(
    hyperspace: Hyperspace,
    runs: Iterable[Any],
    *,
    seed: int = 0,
    holdout: float = HOLDOUT,
    max_depth: int = MAX_DEPTH,
    min_runs: int = MIN_RUNS,
) -> dict[str, Any]:
    """Rules describing where the stack fails, with held-out support/precision/recall.

    Args:
        hyperspace: the hyperspace the runs were generated in.
        runs: stored runs (``.bins`` and ``.status``) or mappings with those keys.
        seed: seed of the numpy Generator that splits fitting and held-out runs (the
            tree itself is deterministic).
        holdout: share of the judged runs held out.
        max_depth: tree depth (most conditions per rule).
        min_runs: fewest judged runs for any rules.

    Returns:
        JSON-ready dict: ``validation`` (how the rules were measured), ``fit_runs``,
        ``holdout_runs``, ``message`` (None, or why there are no rules) and ``rules``
        (ranked by failures covered on the fitting runs), each with ``text``,
        ``conditions``, ``fit`` and ``holdout`` measures.
    """
    codes, y, _ = encode_runs(hyperspace, runs)
    n = len(y)
    order = np.random.default_rng(seed).permutation(n)
    n_hold = int(round(holdout * n))
    hold, fit = order[:n_hold], order[n_hold:]
    out: dict[str, Any] = {
        "validation": (
            f"seeded split (numpy Generator seed {seed}): rules fitted on {len(fit)} runs, "
            f"measured on the other {n_hold} held-out runs"
        ),
        "fit_runs": int(len(fit)),
        "holdout_runs": int(n_hold),
        "message": _not_enough(n, int(y.sum()), min_runs),
        "rules": [],
        "dropped": [],
    }
    if out["message"]:
        return out
    orders = _orders(hyperspace, codes[fit], y[fit])
    threshold = max(0.5, float(y[fit].mean()))
    min_leaf = max(10, len(fit) // 50)
    base_rate = float(y[hold].mean()) if n_hold else 0.0
    out.update(min_leaf=min_leaf, holdout_base_rate=base_rate)
    leaves = grow(_features(codes[fit], orders), y[fit], max_depth=max_depth,
                  min_leaf=min_leaf, threshold=threshold)  # fmt: skip
    for _, lo, hi in leaves:
        conds = _conditions(hyperspace, orders, lo, hi)
        fitted = _measure(_matches(codes[fit], hyperspace, conds), y[fit])
        if not fitted["support"] or fitted["precision"] < threshold:
            continue
        text = " and ".join(c["text"] for c in conds) or "everywhere"
        held = _measure(_matches(codes[hold], hyperspace, conds), y[hold])
        rule = {"text": text, "conditions": conds, "fit": fitted, "holdout": held}
        if _beats(held, base_rate):
            out["rules"].append(rule)
        else:
            out["dropped"].append(rule)
    out["rules"].sort(key=lambda r: (-r["fit"]["failures"], -r["fit"]["precision"]))
    return out


def _beats(held: dict[str, Any], base_rate: float) -> bool:
    """Whether a rule's held-out precision is above the held-out base rate beyond
    sampling error: the lower end of its Wilson 95 % interval is above the base rate."""
    ci = held["precision_ci95"]
    return bool(held["support"]) and ci is not None and ci[0] > base_rate


def rule_line(rule: dict[str, Any]) -> str:
    """One line: the rule and its held-out support, precision [CI] and recall."""
    h = rule["holdout"]
    if not h["support"]:
        return f"{rule['text']}: no held-out run matches"
    lo, hi = h["precision_ci95"]
    return (
        f"{rule['text']}: held-out precision {100 * h['precision']:.0f}% "
        f"[{100 * lo:.0f}, {100 * hi:.0f}] ({h['failures']}/{h['support']}), recall "
        f"{100 * h['recall']:.0f}%, support {100 * h['support_share']:.0f}% of held-out runs"
    )


def explain(
    hyperspace: Hyperspace,
    runs: Iterable[Any],
    *,
    seed: int = 0,
    alpha: float = 0.05,
    bootstrap: int | None = None,
) -> dict[str, Any]:
    """``sitcov explain``'s object: the interaction analysis plus the failure regions.

    Keys: those of :func:`~sitcov.analysis._explain.interaction_analysis` and ``regions``
    (:func:`failure_regions`).
    """
    from sitcov.analysis._explain import BOOTSTRAP, interaction_analysis

    runs = list(runs)
    out = interaction_analysis(
        hyperspace, runs, alpha=alpha, seed=seed,
        bootstrap=BOOTSTRAP if bootstrap is None else bootstrap,
    )  # fmt: skip
    out["regions"] = failure_regions(hyperspace, runs, seed=seed)
    return out


def explain_lines(result: dict[str, Any], top: int = 10) -> list[str]:
    """The plain-language text of ``explain``: counts, ranked findings, rules."""
    ex = result["excluded"]
    lines = [
        f"{result['judged']} judged runs, {result['failures']} failures; excluded: "
        f"{ex['error']} error, {ex['timeout']} timeout, {ex['pending']} pending, "
        f"{ex['unmatched']} not in the hyperspace"
    ]
    if result["message"]:
        return [*lines, result["message"]]
    found = result["findings"]
    lines.append(f"findings (most important first; {result['method']}):")
    lines += [f"{i}. {f['text']}" for i, f in enumerate(found[:top], start=1)]
    if not found:
        lines.append("  no element or pair changes the failure rate detectably")
    regions = result["regions"]
    lines.append(f"failure regions ({regions['validation']}):")
    lines += [f"- {rule_line(r)}" for r in regions["rules"]]
    if not regions["rules"]:
        lines.append("  no rule reaches 50% precision on the fitting runs and, held out, beats"
                     " the base rate")  # fmt: skip
    if regions.get("min_leaf"):
        base = regions.get("holdout_base_rate") or 0.0
        lines.append(
            f"  (rules: >= {regions['min_leaf']} fitting runs per leaf; kept only when the "
            f"lower end of their held-out precision's 95% interval beats the held-out base "
            f"rate {100 * base:.0f}%: {len(regions.get('dropped', []))} dropped)"
        )
    return lines
