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


def outline(kind: str, row: tuple, length: float, width: float) -> list[tuple[float, float]]:
    """The outline of an actor of ``kind`` at ``row`` (t, x, y, yaw, speed): a box for cars
    and trucks, a pointed box (a bike seen from above) for cyclists, a disc for pedestrians."""
    _, x, y, yaw, _ = row
    if kind == "pedestrian":
        r = 0.5 * max(length, width)
        return [
            (x + r * math.cos(a), y + r * math.sin(a))
            for a in (2.0 * math.pi * i / 16 for i in range(16))
        ]
    if kind == "cyclist":
        hl, hw = 0.5 * length, 0.5 * width
        c, s = math.cos(yaw), math.sin(yaw)
        local = ((hl, 0.0), (0.3 * hl, hw), (-hl, hw), (-hl, -hw), (0.3 * hl, -hw))
        return [(x + c * u - s * v, y + s * u + c * v) for u, v in local]
    return [tuple(p) for p in corners((x, y, yaw, 0.5 * length, 0.5 * width))]


def _box(
    ax: Any, kind: str, row: tuple, size: tuple[float, float], color: str, alpha: float
) -> None:
    from matplotlib.patches import Polygon

    ax.add_patch(
        Polygon(
            outline(kind, row, *size),
            closed=True,
            facecolor=color,
            edgecolor="black",
            alpha=alpha,
            linewidth=0.6,
            zorder=4,
        )
    )


#: Colour of the ego; shades per kind for the other actors (the n-th actor of a kind takes
#: the n-th shade), so a picture's colours say which road user is which.
EGO_COLOR = "#1e88e5"
KIND_COLORS: dict[str, tuple[str, ...]] = {
    "car": ("#e53935", "#fb8c00", "#c2185b", "#6d4c41"),
    "truck": ("#5d4037", "#795548"),
    "cyclist": ("#2e7d32", "#00897b", "#9e9d24"),
    "pedestrian": ("#8e24aa", "#5e35b1", "#d81b60"),
}
#: Legend marker and trajectory line style per kind.
KIND_MARKERS = {"car": "s", "truck": "s", "cyclist": ">", "pedestrian": "o"}
KIND_LINES = {"car": "-", "truck": "-", "cyclist": "-.", "pedestrian": "--"}
#: Colours of actors of a kind without its own shades.
ACTOR_COLORS = ("#fdd835", "#3949ab", "#00acc1")


def _size(sizes: dict, name: str, length: float, width: float) -> tuple[float, float]:
    """(length, width) of actor ``name`` from ``meta["actors"]``, else the default."""
    info = sizes.get(name) or {}
    return float(info.get("length", length)), float(info.get("width", width))


def drawn_actors(trace: Trace, meta: dict) -> list[dict[str, Any]]:
    """Every actor to draw: name, kind, rows, route, colour, size, legend label (ego first,
    then the primary OV, then ``actor2``, ``actor3``, ... in slot order)."""
    length, width = meta.get("length", 4.5), meta.get("width", 1.6)
    sizes = meta.get("actors") or {}
    named = trace.actors or {}
    if named and "ov" not in named and any(r == trace.ov for r in named.values()):
        rows = dict(named)  # the primary OV is one of the named actors (esmini's entities)
    else:
        rows = {"ov": trace.ov, **{k: v for k, v in named.items() if k != "ov"}}
    shade: dict[str, int] = {}
    out = [
        {
            "name": "ego",
            "kind": "car",
            "rows": trace.ego,
            "route": meta.get("ego_route"),
            "color": EGO_COLOR,
            "size": (length, width),
            "label": "ego (car)",
        }
    ]
    for name in sorted(rows, key=lambda n: (n != "ov", len(n), n)):
        info = sizes.get(name) or {}
        kind = str(info.get("kind", "car"))
        n = shade.get(kind, 0)
        shade[kind] = n + 1
        palette = KIND_COLORS.get(kind, ACTOR_COLORS)
        out.append(
            {
                "name": name,
                "kind": kind,
                "rows": rows[name],
                "route": meta.get("ov_route") if name == "ov" else info.get("route"),
                "color": palette[n % len(palette)],
                "size": _size(sizes, name, length, width),
                "label": f"{'OV' if name == 'ov' else name} ({kind})",
            }
        )
    return out


def _draw_actor(ax: Any, actor: dict[str, Any]) -> Any:
    """Route (dotted), trajectory and boxes at a few instants; returns the legend handle."""
    from matplotlib.lines import Line2D

    color, kind, rows = actor["color"], actor["kind"], actor["rows"]
    if actor["route"]:
        xs, ys = zip(*actor["route"], strict=False)
        ax.plot(xs, ys, color=color, linestyle=":", linewidth=1, zorder=3)
    line = KIND_LINES.get(kind, "-")
    if rows:
        ax.plot(
            [r[1] for r in rows],
            [r[2] for r in rows],
            color=color,
            linestyle=line,
            linewidth=1.8,
            zorder=3,
        )
        picks = sorted({round(i * (len(rows) - 1) / (SNAPSHOTS - 1)) for i in range(SNAPSHOTS)})
        for n, i in enumerate(picks):
            alpha = 0.25 + 0.6 * n / max(1, len(picks) - 1)
            _box(ax, kind, rows[i], actor["size"], color, alpha)
        if kind == "pedestrian":  # a 0.5 m disc is a dot at junction scale: mark it too
            ax.plot(
                [rows[i][1] for i in picks],
                [rows[i][2] for i in picks],
                marker="o",
                linestyle="",
                markersize=5,
                color=color,
                markeredgecolor="black",
                zorder=5,
            )
    return Line2D(
        [],
        [],
        color=color,
        linestyle=line,
        linewidth=1.8,
        marker=KIND_MARKERS.get(kind, "s"),
        markerfacecolor=color,
        markeredgecolor="black",
        markersize=7,
        label=actor["label"],
    )


def render_topdown(
    outcome_or_trace: Outcome | Trace,
    path: str | FsPath,
    map: JunctionMap | str | Any | None = None,  # noqa: A002
) -> FsPath:
    """Draw the road, every actor's route and trajectory with its outline at a few instants
    (colour, shape and line style by kind; a legend names each), the conflict point and the
    collision.

    Args:
        outcome_or_trace: an Outcome run with ``record=True``, or its Trace.
        path: the PNG file to write.
        map: the map (default: the one named in the trace, else the T-junction), or any
            road drawing with a ``name``, ``draw(ax, limits)`` and ``view(trace)`` (the
            report's drawing of an OpenDRIVE road, ``sitcov.report._road``): the picture
            shows its ``view`` of the run.

    Returns:
        The path written.

    Raises:
        ConfigError: the outcome has no trace.
    """
    trace = outcome_or_trace.trace if isinstance(outcome_or_trace, Outcome) else outcome_or_trace
    if trace is None:
        raise ConfigError("render_topdown: the outcome has no trace; run it with record=True")
    meta = dict(trace.meta or {})
    if not meta.get("collision_point") and isinstance(outcome_or_trace, Outcome):
        point = (outcome_or_trace.metrics or {}).get("collision_point")
        if point:  # backends that keep it in the metrics only (esmini)
            meta["collision_point"] = point
    if map is None:
        map = meta.get("map", "t-junction")
    if isinstance(map, JunctionMap) or not hasattr(map, "draw"):
        jmap = map if isinstance(map, JunctionMap) else load_map(str(map))

        def draw(ax: Any, limits: Any) -> None:
            draw_map(ax, jmap)

        name, view = jmap.name, view_limits
    else:
        draw, name = map.draw, map.name
        view = getattr(map, "view", view_limits)
    import matplotlib

    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 7), dpi=110)
    try:
        limits = view(trace)
        draw(ax, limits)
        handles = [_draw_actor(ax, actor) for actor in drawn_actors(trace, meta)]
        if meta.get("conflict_point"):
            cx, cy = meta["conflict_point"]
            handles += ax.plot(
                cx,
                cy,
                marker="X",
                color="#212121",
                markersize=7,
                zorder=5,
                ls="",
                label="conflict point",
            )
        if meta.get("collision_point"):
            cx, cy = meta["collision_point"]
            handles += ax.plot(
                cx, cy, marker="*", color="black", markersize=16, zorder=6, ls="", label="collision"
            )
        if limits is not None:
            ax.set_xlim(*limits[0])
            ax.set_ylim(*limits[1])
        ax.set_aspect("equal")
        ax.set_facecolor("#7cb342")
        # sizes readable when the report shows the picture at half its width
        ax.legend(handles=handles, loc="upper right", fontsize=11, framealpha=0.9)
        end = trace.ego[-1][0] if trace.ego else math.nan
        ax.set_title(f"{name}: run of {end:.1f} s", fontsize=13)
        ax.set_xlabel("x [m]", fontsize=11)
        ax.set_ylabel("y [m]", fontsize=11)
        ax.tick_params(labelsize=10)
        out = FsPath(path)
        out.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(out, format="png")
    finally:
        plt.close(fig)
    return out


def draw_map(ax: Any, jmap: JunctionMap) -> None:
    """Draw a map's road, sidewalks, crosswalks, markings and kerbs on a matplotlib axis."""
    from matplotlib.patches import Polygon

    geometry = jmap.render_geometry()
    for poly in geometry["road_polygons"]:
        ax.add_patch(Polygon(poly, closed=True, facecolor="#bdbdbd", edgecolor="none", zorder=1))
    for key, color in (("sidewalks", "#9e9e9e"), ("crosswalks", "#eeeeee")):
        for poly in geometry.get(key, ()):
            ax.add_patch(Polygon(poly, closed=True, facecolor=color, edgecolor="none", zorder=1))
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
    ax.set_aspect("equal")
    ax.set_facecolor("#7cb342")


def view_limits(trace: Trace, pad: float = 8.0) -> tuple[tuple[float, float], ...] | None:
    """Square (x, y) limits around every actor's trajectory and the ego's route [m]."""
    meta = trace.meta or {}
    pts = [p for r in (trace.ego, trace.ov) for p in ((row[1], row[2]) for row in r)]
    for rows in (trace.actors or {}).values():
        pts += [(row[1], row[2]) for row in rows]
    pts += [tuple(p) for p in meta.get("ego_route", [])]
    if not pts:
        return None
    xs, ys = zip(*pts, strict=False)
    span = max(max(xs) - min(xs), max(ys) - min(ys)) / 2 + pad
    mx, my = (max(xs) + min(xs)) / 2, (max(ys) + min(ys)) / 2
    return (mx - span, mx + span), (my - span, my + span)
