"""The report's collision map: where on the junction the ego collided, over every run.

Each collision a run stores (``outcome.metrics["collision_point"]``: the centroid of the
two boxes' overlap at the first step they touched, map frame [m]; the embedded, esmini and
CARLA backends record it) is drawn on the junction of the campaign's map (for esmini
campaigns: on the lanes of their OpenDRIVE road near the collisions,
``sitcov.report._road``), coloured by the kind of road user hit (``collision_kind``),
filled when the campaign's judge counts the run as a failure and hollow when it does not
(e.g. a standing ego was hit under the default judge). Campaigns on different maps get a
panel each. Runs stored before the point was recorded (store schema < 5) are counted in
the caption, not drawn.
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sitcov.report import _figures
from sitcov.report._road import road_drawing, run_road
from sitcov.report._sections import b64

#: Marker colour per kind of road user hit (Okabe-Ito: colour-blind safe); others grey.
KIND_COLOURS = {
    "car": "#0072B2",
    "truck": "#56B4E9",
    "pedestrian": "#D55E00",
    "cyclist": "#009E73",
}
OTHER_COLOUR = "#999999"
#: Marker per kind (shape tells the kinds apart without colour too); others a cross.
KIND_MARKERS = {"car": "s", "truck": "D", "pedestrian": "o", "cyclist": "^"}
#: The view around the drawn points: padding [m] and the smallest half side [m].
PAD, MIN_HALF = 8.0, 22.0
#: Panels per row of the figure.
COLUMNS = 2
#: Collisions closer than this [m] (same kind and verdict) share one marker, its area
#: growing with their number.
GRID = 1.0


@dataclass(frozen=True)
class CollisionPoint:
    """One collision: map, where [m], the kind hit, whether the run failed."""

    map: str
    x: float
    y: float
    kind: str
    failed: bool


def campaign_map(config: Mapping[str, Any], metrics: Mapping[str, Any] | None = None) -> str:
    """The map a campaign ran on (its ``backend_options.map``, else the default embedded
    map); for the esmini backend the OpenDRIVE road of the run with ``metrics``
    (:func:`sitcov.report._road.run_road`)."""
    from sitcov.campaign._build import DEFAULT_EMBEDDED_MAP

    if config.get("backend") == "esmini":
        return run_road(config, None, metrics)
    options = config.get("backend_options") or {}
    ref = options.get("map") if isinstance(options, Mapping) else None
    return str(ref) if ref else DEFAULT_EMBEDDED_MAP


def collision_point(run: Any, map_ref: str) -> CollisionPoint | None | bool:
    """The run's :class:`CollisionPoint`; False for a collision stored without a point
    (older stores), None without a collision."""
    outcome = run.outcome
    if outcome is None or not outcome.collision:
        return None
    metrics = outcome.metrics or {}
    point = metrics.get("collision_point")
    if not (isinstance(point, list | tuple) and len(point) == 2):
        return False
    x, y = point
    if not all(isinstance(v, int | float) and math.isfinite(v) for v in (x, y)):
        return False
    kind = metrics.get("collision_kind") or "car"
    return CollisionPoint(map_ref, float(x), float(y), str(kind), run.status == "fail")


def collision_map_section(
    points: Sequence[CollisionPoint], unlocated: int, fig_dir: Path
) -> dict[str, Any]:
    """The page's ``collision_map``: the figure and its caption (None without collisions)."""
    if not points and not unlocated:
        return {"collision_map": None}
    png = None
    if points:
        png = b64(_figures.save(collision_figure(points), fig_dir / "collision_map.png"))
    kinds: dict[str, int] = {}
    for p in points:
        kinds[p.kind] = kinds.get(p.kind, 0) + 1
    counted = sum(p.failed for p in points)
    caption = (
        f"{len(points)} collisions drawn ("
        + ", ".join(f"{n} with a {k}" for k, n in sorted(kinds.items(), key=lambda kv: -kv[1]))
        + f"); {counted} count as failures (filled), {len(points) - counted} do not (hollow)."
    )
    if unlocated:
        caption += (
            f" {unlocated} collisions were stored without a location (runs stored before "
            "sitcov recorded it) and are not drawn."
        )
    return {"collision_map": {"png": png, "caption": caption}}


def collision_figure(points: Sequence[CollisionPoint]) -> Any:
    """One panel per map: the junction (or the OpenDRIVE road near the collisions) drawn as
    the top-down pictures draw it, the
    collisions as markers coloured and shaped by the kind hit, filled for failures, hollow
    otherwise, those within :data:`GRID` metres of each other as one marker whose area
    grows with their number; one legend for all panels below them (counts over every map,
    and the marker sizes)."""
    plt = _figures._plt()
    from matplotlib.lines import Line2D

    maps = list(dict.fromkeys(p.map for p in points))
    cols = min(COLUMNS, len(maps))
    rows = -(-len(maps) // cols)
    side = min(_figures.WIDTH / cols, 6.0)
    groups = sorted(
        {(p.kind, p.failed) for p in points},
        key=lambda kf: (kf[0] not in KIND_COLOURS, kf[0], not kf[1]),
    )
    legend_rows = -(-(len(groups) + 4) // 3)  # the kinds, then up to 4 marker sizes
    height = 0.86 * side * rows + 0.5 + 0.25 * legend_rows + 0.35  # square panels, legend
    fig, axes = plt.subplots(rows, cols, figsize=(_figures.WIDTH, height), squeeze=False)
    fig.subplots_adjust(
        left=0.07,
        right=0.98,
        top=1 - 0.35 / height,
        bottom=(0.5 + 0.25 * legend_rows + 0.1) / height,
        wspace=0.22,
        hspace=0.25,
    )
    for ax in axes.flat[len(maps) :]:
        ax.set_visible(False)
    for ax, ref in zip(axes.flat, maps, strict=False):
        mine = [p for p in points if p.map == ref]
        road = road_drawing(ref)
        (x0, x1), (y0, y1) = _limits(mine)
        road.draw(ax, ((x0, x1), (y0, y1)))
        ax.grid(False)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        for kind, failed in groups:
            cells = _cells([p for p in mine if p.kind == kind and p.failed == failed])
            if cells:
                ax.scatter(
                    [c[0] for c in cells],
                    [c[1] for c in cells],
                    s=[_area(c[2]) for c in cells],
                    marker=KIND_MARKERS.get(kind, "X"),
                    **_style(kind, failed),
                    zorder=6 if not failed else 5,
                )
        failed = sum(p.failed for p in mine)
        ax.set_title(f"{road.name}: {len(mine)} collisions, {failed} failures", fontsize=10)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        ax.tick_params(labelsize=8)
    handles = [
        Line2D(
            [],
            [],
            ls="",
            marker=KIND_MARKERS.get(kind, "X"),
            markersize=8,
            markerfacecolor=_style(kind, failed)["facecolors"],
            markeredgecolor=_style(kind, failed)["edgecolors"],
            label=f"{kind}, {'failure' if failed else 'not a failure'} "
            f"({sum(p.kind == kind and p.failed == failed for p in points)})",
        )
        for kind, failed in groups
    ]
    most = max(Counter(_key(p) for p in points).values())
    handles += [
        Line2D(
            [],
            [],
            ls="",
            marker="o",
            markersize=_area(n) ** 0.5,
            markerfacecolor="#bdbdbd",
            markeredgecolor="black",
            markeredgewidth=0.5,
            label=f"{n} at one place" if n == 1 else f"{n} within {GRID:g} m",
        )
        for n in (1, 10, 100, 1000)
        if n == 1 or n <= most
    ]
    fig.legend(
        handles=handles, loc="lower center", ncol=min(3, len(handles)), fontsize=9, frameon=False
    )
    return fig


def _style(kind: str, failed: bool) -> dict[str, Any]:
    """Marker colours: filled in the kind's colour for a failure, hollow (edge only, drawn
    thicker) for a collision the judge does not count."""
    colour = KIND_COLOURS.get(kind, OTHER_COLOUR)
    if failed:
        return {"facecolors": colour, "edgecolors": "white", "linewidths": 0.4, "alpha": 0.85}
    return {"facecolors": "none", "edgecolors": colour, "linewidths": 1.4, "alpha": 1.0}


def _key(p: CollisionPoint) -> tuple:
    """The cell of :data:`GRID` metres a point falls in, with its map, kind and verdict."""
    return (p.map, p.kind, p.failed, round(p.x / GRID), round(p.y / GRID))


def _cells(points: Sequence[CollisionPoint]) -> list[tuple[float, float, int]]:
    """Collisions within one :data:`GRID` cell drawn as one marker: (mean x, mean y, count)
    per cell, so that a place where hundreds of runs collided shows as a large marker,
    not as one dot with the others hidden under it."""
    cells: dict[tuple, list[CollisionPoint]] = {}
    for p in points:
        cells.setdefault(_key(p), []).append(p)
    return [
        (sum(p.x for p in ps) / len(ps), sum(p.y for p in ps) / len(ps), len(ps))
        for ps in cells.values()
    ]


def _area(count: int) -> float:
    """Marker area [pt^2] of a cell with ``count`` collisions: grows with its square root
    (1: 16, 100: 160, 1000: 506)."""
    return 16.0 * count**0.5


def _limits(points: Sequence[CollisionPoint]) -> tuple[tuple[float, float], tuple[float, float]]:
    """A square view around the points, at least ``2 * MIN_HALF`` metres wide."""
    xs, ys = [p.x for p in points], [p.y for p in points]
    half = max(MIN_HALF, 0.5 * max(max(xs) - min(xs), max(ys) - min(ys)) + PAD)
    mx, my = 0.5 * (max(xs) + min(xs)), 0.5 * (max(ys) + min(ys))
    return (mx - half, mx + half), (my - half, my + half)
