"""The generator race's figure: distinct failure regions found against runs, per generator."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sitcov.report._figures import PALETTE, WIDTH, _plt, save


def race_figure(result: Mapping[str, Any], path: Any) -> bytes:
    """Distinct failure regions found vs runs, per generator: mean over seeds with a 95 %
    t-band; written as PNG to ``path`` (matplotlib, as the report's figures)."""
    import numpy as np
    from scipy.stats import t

    plt = _plt()
    fig, ax = plt.subplots(figsize=(WIDTH * 0.7, 3.6))
    fig.subplots_adjust(left=0.09, right=0.98, bottom=0.13, top=0.9)
    by_gen: dict[str, list[Mapping[str, Any]]] = {}
    for m in result["campaigns"]:
        by_gen.setdefault(m["campaign"].split("/")[1], []).append(m)
    order = [g for g in result["table"] if g in by_gen]
    for i, gen in enumerate(order):
        runs = min(m["runs"] for m in by_gen[gen])
        x = np.arange(1, runs + 1)
        curves = np.array(
            [[sum(f is not None and f <= n for f in m["first_failure"]) for n in x]
             for m in by_gen[gen]]
        )  # fmt: skip
        mean = curves.mean(axis=0)
        colour = PALETTE[i % len(PALETTE)]
        ax.plot(x, mean, label=gen, color=colour, lw=1.5)
        if len(curves) > 1:
            half = t.ppf(0.975, len(curves) - 1) * curves.std(axis=0, ddof=1) / len(curves) ** 0.5
            top = len(result["regions"])
            lo, hi = np.clip(mean - half, 0, top), np.clip(mean + half, 0, top)
            ax.fill_between(x, lo, hi, color=colour, alpha=0.12, lw=0)
    ax.axhline(len(result["regions"]), color="#444444", lw=0.8, ls=":")
    ax.set_ylim(0, len(result["regions"]) + 0.5)
    ax.set_xlabel("runs")
    ax.set_ylabel("distinct failure regions found")
    ax.set_title(f"Generator race: {len(result['regions'])} reference failure regions, "
                 "mean over seeds with 95% band")  # fmt: skip
    ax.legend(fontsize=8, ncol=2)
    return save(fig, Path(path))
