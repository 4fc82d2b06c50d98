"""The report's "Why it fails" section: ranked findings and failure regions (sitcov explain).

Kept apart from the other sections so that the statistics (sitcov.analysis._explain and
_regions) stay the single source of what ``sitcov explain`` prints and what the report shows.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any


def _rule_row(rule: dict[str, Any]) -> dict[str, str]:
    h = rule["holdout"]
    ci = h["precision_ci95"]
    return {
        "text": rule["text"],
        "precision": "-" if h["precision"] is None else f"{100 * h['precision']:.0f}%",
        "ci": "" if ci is None else f"[{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]",
        "fj": f"{h['failures']} / {h['support']}",
        "recall": "-" if h["recall"] is None else f"{100 * h['recall']:.0f}%",
        "fit": f"{rule['fit']['failures']} / {rule['fit']['support']}",
    }


def explain_section(hs: Any, runs: Sequence[Any], scope: str, top: int = 8) -> dict[str, Any]:
    """``explain`` for the template: findings (text), rules (rows), notes; a small
    campaign gets an empty section saying why."""
    from sitcov.analysis import explain

    result = explain(hs, runs, bootstrap=0)  # pair tests: seconds per replicate
    ex = result["excluded"]
    note = (
        f"{result['judged']} judged runs, {result['failures']} failures; excluded: "
        f"{ex['error']} error, {ex['timeout']} timeout. Interactions of pairs of elements "
        f"are tested by sitcov explain only (its bootstrap is too slow for a report). {scope}"
    )
    if result["message"]:
        note = f"{result['message']}. {scope}"
    return {
        "explain": {
            "note": note,
            "method": result["method"],
            "findings": [f["text"] for f in result["findings"][:top]],
            "validation": result["regions"]["validation"],
            "rules": [_rule_row(r) for r in result["regions"]["rules"]],
        }
    }
