"""The cross-tabulation of two elements behind the report's heat map.

Per-bin statistics, the worst bins and the worst pairs come from :mod:`sitcov.analysis`; this
module only adds the full two-element grid the heat map draws, with the same conventions:
failures are runs with status ``fail``, the rate is over judged runs (``pass`` + ``fail``),
intervals are Wilson 95 %.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class CellStats:
    """Counts of one bin (or bin pair) over a set of runs.

    Attributes:
        generated: runs that were executed (any status but pending).
        failures: runs with status ``fail``.
        judged: runs with status ``pass`` or ``fail`` (the rate's denominator).
    """

    generated: int = 0
    failures: int = 0
    judged: int = 0

    @property
    def rate(self) -> float | None:
        """failures / judged, None when nothing was judged."""
        return self.failures / self.judged if self.judged else None

    @property
    def ci95(self) -> tuple[float, float] | None:
        """Wilson 95 % interval of the rate, None when nothing was judged."""
        from sitcov.analysis import wilson_interval

        if not self.judged:
            return None
        lo, hi = wilson_interval(self.failures, self.judged)
        return float(lo), float(hi)


def _tally(runs: Iterable[Any], key) -> dict[Any, list[int]]:
    table: dict[Any, list[int]] = {}
    for run in runs:
        if run.status == "pending":
            continue
        k = key(run.bins)
        if k is None:
            continue
        cell = table.setdefault(k, [0, 0, 0])
        cell[0] += 1
        if run.status == "fail":
            cell[1] += 1
            cell[2] += 1
        elif run.status == "pass":
            cell[2] += 1
    return table


def pair_table(
    runs: Sequence[Any], element_a: str, element_b: str
) -> dict[tuple[str, str], CellStats]:
    """(label of ``element_a``, label of ``element_b``) -> counts, for the cells seen."""

    def key(bins):
        if element_a in bins and element_b in bins:
            return bins[element_a], bins[element_b]
        return None

    return {k: CellStats(*v) for k, v in _tally(runs, key).items()}
