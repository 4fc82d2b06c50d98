"""The report's "By road user and conflict" section: failure rates per actor kind and per
conflict type, with Wilson 95% intervals.

The numbers come from :func:`sitcov.analysis.breakdowns` (the same as ``sitcov summary``),
over the stored runs; kinds and types are read from the hyperspace's ``intsit`` and
``actorN`` values, actor slots typed by the geometry of the hyperspace's map.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

#: The section's two tables: breakdown key -> column title.
TABLES = {"actor_kind": "actor kind", "conflict_type": "conflict type"}


def _row(name: str, stats: dict[str, Any]) -> dict[str, str]:
    from sitcov.report._sections import pct

    ci = stats["ci95"]
    return {
        "name": name.replace("_", " "),
        "runs": str(stats["generated"]),
        "fj": f"{stats['failures']} / {stats['judged']}",
        "rate": pct(stats["failure_rate"]),
        "ci": "–" if ci is None else f"{100 * ci[0]:.1f}–{100 * ci[1]:.1f}%",
    }


def breakdown_section(hs: Any, runs: Sequence[Any], scope: str) -> dict[str, Any]:
    """``breakdown`` for the template: ``tables`` (title, rows), ``note``, ``hits`` (rows of
    the road user the ego hit) and ``hit_note``; no tables for a hyperspace without actor
    elements."""
    from sitcov.analysis import breakdowns
    from sitcov.campaign._breakdown import slot_types

    found = breakdowns(hs, runs, slot_types(hs))
    tables = [
        {"title": title, "rows": [_row(k, s) for k, s in found[key].items() if s["generated"]]}
        for key, title in TABLES.items()
        if key in found
    ]
    note = (
        "Failure rate of the runs involving each kind of road user and each type of conflict "
        "with the ego (the primary actor of the intersection situation and every further actor); "
        "a run with several kinds counts in each of their rows, so rows overlap. Situations "
        "without a conflict type are the paper's, which it calls cross-collisions. " + scope
    )
    hits = [_hit_row(k, s) for k, s in found.get("hit_kind", {}).items() if s["generated"]]
    return {
        "breakdown": {"tables": tables, "note": note.strip(), "hits": hits, "hit_note": HIT_NOTE}
    }


#: What the "road user hit" table counts.
HIT_NOTE = (
    "Which road user the ego actually collided with: per kind, the runs whose collision was "
    "with a road user of that kind, as a rate among the judged runs that had one (Wilson 95% "
    "interval) and as a share of all collisions. Runs that store no kind (the paper's "
    "two-car scene) hit their intersection situation's road user."
)


def _hit_row(name: str, stats: dict[str, Any]) -> dict[str, str]:
    from sitcov.report._sections import pct

    ci, share = stats["ci95"], stats["share"]
    return {
        "name": name,
        "runs": str(stats["generated"]),
        "fj": f"{stats['collisions']} / {stats['judged']}",
        "rate": pct(stats["collision_rate"]),
        "ci": "–" if ci is None else f"{100 * ci[0]:.1f}–{100 * ci[1]:.1f}%",
        "share": "–" if share is None else f"{100 * share:.0f}%",
    }
