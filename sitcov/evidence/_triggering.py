"""Triggering conditions (ISO 21448 / SOTIF): where the stack fails, as a catalogue.

Each failure region of :func:`sitcov.analysis.failure_regions` (rules fitted on one part of
the runs, measured on held-out runs) becomes a catalogue entry with its ODD attributes,
its evidence counts and a few replay lines of failing runs it covers. An entry whose
held-out precision's lower 95 % bound is above the campaign's base failure rate is a
*known unsafe* condition (SOTIF area 2); the others are *candidates* that more runs must
confirm or refute.
"""

from __future__ import annotations

import shlex
from collections.abc import Sequence
from typing import Any

from sitcov.evidence._taxonomy import Taxonomy

KNOWN_UNSAFE, CANDIDATE = "known unsafe", "candidate"
#: replay lines listed per condition
REPLAYS = 3


def _covers(run: Any, conditions: Sequence[dict[str, Any]]) -> bool:
    return all(run.bins.get(c["element"]) in c["bins"] for c in conditions)


def _attributes(taxonomy: Taxonomy, conditions: Sequence[dict[str, Any]]) -> list[dict]:
    out = []
    for c in conditions:
        spec = taxonomy.specs.get(c["element"])
        if spec is None:
            continue
        element = taxonomy.hyperspace.element(c["element"])
        categories: list[str] = []
        for label in c["bins"]:
            category = taxonomy.category(c["element"], element.bin(label).value)
            if category not in categories:
                categories.append(category)
        out.append(
            {"attribute": spec.attribute, "openlabel": spec.openlabel, "categories": categories}
        )
    return out


def triggering_conditions(
    taxonomy: Taxonomy, runs: Sequence[Any], *, db: str, seed: int = 0
) -> dict[str, Any]:
    """The catalogue: ``base_rate``, ``validation`` and ``conditions`` (ranked as the
    failure regions are: by failures covered on the fitting runs)."""
    from sitcov.analysis import failure_regions

    judged = [r for r in runs if r.status in ("pass", "fail")]
    regions = failure_regions(taxonomy.hyperspace, judged, seed=seed)
    base = sum(r.status == "fail" for r in judged) / len(judged) if judged else None
    entries = []
    for i, rule in enumerate(regions["rules"], start=1):
        held = rule["holdout"]
        ci = held["precision_ci95"]
        supported = bool(ci) and base is not None and ci[0] > base
        failing = [r for r in judged if r.status == "fail" and _covers(r, rule["conditions"])]
        entries.append(
            {
                "id": f"TRIG-{i:03d}",
                "condition": rule["text"],
                "elements": rule["conditions"],
                "odd_attributes": _attributes(taxonomy, rule["conditions"]),
                "classification": KNOWN_UNSAFE if supported else CANDIDATE,
                "evidence": {"fit": rule["fit"], "holdout": held},
                "replay": [
                    f"sitcov replay --db {shlex.quote(db)} {r.campaign}:{r.index}"
                    for r in failing[:REPLAYS]
                ],
            }
        )
    return {
        "base_rate": base,
        "validation": regions["validation"],
        "message": regions["message"],
        "conditions": entries,
    }
