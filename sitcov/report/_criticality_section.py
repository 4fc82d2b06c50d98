"""The report's criticality section: distributions of the surrogate safety measures every
run stores (minimum TTC, PET, minimum distance, maximum DRAC, over all road users) for
passing and failing runs, and the near misses: runs that passed but came close; and, from
the same pass over the runs, the collision map (:mod:`sitcov.report._collision_map`).

The measures are the backends' (docs/metrics.md): per run the smallest (for DRAC the
largest) over every road user of its ``metrics["actors"]`` entry (the paper's two-car runs
store the OV's only, as the outcome's own ``min_ttc`` / ``pet`` / ``min_distance`` and the
run's ``metrics["max_drac"]``). DRAC, the deceleration rate to avoid a crash (Cooper &
Ferguson 1976; Archer 2005), is computed every step by the embedded world's proximity
monitor; runs stored before it was (store schema < 5) have none and are left out of its
histogram.
"""

from __future__ import annotations

import math
import shlex
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sitcov.report import _figures
from sitcov.report._collision_map import campaign_map, collision_map_section, collision_point
from sitcov.report._sections import b64

#: a passing run is a near miss when its minimum TTC is below this [s] ...
NEAR_TTC = 1.0
#: ... or its minimum distance below this [m]
NEAR_DISTANCE = 1.0
#: rows of the near-miss table
NEAR_ROWS = 10
MEASURES = (
    ("min_ttc", "minimum TTC [s]", 10.0),
    ("pet", "PET [s]", 10.0),
    ("min_distance", "minimum distance [m]", 30.0),
    ("max_drac", "maximum DRAC [m/s²]", 12.0),
)
#: measures where the largest value over the road users is the critical one
LARGEST = frozenset({"max_drac"})
#: a common DRAC criticality threshold [m/s^2] (Archer 2005), marked in its histogram
DRAC_THRESHOLD = 3.35


def run_measures(run: Any) -> dict[str, Any]:
    """The smallest minimum TTC, PET and minimum distance and the largest DRAC over a run's
    road users, and the road user (name, kind) of the smallest TTC."""
    outcome = run.outcome
    actors = (outcome.metrics or {}).get("actors") or {}
    rows = [(name, a) for name, a in actors.items() if isinstance(a, dict)]
    if not rows:
        rows = [
            (
                "ov",
                {
                    "min_ttc": outcome.min_ttc,
                    "pet": outcome.pet,
                    "min_distance": outcome.min_distance,
                    "max_drac": (outcome.metrics or {}).get("max_drac"),
                    "kind": "car",
                },
            )
        ]
    out: dict[str, Any] = {}
    for key, _, _ in MEASURES:
        values = [a.get(key) for _, a in rows if _finite(a.get(key))]
        out[key] = (max if key in LARGEST else min)(values) if values else None
    closest = min(
        rows, key=lambda r: r[1].get("min_ttc") if _finite(r[1].get("min_ttc")) else math.inf
    )
    out["actor"] = f"{closest[0]} ({closest[1].get('kind', 'car')})"
    return out


def _finite(x: Any) -> bool:
    return isinstance(x, int | float) and math.isfinite(x)


def criticality_section(
    store: Any, db: str, campaigns: Sequence[str], fig_dir: Path
) -> dict[str, Any]:
    """Histograms of the measures (passes and failures apart) and the near-miss table, over
    the judged runs of ``campaigns`` (read one at a time: only their measures are kept)."""
    measured, points, unlocated = [], [], 0
    for name in campaigns:
        config = store.campaign(name).config
        map_ref = campaign_map(config)
        per_run = config.get("backend") == "esmini"  # a catalogue's files name their roads
        for r in store.iter_runs(name, ("pass", "fail")):
            if r.outcome is None:
                continue
            measured.append((_Ref(r.campaign, r.index, r.status), run_measures(r)))
            ref = (
                campaign_map(config, r.outcome.metrics)
                if per_run and r.outcome.collision
                else map_ref
            )
            point = collision_point(r, ref)
            if point:
                points.append(point)
            elif point is False:
                unlocated += 1
    page = collision_map_section(points, unlocated, fig_dir)
    if not measured:
        return {"criticality": None, **page}
    judged = [r for r, _ in measured]
    series = {}
    for key, label, cap in MEASURES:
        series[label] = {
            status: [
                min(m[key], cap) for r, m in measured if r.status == status and m[key] is not None
            ]
            for status in ("pass", "fail")
        }
    figure = _figures.histograms_figure(
        series,
        caps={label: cap for _, label, cap in MEASURES},
        marks={MEASURES[3][1]: (DRAC_THRESHOLD, f"{DRAC_THRESHOLD:g} m/s² (Archer 2005)")},
    )
    png = _figures.save(figure, fig_dir / "criticality.png")
    near = [
        (r, m)
        for r, m in measured
        if r.status == "pass"
        and (
            (m["min_ttc"] is not None and m["min_ttc"] < NEAR_TTC)
            or (m["min_distance"] is not None and m["min_distance"] < NEAR_DISTANCE)
        )
    ]
    near.sort(key=lambda rm: rm[1]["min_ttc"] if rm[1]["min_ttc"] is not None else math.inf)
    rows = [
        {
            "run": r.ref,
            "actor": m["actor"],
            "ttc": _fmt(m["min_ttc"]),
            "distance": _fmt(m["min_distance"]),
            "pet": _fmt(m["pet"]),
            "drac": _fmt(m["max_drac"]),
            "command": f"sitcov replay --db {shlex.quote(db)} {shlex.quote(r.ref)}",
        }
        for r, m in near[:NEAR_ROWS]
    ]
    passes = sum(r.status == "pass" for r in judged)
    return {
        **page,
        "criticality": {
            "png": b64(png),
            "near": rows,
            "near_total": len(near),
            "passes": passes,
            "rule": f"passing runs with minimum TTC < {NEAR_TTC:g} s or minimum distance < "
            f"{NEAR_DISTANCE:g} m to any road user",
        },
    }


@dataclass(frozen=True)
class _Ref:
    campaign: str
    index: int
    status: str

    @property
    def ref(self) -> str:
        return f"{self.campaign}:{self.index}"


def _fmt(x: float | None) -> str:
    return "–" if x is None else f"{x:.2f}"
