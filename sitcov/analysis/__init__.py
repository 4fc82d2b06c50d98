"""Coverage and failure statistics of campaign runs (counts, coverage, uniformity, Wilson)."""

from sitcov.analysis._stats import Z95, uniformity, wilson_interval
from sitcov.analysis._summary import (
    bin_stats,
    coverage,
    coverage_growth,
    failures_by_kind,
    summarize,
    worst_bins,
    worst_pairs,
)

__all__ = [
    "Z95",
    "bin_stats",
    "coverage",
    "coverage_growth",
    "failures_by_kind",
    "summarize",
    "uniformity",
    "wilson_interval",
    "worst_bins",
    "worst_pairs",
]
