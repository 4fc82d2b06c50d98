"""Coverage and failure statistics of campaign runs (counts, coverage, uniformity, Wilson),
and explanations of the failures (interaction tests, failure regions)."""

from sitcov.analysis._explain import interaction_analysis
from sitcov.analysis._progress import completion_lines, route_completion_stats
from sitcov.analysis._regions import explain, explain_lines, failure_regions
from sitcov.analysis._stats import Z95, uniformity, wilson_interval
from sitcov.analysis._summary import (
    bin_stats,
    breakdowns,
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
    "completion_lines",
    "breakdowns",
    "coverage",
    "coverage_growth",
    "explain",
    "explain_lines",
    "failures_by_kind",
    "failure_regions",
    "interaction_analysis",
    "route_completion_stats",
    "summarize",
    "uniformity",
    "wilson_interval",
    "worst_bins",
    "worst_pairs",
]
