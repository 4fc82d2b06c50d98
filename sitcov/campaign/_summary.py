"""Campaign summaries: the JSON of ``sitcov summary --json`` and the console table.

The numbers come from ``sitcov.analysis.summarize`` over the finished runs (pending runs
are not counted). Bins are ranked "worst" by the lower end of their Wilson 95% interval,
so a bin with 1 failure in 1 run does not outrank one with 30 in 60.
"""

from __future__ import annotations

import json
from typing import Any

from sitcov.campaign._store import Store, StoreError

FINISHED = ("pass", "fail", "error", "timeout")


def campaign_hyperspace(store: Store, campaign: str | None = None) -> Any:
    """The hyperspace of ``campaign`` (or of every campaign, which must share one)."""
    from sitcov.hyperspace import Hyperspace

    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    if not infos:
        raise StoreError(f"{store.location}: the store holds no campaigns")
    first = infos[0].hyperspace
    others = [c.name for c in infos if c.hyperspace != first]
    if others:
        raise StoreError(
            f"{store.location}: campaigns use different hyperspaces ({infos[0].name} vs "
            f"{', '.join(others)}); choose one with --campaign"
        )
    return Hyperspace.from_dict(first, file=f"{store.location} (campaign {infos[0].name})")


def summarize_store(store: Store, campaign: str | None = None) -> dict[str, Any]:
    """The ``sitcov summary --json`` object (:func:`sitcov.analysis.summarize`) of the finished
    runs of ``campaign`` (or all)."""
    from sitcov.analysis import summarize

    hyperspace = campaign_hyperspace(store, campaign)
    return summarize(hyperspace, store.runs(campaign, FINISHED))


def worst_bins(summary: dict[str, Any], n: int = 5) -> list[tuple[str, str, dict[str, Any]]]:
    """The ``n`` bins with the highest Wilson lower bound of failure rate (ties: rate, count)."""
    ranked = []
    for element, bins in summary.get("elements", {}).items():
        for label, stats in bins.items():
            if stats.get("failures") and stats.get("ci95"):
                key = (stats["ci95"][0], stats["failure_rate"], stats["generated"])
                ranked.append((key, element, label, stats))
    ranked.sort(key=lambda r: r[0], reverse=True)
    return [(e, lab, s) for _, e, lab, s in ranked[:n]]


def summary_table(summary: dict[str, Any], title: str = "campaign summary") -> Any:
    """A rich renderable: totals, coverage and the worst bins."""
    from rich.console import Group
    from rich.table import Table

    from sitcov.analysis import wilson_interval

    runs, failures, errors = summary["runs"], summary["failures"], summary["errors"]
    judged = max(runs - errors, 0)
    totals = Table(title=title, show_header=False, title_justify="left")
    totals.add_column(style="bold")
    totals.add_column(justify="right")
    totals.add_row("runs", str(runs))
    totals.add_row("failures", str(failures))
    if judged:
        lo, hi = wilson_interval(failures, judged)
        rate = f"{failures / judged:.1%}  (95% CI {lo:.1%} - {hi:.1%})"
    else:
        rate = "n/a"
    totals.add_row("failure rate", rate)
    totals.add_row("errors + timeouts", str(errors))
    cov = summary.get("coverage", {})
    totals.add_row("bins covered", f"{cov.get('bins_covered', 0)} / {cov.get('bins_total', 0)}")
    totals.add_row("pairwise coverage", f"{cov.get('pairwise', 0.0):.1%}")
    worst = Table(title="worst bins (by Wilson lower bound)", title_justify="left")
    for col in ("element", "bin", "runs", "failures", "rate", "95% CI"):
        worst.add_column(col, justify="left" if col in ("element", "bin") else "right")
    for element, label, s in worst_bins(summary):
        lo, hi = s["ci95"]
        worst.add_row(
            element,
            label,
            str(s["generated"]),
            str(s["failures"]),
            f"{s['failure_rate']:.0%}",
            f"{lo:.0%} - {hi:.0%}",
        )
    return Group(totals, worst) if worst.row_count else totals


def summary_json(store: Store, campaign: str | None = None) -> str:
    """``sitcov summary --json`` output (one JSON object)."""
    return json.dumps(summarize_store(store, campaign))
