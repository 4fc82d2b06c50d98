"""``summarize`` reads its runs once, as a stream, and gives exactly what the per-part
functions (bin_stats, coverage, failures_by_kind, kind_counts_per_bin) give."""

from __future__ import annotations

import numpy as np
import pytest

from sitcov.analysis import bin_stats, coverage, summarize
from sitcov.analysis._summary import FAILURE_KINDS, failures_by_kind, kind_counts_per_bin
from sitcov.hyperspace import load_hyperspace

STATUSES = ("pass", "fail", "error", "timeout", "pending")


def _random_runs(hs, n: int, rng: np.random.Generator) -> list[dict]:
    """Runs with every status, kinds, and some bins outside the hyperspace or missing."""
    runs = []
    for _ in range(n):
        bins = {e.name: e.labels[int(rng.integers(len(e.labels)))] for e in hs.elements}
        odd = rng.random()
        if odd < 0.03:
            bins[hs.element_names[0]] = "no-such-bin"
        elif odd < 0.06:
            bins.pop(hs.element_names[-1])
        status = STATUSES[int(rng.choice(5, p=[0.45, 0.35, 0.1, 0.05, 0.05]))]
        run = {"bins": bins, "status": status}
        if status == "fail" and rng.random() < 0.9:  # the rest: no kind (collision)
            run["failure_kind"] = FAILURE_KINDS[int(rng.integers(3))]
        runs.append(run)
    return runs


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_streamed_summary_equals_the_per_part_functions(seed):
    hs = load_hyperspace("t-junction")
    runs = _random_runs(hs, 600, np.random.default_rng(seed))
    summary = summarize(hs, iter(runs))  # a one-shot iterator: read once
    expected_elements = bin_stats(hs, runs)
    for element, per_bin in kind_counts_per_bin(hs, runs).items():
        for label, kinds in per_bin.items():
            expected_elements[element][label]["failures_by_kind"] = kinds
    assert summary["elements"] == expected_elements
    assert summary["coverage"] == coverage(hs, runs)
    assert summary["failures_by_kind"] == failures_by_kind(runs)
    finished = [r for r in runs if r["status"] != "pending"]
    assert summary["runs"] == len(finished)
    assert summary["pending"] == len(runs) - len(finished)
    for key, status in (("failures", "fail"), ("passes", "pass"), ("errors", "error")):
        assert summary[key] == sum(r["status"] == status for r in runs)
    fits = [r for r in finished if all(r["bins"].get(e.name) in e.labels for e in hs.elements)]
    assert summary["unmatched"] == len(finished) - len(fits) > 0
    assert summary["coverage"]["pairs_covered"] > 0


def test_empty_and_all_pending_runs():
    hs = load_hyperspace("t-junction")
    for runs in ([], [{"bins": {}, "status": "pending"}]):
        summary = summarize(hs, runs)
        assert summary["runs"] == 0 and summary["coverage"]["bins_covered"] == 0
        assert summary["failure_rate"] is None
