"""Route completion of a set of runs: mean, goal rate and distribution.

Shown next to the failure rate (as the CARLA Leaderboard shows its route completion next
to its infractions): a campaign whose stack passes by not driving has a low completion.
Each run contributes its ``route_completion`` fact (0-1, the share of its route's arc
length the ego drove; 1 = reached its goal); runs that store none (made before world
model 3, or by a backend that does not report it) are counted apart, never as 0.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

#: Upper edges of the distribution's bins of route completion (the last bin is the goal).
COMPLETION_EDGES = (0.25, 0.5, 0.75, 1.0)
#: Labels of the distribution's bins, in order.
COMPLETION_BINS = ("<25%", "25-50%", "50-75%", "75-<100%", "goal")


def route_completion_stats(values: Iterable[float | None]) -> dict[str, object]:
    """Statistics of route completion over runs (None: a run without the fact).

    Returns:
        ``runs`` (with the fact), ``without`` (runs without it), ``mean`` (0-1, None
        without runs), ``goal_rate`` (share that reached the goal), ``p10``, ``median``,
        ``p90`` and ``distribution`` (runs per :data:`COMPLETION_BINS` label).
    """
    kept: list[float] = []
    without = 0
    for v in values:
        if v is None:
            without += 1
        else:
            kept.append(float(v))
    arr = np.asarray(kept, dtype=float)
    goal = arr >= 1.0
    counts = [int(((arr < COMPLETION_EDGES[0]) & ~goal).sum())]
    for lo, hi in zip(COMPLETION_EDGES, COMPLETION_EDGES[1:], strict=False):
        counts.append(int(((arr >= lo) & (arr < hi) & ~goal).sum()))
    counts.append(int(goal.sum()))
    n = len(kept)
    q = np.quantile(arr, (0.1, 0.5, 0.9)).tolist() if n else [None, None, None]
    return {
        "runs": n,
        "without": without,
        "mean": float(arr.mean()) if n else None,
        "goal_rate": float(goal.mean()) if n else None,
        "p10": q[0],
        "median": q[1],
        "p90": q[2],
        "distribution": dict(zip(COMPLETION_BINS, counts, strict=True)),
    }


def completion_lines(stats: dict[str, object]) -> tuple[str, str]:
    """Two short lines for consoles and reports: the headline (mean, goal rate, median,
    runs) and the distribution (empty without runs)."""
    n = stats.get("runs") or 0
    if not n:
        return "n/a (no run reports it)", ""
    head = f"mean {stats['mean']:.1%}, goal {stats['goal_rate']:.1%}, median {stats['median']:.0%}"
    if stats.get("without"):
        head += f" ({stats['without']} runs without it)"
    dist = " · ".join(f"{k} {v}" for k, v in stats["distribution"].items())  # type: ignore[union-attr]
    return head, dist
