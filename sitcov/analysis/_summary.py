"""Coverage and failure statistics of a set of runs over a hyperspace.

A run is any object with ``.bins`` (element -> label) and ``.status`` (``pass``, ``fail``,
``error``, ``timeout`` or ``pending``), e.g. :class:`sitcov.campaign.RunRecord`; mappings
with those keys work too. ``pending`` runs were planned but not run and are ignored;
``generated`` counts every other run; failure rates are over *judged* runs (pass + fail),
so errors and timeouts neither count as failures nor dilute the rate.

A failed run's kind (``collision``, ``ego_stationary``, ``road_departure``,
``lane_departure``, ``blocked``, ``route_incomplete``) is its
``failure_kind`` (a RunRecord property or a mapping key); a failed run without one is a
collision, as every failure was before failure kinds existed.
"""

from __future__ import annotations

import math
from array import array
from collections.abc import Iterable, Mapping
from itertools import combinations
from typing import Any

import numpy as np

from sitcov.analysis._breakdown import Roles, SlotTypes, breakdowns_of, run_hit
from sitcov.analysis._stats import uniformity, wilson_interval
from sitcov.analysis._statuses import STATUSES
from sitcov.hyperspace import Hyperspace

#: Kinds a failed run can have (``sitcov.sim.FAILURE_KINDS``, repeated to keep analysis
#: free of simulation imports).
FAILURE_KINDS = (
    "collision",
    "ego_stationary",
    "road_departure",
    "lane_departure",
    "blocked",
    "route_incomplete",
)
#: Kinds that are a collision of the ego (which road user it hit is counted for them).
COLLISION_KINDS = ("collision", "ego_stationary")


def _field(run: Any, name: str) -> Any:
    if type(run) is dict:  # the common case first: isinstance(Mapping) is slow per run
        return run[name]
    return run[name] if isinstance(run, Mapping) else getattr(run, name)


def _indexed(hs: Hyperspace, runs: Iterable[Any]) -> tuple[list[tuple[list[int], str]], int]:
    """(bin indices, status) of the non-pending runs that fit ``hs``; and how many did not."""
    out = []
    unmatched = 0
    lookup = hs._label_index
    names = hs.element_names
    for run in runs:
        status = _field(run, "status")
        if status == "pending":
            continue
        bins = _field(run, "bins")
        idx = []
        for e, name in enumerate(names):
            i = lookup[e].get(bins.get(name)) if name in bins else None
            if i is None:
                break
            idx.append(i)
        if len(idx) != len(names):
            unmatched += 1
            continue
        out.append((idx, status))
    return out, unmatched


def _kind(run: Any) -> str:
    """The failure kind of a failed run (``collision`` when it does not say)."""
    if type(run) is dict or isinstance(run, Mapping):
        kind = run.get("failure_kind")
    else:
        kind = getattr(run, "failure_kind", None)
    return kind if kind in FAILURE_KINDS else "collision"


def failures_by_kind(runs: Iterable[Any]) -> dict[str, dict[str, Any]]:
    """Per failure kind: failures, failure_rate (over judged runs) and ci95 (Wilson).

    Every kind of :data:`FAILURE_KINDS` is present (0 failures when none); the rates add
    up to the overall failure rate.
    """
    counts = dict.fromkeys(FAILURE_KINDS, 0)
    judged = 0
    for run in runs:
        status = _field(run, "status")
        judged += status in ("pass", "fail")
        if status == "fail":
            counts[_kind(run)] += 1
    out = {}
    for kind, n in counts.items():
        rate, ci = _rate(n, judged)
        out[kind] = {"failures": n, "failure_rate": rate, "ci95": ci}
    return out


def kind_counts_per_bin(hyperspace: Hyperspace, runs: Iterable[Any]) -> dict[str, Any]:
    """Per element and bin: failures per kind, ``{element: {label: {kind: n}}}``."""
    names = set(hyperspace.element_names)
    out = {
        e.name: {label: dict.fromkeys(FAILURE_KINDS, 0) for label in e.labels}
        for e in hyperspace.elements
    }
    for run in runs:
        if _field(run, "status") != "fail":
            continue
        bins = _field(run, "bins")
        if any(bins.get(e) not in out[e] for e in names):
            continue  # does not fit the hyperspace (counted as unmatched by summarize)
        kind = _kind(run)
        for element in names:
            out[element][bins[element]][kind] += 1
    return out


def _rate(failures: int, judged: int) -> tuple[float | None, list[float] | None]:
    ci = wilson_interval(failures, judged)
    return (failures / judged if judged else None), (list(ci) if ci else None)


def bin_stats(hyperspace: Hyperspace, runs: Iterable[Any]) -> dict[str, dict[str, dict[str, Any]]]:
    """Per element and bin: generated, failures, passes, errors, timeouts, judged,
    failure_rate (failures / judged, None if nothing judged) and ci95 (Wilson, or None)."""
    indexed, _ = _indexed(hyperspace, runs)
    return _bin_stats(hyperspace, indexed)


def _bin_stats(hs: Hyperspace, indexed: list[tuple[list[int], str]]) -> dict[str, Any]:
    tallies = [[dict.fromkeys(STATUSES, 0) for _ in range(n)] for n in hs.sizes]
    for idx, status in indexed:
        for e, i in enumerate(idx):
            if status in tallies[e][i]:
                tallies[e][i][status] += 1
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for e, element in enumerate(hs.elements):
        per_bin = {}
        for i, label in enumerate(element.labels):
            per_bin[label] = _bin_row(tallies[e][i])
        out[element.name] = per_bin
    return out


def _bin_row(t: dict[str, int]) -> dict[str, Any]:
    """A bin's statistics from its counts per status."""
    judged = t["pass"] + t["fail"]
    rate, ci = _rate(t["fail"], judged)
    return {
        "generated": sum(t.values()),
        "failures": t["fail"],
        "failure_rate": rate,
        "ci95": ci,
        "passes": t["pass"],
        "errors": t["error"],
        "timeouts": t["timeout"],
        "judged": judged,
    }


def _feasible_bins(hs: Hyperspace) -> int:
    if not hs.constraints:
        return sum(hs.sizes)
    return sum(1 for e in hs.elements for label in e.labels if hs.count({e.name: [label]}) > 0)


def coverage(hyperspace: Hyperspace, runs: Iterable[Any]) -> dict[str, Any]:
    """Bins covered / total and the fraction of allowed 2-way bin combinations seen.

    Bins and pairs that no allowed situation contains (because of constraints) are not
    counted in the totals.
    """
    indexed, _ = _indexed(hyperspace, runs)
    return _coverage(hyperspace, indexed)


def _pairs_of(idx: list[int]) -> list[tuple[int, int, int, int]]:
    return [(e1, idx[e1], e2, idx[e2]) for e1, e2 in combinations(range(len(idx)), 2)]


def _coverage(hs: Hyperspace, indexed: list[tuple[list[int], str]]) -> dict[str, Any]:
    seen_bins = {(e, i) for idx, _ in indexed for e, i in enumerate(idx)}
    allowed = hs.allowed_pairs
    seen_pairs = {p for idx, _ in indexed for p in _pairs_of(idx)} & allowed
    total_pairs = len(allowed)
    return {
        "bins_covered": len(seen_bins),
        "bins_total": _feasible_bins(hs),
        "pairwise": len(seen_pairs) / total_pairs if total_pairs else 1.0,
        "pairs_covered": len(seen_pairs),
        "pairs_total": total_pairs,
    }


def _json_uniformity(counts: list[int]) -> dict[str, Any]:
    u = uniformity(counts)
    if u["max_min_ratio"] is not None and math.isinf(u["max_min_ratio"]):
        u["max_min_ratio"] = None  # JSON has no infinity; "min": 0 says why
    return u


def summarize(
    hyperspace: Hyperspace, runs: Iterable[Any], slot_types: SlotTypes | None = None
) -> dict[str, Any]:
    """The summary JSON of ``sitcov summary --json`` (a stable interface: the keys below).

    Keys: ``runs`` (non-pending), ``failures``, ``errors``, ``timeouts``, ``passes``,
    ``pending``, ``failure_rate`` and ``ci95`` overall, ``failures_by_kind`` (see
    :func:`failures_by_kind`), ``elements`` (see :func:`bin_stats`; each bin also has
    ``failures_by_kind``, counts per kind), ``coverage`` (see :func:`coverage`),
    ``uniformity`` per element (see :func:`~sitcov.analysis.uniformity`; an unused bin
    gives ``max_min_ratio: null`` with ``min: 0``), ``unmatched`` (runs whose bins are not
    in this hyperspace), ``hyperspace`` (its name) and ``breakdowns``: failure rates by
    ``actor_kind`` and ``conflict_type`` (:mod:`sitcov.analysis._breakdown`; ``slot_types``
    types the actor slots; ``{}`` for a hyperspace without actor elements), and
    ``hit_kind``: which road user the ego collided with, per kind.

    ``runs`` is read once, as a stream: a 100,000-run campaign is summarised from compact
    per-run bin indices (a few bytes each) and counted with numpy, never held as records.
    """
    tally = _Tally(hyperspace)
    for run in runs:
        tally.add(run)
    return {**tally.summary(), "breakdowns": tally.breakdowns(slot_types)}


#: Status codes of the tallies (index into STATUSES); other statuses are not tallied.
_CODE = {s: i for i, s in enumerate(STATUSES)}


class _Tally:
    """One pass over the runs: status and kind counts, and the bin indices of each run."""

    def __init__(self, hs: Hyperspace) -> None:
        self.hs = hs
        self.lookup = hs._label_index
        self.names = hs.element_names
        self.statuses = dict.fromkeys(STATUSES, 0)
        self.other = 0  # finished runs with a status outside STATUSES
        self.pending = 0
        self.unmatched = 0
        self.kinds = dict.fromkeys(FAILURE_KINDS, 0)  # every failed run, matched or not
        self.idx = array("i")  # bin indices of matched runs, row after row
        self.codes = array("b")  # their status codes (-1: not tallied)
        self.kind_codes = array("b")  # their failure kind (-1: not failed)
        self.hits: list[str | None] = []  # the kind of road user the ego hit (HIT_UNSTORED)

    def add(self, run: Any) -> None:
        status = _field(run, "status")
        if status == "pending":
            self.pending += 1
            return
        if status in self.statuses:
            self.statuses[status] += 1
        else:
            self.other += 1
        kind = FAILURE_KINDS.index(_kind(run)) if status == "fail" else -1
        if kind >= 0:
            self.kinds[FAILURE_KINDS[kind]] += 1
        bins = _field(run, "bins")
        row = []
        for e, name in enumerate(self.names):
            i = self.lookup[e].get(bins.get(name)) if name in bins else None
            if i is None:
                self.unmatched += 1
                return
            row.append(i)
        self.idx.extend(row)
        self.codes.append(_CODE.get(status, -1))
        self.kind_codes.append(kind)
        self.hits.append(run_hit(run, kind >= 0 and FAILURE_KINDS[kind] in COLLISION_KINDS))

    def _matrix(self) -> np.ndarray:
        return np.array(self.idx, dtype=np.int64).reshape(-1, len(self.names))

    def elements(self, idx: np.ndarray) -> dict[str, Any]:
        codes = np.array(self.codes, dtype=np.int64)
        kinds = np.array(self.kind_codes, dtype=np.int64)
        tallied, failed = codes >= 0, kinds >= 0
        out: dict[str, Any] = {}
        for e, element in enumerate(self.hs.elements):
            n = len(element.labels)
            counts = np.zeros((n, len(STATUSES)), dtype=np.int64)
            np.add.at(counts, (idx[tallied, e], codes[tallied]), 1)
            by_kind = np.zeros((n, len(FAILURE_KINDS)), dtype=np.int64)
            np.add.at(by_kind, (idx[failed, e], kinds[failed]), 1)
            out[element.name] = {
                label: {
                    **_bin_row(dict(zip(STATUSES, map(int, counts[i]), strict=True))),
                    "failures_by_kind": dict(zip(FAILURE_KINDS, map(int, by_kind[i]), strict=True)),
                }
                for i, label in enumerate(element.labels)
            }
        return out

    def coverage(self, idx: np.ndarray) -> dict[str, Any]:
        hs = self.hs
        seen_bins = sum(len(np.unique(idx[:, e])) for e in range(idx.shape[1]))
        allowed = hs.allowed_pairs
        seen = set()
        for e1, e2 in combinations(range(idx.shape[1]), 2):
            n2 = hs.sizes[e2]
            for code in np.unique(idx[:, e1] * n2 + idx[:, e2]).tolist():
                seen.add((e1, code // n2, e2, code % n2))
        seen &= allowed
        total = len(allowed)
        return {
            "bins_covered": int(seen_bins),
            "bins_total": _feasible_bins(hs),
            "pairwise": len(seen) / total if total else 1.0,
            "pairs_covered": len(seen),
            "pairs_total": total,
        }

    def breakdowns(self, slot_types: SlotTypes | None) -> dict[str, Any]:
        """Failure rates by actor kind and conflict type of the matched runs."""
        codes = np.array(self.codes, dtype=np.int64)
        roles = Roles(self.hs, slot_types)
        return breakdowns_of(roles, self._matrix(), codes, _bin_row, self.hits, _rate)

    def summary(self) -> dict[str, Any]:
        idx = self._matrix()
        n_fail, n_pass = self.statuses["fail"], self.statuses["pass"]
        judged = n_fail + n_pass
        rate, ci = _rate(n_fail, judged)
        elements = self.elements(idx)
        by_kind = {}
        for kind, n in self.kinds.items():
            k_rate, k_ci = _rate(n, judged)
            by_kind[kind] = {"failures": n, "failure_rate": k_rate, "ci95": k_ci}
        return {
            "runs": sum(self.statuses.values()) + self.other,
            "failures": n_fail,
            "errors": self.statuses["error"],
            "elements": elements,
            "coverage": self.coverage(idx),
            "timeouts": self.statuses["timeout"],
            "passes": n_pass,
            "pending": self.pending,
            "failure_rate": rate,
            "ci95": ci,
            "failures_by_kind": by_kind,
            "uniformity": {
                name: _json_uniformity([b["generated"] for b in per_bin.values()])
                for name, per_bin in elements.items()
            },
            "unmatched": self.unmatched,
            "hyperspace": self.hs.name,
        }


def coverage_growth(hyperspace: Hyperspace, runs: Iterable[Any]) -> list[dict[str, Any]]:
    """Coverage after each run, in the order given (for the report's growth curve).

    Returns:
        One dict per non-pending run that fits the hyperspace: ``runs`` (how many so far),
        ``bins_covered`` and ``pairwise`` (fraction of allowed pairs seen).
    """
    indexed, _ = _indexed(hyperspace, runs)
    allowed = hyperspace.allowed_pairs
    total = len(allowed) or 1
    seen_bins: set[tuple[int, int]] = set()
    seen_pairs: set[tuple[int, int, int, int]] = set()
    out = []
    for n, (idx, _) in enumerate(indexed, start=1):
        seen_bins.update(enumerate(idx))
        seen_pairs.update(p for p in _pairs_of(idx) if p in allowed)
        out.append({"runs": n, "bins_covered": len(seen_bins), "pairwise": len(seen_pairs) / total})
    return out


def _ranked(rows: list[dict[str, Any]], min_judged: int, top: int | None) -> list[dict[str, Any]]:
    rows = [r for r in rows if r["judged"] >= min_judged and r["ci95"] is not None]
    rows.sort(key=lambda r: (-r["ci95"][0], -r["failure_rate"], -r["judged"]))
    return rows if top is None else rows[:top]


def worst_bins(
    hyperspace: Hyperspace, runs: Iterable[Any], *, min_judged: int = 5, top: int | None = 10
) -> list[dict[str, Any]]:
    """Bins with the highest failure rates, ranked by the Wilson 95% lower bound (so a
    rate backed by many runs outranks the same rate from a few).

    Args:
        min_judged: ignore bins with fewer judged (pass + fail) runs.
        top: keep this many (None = all).
    """
    rows = []
    for element, per_bin in bin_stats(hyperspace, runs).items():
        for label, s in per_bin.items():
            rows.append({"element": element, "label": label, **s})
    return _ranked(rows, min_judged, top)


def worst_pairs(
    hyperspace: Hyperspace,
    runs: Iterable[Any],
    *,
    min_judged: int = 5,
    top: int | None = 10,
    beyond_bins: bool = False,
) -> list[dict[str, Any]]:
    """Pairs of bins (two elements) with the highest failure rates, ranked as
    :func:`worst_bins`; each row has ``elements`` and ``labels`` (2-tuples) and
    ``bin_rates``, the two bins' own failure rates.

    With ``beyond_bins`` only pairs that fail more than both of their bins alone are kept
    (the lower end of the pair's Wilson interval above each bin's own failure rate):
    otherwise one bad bin (friction 0.1) fills the list with copies of itself paired with
    every other bin.
    """
    indexed, _ = _indexed(hyperspace, runs)
    tallies: dict[tuple[int, int, int, int], list[int]] = {}
    singles: dict[tuple[int, int], list[int]] = {}
    for idx, status in indexed:
        if status not in ("pass", "fail"):
            continue
        for e, b in enumerate(idx):
            t = singles.setdefault((e, b), [0, 0])
            t[0] += status == "fail"
            t[1] += 1
        for p in _pairs_of(idx):
            t = tallies.setdefault(p, [0, 0])
            t[0] += status == "fail"
            t[1] += 1
    names = hyperspace.element_names
    rows = []
    for (e1, b1, e2, b2), (fails, judged) in tallies.items():
        rate, ci = _rate(fails, judged)
        (k1, n1), (k2, n2) = singles[(e1, b1)], singles[(e2, b2)]
        alone = (k1 / n1, k2 / n2)
        if beyond_bins and (ci is None or ci[0] <= max(alone)):
            continue
        rows.append(
            {
                "elements": (names[e1], names[e2]),
                "labels": (hyperspace.elements[e1].labels[b1], hyperspace.elements[e2].labels[b2]),
                "failures": fails,
                "judged": judged,
                "failure_rate": rate,
                "ci95": ci,
                "bin_rates": alone,
            }
        )
    return _ranked(rows, min_judged, top)


def breakdowns(
    hs: Hyperspace, runs: Any, slot_types: SlotTypes | None = None
) -> dict[str, dict[str, dict[str, Any]]]:
    """Failure rates by actor kind and by conflict type over ``runs`` (see the module doc).

    Each row has the per-bin keys of :func:`sitcov.analysis.bin_stats` (generated,
    failures, passes, errors, timeouts, judged, failure_rate, ci95); a third key,
    ``hit_kind``, has the rows of :func:`hit_rows` (which road user the ego hit). Runs that
    do not fit the hyperspace, and pending runs, are left out.
    """
    tally = _Tally(hs)
    for run in runs:
        tally.add(run)
    return tally.breakdowns(slot_types)
