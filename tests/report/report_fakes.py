"""Synthetic campaign stores for the report tests (no simulation needed).

Imported by module name (``report_fakes``): pytest puts this folder on ``sys.path``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from sitcov.campaign import CampaignInfo, PlannedRun
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim import Outcome


def random_situation(hs: Any, rng: np.random.Generator) -> Situation:
    """A uniformly drawn situation of ``hs``."""
    bins = {e.name: e.bins[int(rng.integers(len(e.bins)))].label for e in hs.elements}
    return hs.situation_from_bins(bins, rng)


def status_for(situation: Situation, rng: np.random.Generator) -> str:
    """Synthetic judge: low friction and IntSit-1..4 fail more often; a few errors."""
    p = 0.1 + (0.5 if situation.bins["friction"] in ("0.1", "0.2") else 0.0)
    p += 0.2 if situation.bins["intsit"] in ("IntSit-1", "IntSit-2", "IntSit-3", "IntSit-4") else 0
    u = float(rng.random())
    if u < 0.02:
        return "error"
    return "fail" if u < p else "pass"


def add_campaign(
    store: Any,
    name: str,
    n: int,
    seed: int,
    *,
    generator: str = "random",
    fault: str | None = None,
    tags: Mapping[str, Any] | None = None,
    situations: list[tuple[Situation, int]] | None = None,
    judge: Callable[[Situation, np.random.Generator], str] = status_for,
) -> list[tuple[Situation, int]]:
    """Store a finished campaign of ``n`` synthetic runs; returns its (situation, seed) list."""
    hs = load_hyperspace()
    rng = np.random.default_rng(seed)
    plan = situations or [(random_situation(hs, rng), int(rng.integers(2**31))) for _ in range(n)]
    config = {
        "name": name,
        "generator": generator,
        "runs": len(plan),
        "seed": seed,
        "fault": fault,
        "backend": "embedded",
        "av": "reference",
        "hyperspace": "t-junction",
    }
    info = CampaignInfo(
        name=name,
        config=config,
        hyperspace=hs.to_dict(),
        sitcov_version="test",
        created="2026-01-01T00:00:00+00:00",
        generator=generator,
        tags=dict(tags or {}),
    )
    store.create_campaign(info, [PlannedRun(i, s, sd) for i, (s, sd) in enumerate(plan)])
    for i, (situation, _) in enumerate(plan):
        status = judge(situation, rng)
        if status == "error":
            outcome = Outcome.errored("synthetic error")
        else:
            outcome = Outcome(
                status=status,
                end_reason="collision" if status == "fail" else "goal",
                collision=status == "fail",
            )
        store.record_result(name, i, outcome, 0.001)
    return plan
