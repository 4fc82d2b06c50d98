"""A top-down picture of a recorded run (PNG), for reports and debugging."""

from __future__ import annotations

import math
from pathlib import Path as FsPath
from typing import Any

from sitcov.errors import ConfigError
from sitcov.sim._base import Outcome, Trace
from sitcov.sim.embedded._collision import corners
from sitcov.sim.embedded._map import JunctionMap, load_map

#: How many vehicle boxes to draw along each trajectory.
SNAPSHOTS = 5


def _box(ax: Any, row: tuple, length: float, width: float, color: str, alpha: float) -> None:
    from matplotlib.patches import Polygon

    _, x, y, yaw, _ = row
    pts = corners((x, y, yaw, 0.5 * length, 0.5 * width))
    ax.add_patch(
        Polygon(
            pts,
            closed=True,
            facecolor=color,
            edgecolor="black",
            alpha=alpha,
            linewidth=0.6,
            zorder=4,
        )
    )


#: Colours of the actors beyond the ego and the OV in top-down pictures.
ACTOR_COLORS = ("#fb8c00", "#8e24aa", "#00897b", "#6d4c41", "#fdd835", "#3949ab")


def _size(sizes: dict, name: str, length: float, width: float) -> tuple[float, float]:
    """(length, width) of actor ``name`` from ``meta["actors"]``, else the default."""
    info = sizes.get(name) or {}
    return float(info.get("length", length)), float(info.get("width", width))


def render_topdown(
    outcome_or_trace: Outcome | Trace,
    path: str | FsPath,
    map: JunctionMap | str | None = None,  # noqa: A002
) -> FsPath:
    """Draw the road, both routes and paths, vehicle boxes at a few instants, the collision.

    Args:
        outcome_or_trace: an Outcome run with ``record=True``, or its Trace.
        path: the PNG file to write.
        map: the map (default: the one named in the trace, else the T-junction).

    Returns:
        The path written.

    Raises:
        ConfigError: the outcome has no trace.
    """
    trace = outcome_or_trace.trace if isinstance(outcome_or_trace, Outcome) else outcome_or_trace
    if trace is None:
        raise ConfigError("render_topdown: the outcome has no trace; run it with record=True")
    meta = trace.meta or {}
    if map is None:
        map = meta.get("map", "t-junction")
    jmap = map if isinstance(map, JunctionMap) else load_map(str(map))
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    from matplotlib.patches import Polygon

    geometry = jmap.render_geometry()
    fig, ax = plt.subplots(figsize=(7, 7), dpi=110)
    try:
        for poly in geometry["road_polygons"]:
            ax.add_patch(
                Polygon(poly, closed=True, facecolor="#bdbdbd", edgecolor="none", zorder=1)
            )
        for key, color in (("sidewalks", "#9e9e9e"), ("crosswalks", "#eeeeee")):
            for poly in geometry.get(key, ()):
                ax.add_patch(
                    Polygon(poly, closed=True, facecolor=color, edgecolor="none", zorder=1)
                )
        for mark in geometry["markings"]:
            xs, ys = zip(*mark["points"], strict=False)
            ax.plot(
                xs,
                ys,
                color="#fbc02d" if mark["color"] == "yellow" else "white",
                linestyle="--" if mark["style"] == "dashed" else "-",
                linewidth=1,
                zorder=2,
            )
        for kerb in geometry["kerbs"]:
            xs, ys = zip(*kerb, strict=False)
            ax.plot(xs, ys, color="#555555", linewidth=1.2, zorder=2)
        length, width = meta.get("length", 4.5), meta.get("width", 1.6)
        sizes = meta.get("actors") or {}
        drawn = [
            ("ego_route", trace.ego, "#1e88e5", "ego", length, width),
            ("ov_route", trace.ov, "#e53935", "OV", *_size(sizes, "ov", length, width)),
        ]
        # further actors (traces recorded before actors existed have none)
        for n, (name, rows) in enumerate(sorted((trace.actors or {}).items())):
            if name != "ov":
                info = sizes.get(name, {})
                color = ACTOR_COLORS[n % len(ACTOR_COLORS)]
                label = f"{name} ({info.get('kind', '?')})"
                drawn.append((name, rows, color, label, *_size(sizes, name, length, width)))
        for key, rows, color, label, length, width in drawn:
            route = meta.get(key) or sizes.get(key, {}).get("route")
            if route:
                xs, ys = zip(*route, strict=False)
                ax.plot(xs, ys, color=color, linestyle=":", linewidth=1, zorder=3)
            if rows:
                ax.plot(
                    [r[1] for r in rows],
                    [r[2] for r in rows],
                    color=color,
                    linewidth=1.8,
                    zorder=3,
                    label=label,
                )
                picks = sorted(
                    {round(i * (len(rows) - 1) / (SNAPSHOTS - 1)) for i in range(SNAPSHOTS)}
                )
                for n, i in enumerate(picks):
                    _box(ax, rows[i], length, width, color, 0.25 + 0.6 * n / max(1, len(picks) - 1))
        if meta.get("conflict_point"):
            cx, cy = meta["conflict_point"]
            ax.plot(
                cx, cy, marker="o", color="#6a1b9a", markersize=6, zorder=5, label="conflict point"
            )
        if meta.get("collision_point"):
            cx, cy = meta["collision_point"]
            ax.plot(cx, cy, marker="*", color="black", markersize=16, zorder=6, label="collision")
        pts = [p for r in (trace.ego, trace.ov) for p in ((row[1], row[2]) for row in r)]
        for rows in (trace.actors or {}).values():
            pts += [(row[1], row[2]) for row in rows]
        pts += [tuple(p) for p in meta.get("ego_route", [])]
        if pts:
            xs, ys = zip(*pts, strict=False)
            pad = 8.0
            span = max(max(xs) - min(xs), max(ys) - min(ys)) / 2 + pad
            mx, my = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
            ax.set_xlim(mx - span, mx + span)
            ax.set_ylim(my - span, my + span)
        ax.set_aspect("equal")
        ax.set_facecolor("#7cb342")
        ax.legend(loc="upper right", fontsize=8)
        end = trace.ego[-1][0] if trace.ego else math.nan
        ax.set_title(f"{jmap.name}: run of {end:.1f} s", fontsize=10)
        ax.set_xlabel("x [m]")
        ax.set_ylabel("y [m]")
        out = FsPath(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, format="png")
    finally:
        plt.close(fig)
    return out
