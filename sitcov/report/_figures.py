"""The report's figures, drawn with matplotlib (Agg backend, imported only when a report is built).

Each function returns a finished :class:`matplotlib.figure.Figure`; :func:`save` writes it as a
PNG file and returns the bytes so the HTML can embed them.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

#: Figure width [in] and resolution [dots per inch] of every figure.
WIDTH = 10.0
DPI = 96

#: Colours of the compared series (colour-blind-safe, Okabe-Ito).
PALETTE = ("#0072B2", "#D55E00", "#009E73", "#CC79A7", "#E69F00", "#56B4E9", "#999999")


def _plt():
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    plt.rcParams.update(
        {
            "font.size": 9,
            "axes.titlesize": 10,
            "axes.spines.top": False,
            "axes.spines.right": False,
            "axes.grid": True,
            "axes.grid.axis": "y",
            "grid.alpha": 0.3,
            "legend.frameon": False,
        }
    )
    return plt


def save(fig: Any, path: Path) -> bytes:
    """Write ``fig`` to ``path`` as PNG, close it and return the PNG bytes."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI, format="png")
    _plt().close(fig)
    return path.read_bytes()


def _rotate(ax: Any, labels: Sequence[str]) -> None:
    if sum(len(str(lab)) for lab in labels) > 60 or len(labels) > 8:
        for tick in ax.get_xticklabels():
            tick.set_rotation(35)
            tick.set_horizontalalignment("right")


def element_figure(
    element: str,
    labels: Sequence[str],
    counts: Mapping[str, Mapping[str, int]],
    rates: Mapping[str, Mapping[str, Mapping[str, Any]]],
) -> Any:
    """Generated count per bin and failure rate per bin with Wilson 95 % error bars.

    Args:
        element: element name (title).
        labels: the element's bin labels, in hyperspace order.
        counts: series name -> label -> generated runs.
        rates: panel title (e.g. ``"no fault"``, ``"fault F1"``) -> series name -> label ->
            the summary's bin statistics (``failure_rate``, ``ci95``, ``failures``).
    """
    plt = _plt()
    panels = 1 + len(rates)
    wide = len(labels) > 8
    width_in = WIDTH if wide else WIDTH * 0.56
    height = 0.9 + 1.75 * panels
    fig, axes = plt.subplots(panels, 1, figsize=(width_in, height), sharex=True)
    long_labels = sum(len(str(lab)) for lab in labels) > 60
    fig.subplots_adjust(
        left=0.75 / width_in,
        right=1 - 0.15 / width_in,
        top=1 - 0.55 / height,
        bottom=(0.85 if long_labels else 0.4) / height,
        hspace=0.5,
    )
    axes = list(axes) if panels > 1 else [axes]
    series = list(counts)
    n = max(1, len(series))
    width = 0.8 / n
    xs = range(len(labels))

    ax = axes[0]
    for i, name in enumerate(series):
        offs = [x - 0.4 + width * (i + 0.5) for x in xs]
        ax.bar(
            offs,
            [counts[name].get(lab, 0) for lab in labels],
            width,
            label=name,
            color=PALETTE[i % len(PALETTE)],
        )
    ax.set_ylabel("runs generated")
    ax.set_title("runs per bin", loc="left", fontsize=9)
    fig.suptitle(
        element,
        x=0.75 / width_in,
        y=1 - 0.08 / height,
        ha="left",
        va="top",
        fontsize=11,
        fontweight="bold",
    )
    if len(series) > 1:
        fig.legend(
            *ax.get_legend_handles_labels(),
            ncols=min(4, len(series)),
            fontsize=8,
            loc="upper right",
            bbox_to_anchor=(1 - 0.15 / width_in, 1 - 0.04 / height),
        )

    for ax, (title, per_series) in zip(axes[1:], rates.items(), strict=True):
        for i, name in enumerate(series):
            stats = per_series.get(name, {})
            offs, heights, lo_err, hi_err = [], [], [], []
            for x, lab in zip(xs, labels, strict=True):
                s = stats.get(lab) or {}
                rate, ci = s.get("failure_rate"), s.get("ci95")
                if rate is None or ci is None:
                    continue
                offs.append(x - 0.4 + width * (i + 0.5))
                heights.append(rate)
                lo_err.append(max(0.0, rate - ci[0]))
                hi_err.append(max(0.0, ci[1] - rate))
            ax.bar(
                offs,
                heights,
                width,
                color=PALETTE[i % len(PALETTE)],
                alpha=0.85,
                yerr=[lo_err, hi_err],
                error_kw={"elinewidth": 1, "capsize": 2},
                label=name,
            )
        ax.set_ylim(0, 1.05)
        ax.set_ylabel("failure rate")
        ax.set_title(f"failure rate, {title} (Wilson 95% CI)", loc="left", fontsize=9)
    axes[-1].set_xticks(list(xs), [str(lab) for lab in labels])
    _rotate(axes[-1], labels)
    return fig


def ranked_bins_figure(title: str, rows: Sequence[Mapping[str, Any]], note: str = "") -> Any:
    """Horizontal failure-rate bars with Wilson 95 % intervals, one row per bin or group,
    labelled ``label (failures/judged)``: readable whatever the number of bins, since the
    figure's height follows the rows shown and long labels sit on the y axis.

    Args:
        title: the figure's title.
        rows: ``label``, ``failures``, ``judged``, ``failure_rate``, ``ci95`` per row, in
            the order to draw (top first).
        note: a line under the title (e.g. "30 of 216 bins shown").
    """
    plt = _plt()
    n = max(1, len(rows))
    longest = max((len(str(r["label"])) for r in rows), default=10) + 10
    left = min(4.5, 0.3 + 0.065 * longest)  # [in] room for the labels
    height = 1.0 + 0.24 * n
    fig, ax = plt.subplots(figsize=(WIDTH, height))
    fig.subplots_adjust(left=left / WIDTH, right=0.97, top=1 - 0.62 / height, bottom=0.4 / height)
    ys = list(range(n))[::-1]
    rates = [r["failure_rate"] or 0.0 for r in rows]
    lo = [
        max(0.0, rate - (r["ci95"] or (rate, rate))[0]) for rate, r in zip(rates, rows, strict=True)
    ]
    hi = [
        max(0.0, (r["ci95"] or (rate, rate))[1] - rate) for rate, r in zip(rates, rows, strict=True)
    ]
    ax.barh(
        ys,
        rates,
        xerr=[lo, hi],
        color=PALETTE[0],
        alpha=0.85,
        height=0.7,
        error_kw={"elinewidth": 1, "capsize": 2},
    )
    ax.set_yticks(ys, [f"{r['label']} ({r['failures']}/{r['judged']})" for r in rows], fontsize=8)
    ax.set_xlim(0, 1.02)
    ax.set_xlabel("failure rate (Wilson 95% CI)")
    ax.grid(axis="x", alpha=0.3)
    ax.grid(axis="y", visible=False)
    fig.suptitle(
        title,
        x=left / WIDTH,
        ha="left",
        y=1 - 0.08 / height,
        va="top",
        fontsize=11,
        fontweight="bold",
    )
    if note:
        fig.text(left / WIDTH, 1 - 0.38 / height, note, fontsize=8, color="#555", va="top")
    return fig


def histograms_figure(
    series: Mapping[str, Mapping[str, Sequence[float]]],
    caps: Mapping[str, float],
    marks: Mapping[str, tuple[float, str]] | None = None,
) -> Any:
    """One histogram per measure, passing and failing runs overlaid (counts), values above
    a measure's cap gathered in its last bin (labelled ``>= cap``); two per row from four
    measures on (each stays wide enough to read); ``marks``: measure -> (value, label) of
    a dashed vertical line (a threshold)."""
    plt = _plt()
    import numpy as np

    n = max(1, len(series))
    cols = n if n <= 3 else 2
    rows = -(-n // cols)
    height = 3.0 * rows + 0.3
    fig, axes = plt.subplots(rows, cols, figsize=(WIDTH, height), squeeze=False)
    fig.subplots_adjust(
        left=0.07,
        right=0.98,
        bottom=0.6 / height,
        top=1 - 0.45 / height,
        wspace=0.28 if cols > 2 else 0.2,
        hspace=0.9 / 3.0,
    )
    axes = list(axes.flat)
    for ax in axes[n:]:
        ax.set_visible(False)
    for ax, (label, by_status) in zip(axes, series.items(), strict=False):
        cap = caps[label]
        edges = np.linspace(0.0, cap, 21)
        edges[-1] = cap + 1e-9
        for i, (status, colour) in enumerate((("pass", PALETTE[0]), ("fail", PALETTE[1]))):
            values = by_status.get(status, [])
            ax.hist(
                values,
                bins=edges,
                color=colour,
                alpha=0.6 if i else 0.75,
                label=f"{status} ({len(values)})",
            )
        if marks and label in marks:
            value, text = marks[label]
            ax.axvline(value, color="black", ls="--", lw=1, label=text)
        ax.set_xlabel(f"{label} (last bin: >= {cap:g})")
        ax.set_ylabel("runs")
        # the tall bars sit at either end (TTC near 0, DRAC in its last bin): a framed
        # legend where it covers least stays readable over a bar; with a threshold mark
        # (DRAC: tall bars at both ends) between the ends
        where = "upper center" if marks and label in marks else "best"
        ax.legend(fontsize=8, loc=where, frameon=True, framealpha=0.85, edgecolor="none")
    fig.suptitle("Criticality of every judged run (most critical over its road users)", fontsize=10)
    return fig


def growth_figure(curves: Mapping[str, tuple[Sequence[float], Sequence[float], int]]) -> Any:
    """Bins covered and pairwise coverage against run index, one line per campaign.

    Args:
        curves: campaign name -> (bins covered after each run, pairwise coverage after each
            run in [0, 1], total number of bins).
    """
    plt = _plt()
    from matplotlib.ticker import MaxNLocator

    rows = -(-len(curves) // 4) if len(curves) > 1 else 0  # legend rows below the axes
    height = 3.2 + 0.22 * rows
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(WIDTH, height))
    fig.subplots_adjust(
        left=0.07,
        right=0.98,
        bottom=(0.5 + 0.22 * rows + 0.1) / height,
        top=1 - 0.35 / height,
        wspace=0.22,
    )
    total, longest = 0, 0
    for i, (name, (bins, pairs, n_bins)) in enumerate(curves.items()):
        colour = PALETTE[i % len(PALETTE)]
        style = ("-", "--", ":", "-.")[(i // len(PALETTE)) % 4]
        xs = range(1, len(bins) + 1)
        ax1.plot(xs, bins, color=colour, ls=style, label=name, lw=1.4)
        ax2.plot(xs, [100.0 * p for p in pairs], color=colour, ls=style, lw=1.4)
        total = max(total, n_bins)
        longest = max(longest, len(bins))
    if longest > 100:  # early growth is what differs between generators: log scale shows it
        for ax in (ax1, ax2):
            ax.set_xscale("log")
            ax.set_xlim(1, longest)
    else:
        for ax in (ax1, ax2):
            ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    if total:
        ax1.axhline(total, color="#555", ls="--", lw=0.8)
    ax1.set_xlabel("runs")
    ax1.set_ylabel("bins covered")
    ax1.set_title("Bins covered" + (f" (of {total})" if total else ""))
    ax2.set_xlabel("runs")
    ax2.set_ylabel("pairwise coverage [%]")
    ax2.set_ylim(0, 101)
    ax2.set_title("2-way (pairwise) coverage")
    if rows:
        fig.legend(loc="lower center", ncols=4, fontsize=7, bbox_to_anchor=(0.5, 0.0))
    return fig


def heatmap_figure(
    element_a: str,
    labels_a: Sequence[str],
    element_b: str,
    labels_b: Sequence[str],
    cells: Mapping[tuple[str, str], Any],
) -> Any:
    """Failure rate over two elements; each cell is annotated with failures/judged runs."""
    plt = _plt()
    import numpy as np

    labels_a, note_a = _busiest(labels_a, cells, rows=True)
    labels_b, note_b = _busiest(labels_b, cells, rows=False)
    grid = np.full((len(labels_a), len(labels_b)), np.nan)
    for i, la in enumerate(labels_a):
        for j, lb in enumerate(labels_b):
            cell = cells.get((la, lb))
            if cell is not None and cell.rate is not None:
                grid[i, j] = cell.rate
    height = 1.4 + 0.32 * len(labels_a)
    longest = max((len(str(lab)) for lab in labels_a), default=4)
    left = min(3.5, 0.5 + 0.07 * longest)  # [in] room for the row labels
    width = min(WIDTH, left + 1.5 + 0.9 * len(labels_b))
    fig, ax = plt.subplots(figsize=(width, height))
    fig.subplots_adjust(left=left / width, right=1.0, bottom=1.0 / height, top=1 - 0.55 / height)
    cmap = plt.get_cmap("Reds").with_extremes(bad="#eeeeee")
    image = ax.imshow(grid, cmap=cmap, vmin=0.0, vmax=1.0, aspect="auto")
    ax.grid(False)
    for i, la in enumerate(labels_a):
        for j, lb in enumerate(labels_b):
            cell = cells.get((la, lb))
            if cell is None or not cell.judged:
                continue
            value = grid[i, j]
            ax.text(
                j,
                i,
                f"{cell.failures}/{cell.judged}",
                ha="center",
                va="center",
                fontsize=7,
                color="white" if value > 0.6 else "#222",
            )
    ax.set_xticks(range(len(labels_b)), [str(lab) for lab in labels_b])
    ax.set_yticks(range(len(labels_a)), [str(lab) for lab in labels_a])
    ax.set_xlabel(element_b)
    ax.set_ylabel(element_a)
    title = f"Failure rate by {element_a} and {element_b} (failures/judged runs)"
    shown = "; ".join(x for x in (note_a, note_b) if x)
    ax.set_title(title + (f"\n{shown}" if shown else ""), fontsize=9)
    _rotate(ax, [str(lab) for lab in labels_b])
    fig.colorbar(image, ax=ax, label="failure rate", shrink=0.9)
    return fig


#: the heat map shows at most this many rows and columns (the highest failure rates)
MAX_HEAT = 24


def _busiest(
    labels: Sequence[str], cells: Mapping[tuple[str, str], Any], *, rows: bool
) -> tuple[list[str], str]:
    """At most :data:`MAX_HEAT` labels of one side of the heat map: those whose cells fail
    most in total (Wilson lower bound of their pooled rate), in hyperspace order."""
    labels = list(labels)
    if len(labels) <= MAX_HEAT:
        return labels, ""
    from sitcov.analysis import wilson_interval

    score = {}
    for lab in labels:
        k = n = 0
        for (la, lb), cell in cells.items():
            if (la if rows else lb) == lab and cell is not None:
                k, n = k + cell.failures, n + cell.judged
        ci = wilson_interval(k, n)
        score[lab] = ci[0] if ci else -1.0
    keep = set(sorted(labels, key=lambda lab: -score[lab])[:MAX_HEAT])
    side = "rows" if rows else "columns"
    return [lab for lab in labels if lab in keep], (
        f"{MAX_HEAT} of {len(labels)} {side} shown (highest failure rates)"
    )


def table2_figure(table: Mapping[str, Mapping[str, Any]]) -> Any:
    """Failures per fault for each generator, Wilson 95 % intervals (Table 2 as a chart)."""
    plt = _plt()
    faults = ["NF", "F1", "F2", "F3"]
    gens = list(table)
    fig, ax = plt.subplots(figsize=(WIDTH * 0.6, 3.0))
    fig.subplots_adjust(left=0.12, right=0.98, bottom=0.1, top=0.9)
    width = 0.8 / max(1, len(gens))
    for i, gen in enumerate(gens):
        row = table[gen]
        runs = max(1, int(row.get("runs", 0)))
        offs, vals, lo, hi = [], [], [], []
        for x, fault in enumerate(faults):
            if fault not in row:
                continue
            rate = row[fault] / runs
            ci = row.get("ci95", {}).get(fault) or (rate, rate)
            offs.append(x - 0.4 + width * (i + 0.5))
            vals.append(rate)
            lo.append(max(0.0, rate - ci[0]))
            hi.append(max(0.0, ci[1] - rate))
        ax.bar(
            offs, vals, width, yerr=[lo, hi], capsize=3, label=gen, color=PALETTE[i % len(PALETTE)]
        )
    ax.set_xticks(range(len(faults)), faults)
    ax.set_ylim(0, 1.05)
    ax.set_ylabel("failure rate")
    ax.set_title("Failures per seeded fault (Table 2), Wilson 95% intervals")
    ax.legend(fontsize=8)
    return fig
