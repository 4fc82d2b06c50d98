"""The road under the report's top-down drawings, from whichever source a campaign used.

One interface for every drawing of a run or a campaign (pictured failing runs,
``sitcov animate``, the collision map): :func:`road_drawing` gives an object with a
``name`` and ``draw(ax, limits)``:

- an embedded map (a shipped name, a map YAML, an imported ``FILE.xodr#ID`` junction):
  the embedded renderer's ``draw_map`` (road, sidewalks, crosswalks, markings, kerbs);
- an OpenDRIVE file (the esmini backend's road, ``--road FILE.xodr`` or the scenario's
  ``LogicFile``): every lane drawn from sitcov's own reader (``sitcov.roads``): driving
  lanes, sidewalks, other lane types (shoulders, parking, ...) in their own shades, lane
  lines, the line between the two directions and the road's edges, in the embedded maps'
  colours. Only what lies in the view is drawn (a town has thousands of lanes), and each
  file is parsed once per process.

:func:`run_road` says which road a stored run was played on (its campaign's configuration
and its trace).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path
from typing import Any, Protocol

from sitcov.errors import ConfigError

#: Colours, as the embedded renderer draws its maps (``sitcov.sim.embedded._render``).
GRASS, ROAD, SIDEWALK = "#7cb342", "#bdbdbd", "#9e9e9e"
#: Lane types that are not driving lanes nor sidewalks (shoulder, parking, biking, ...);
#: ``none`` and ``border`` lanes are OpenDRIVE's filler and are not drawn.
OTHER_LANE = "#d7ccc8"
HIDDEN_TYPES = frozenset({"none", "border"})
#: Line colour, width [pt] and style per :class:`~sitcov.roads.LaneBorder` kind.
LINES = {
    "lane": ("white", 1.0, "--"),
    "centre": ("#fbc02d", 1.2, "-"),
    "edge": ("#555555", 1.2, "-"),
}
#: Lanes and lines within this distance [m] of the view are drawn.
MARGIN = 5.0
#: On an OpenDRIVE road the view holds the ego's path and route, and the other actors'
#: positions within this distance [m] of the ego's path (a car 300 m away on a straight
#: road, or across a town, would shrink the junction to a few pixels).
NEAR = 30.0
#: Padding [m] around the view's points.
PAD = 8.0

Limits = tuple[tuple[float, float], tuple[float, float]]


class RoadDrawing(Protocol):
    """What the report draws a road with: a name for titles, and ``draw`` onto a
    matplotlib axis, limited to ``limits`` ((x0, x1), (y0, y1)) [m] when given."""

    name: str

    def draw(self, ax: Any, limits: Limits | None = None) -> None: ...

    def view(self, trace: Any) -> Limits | None:
        """The (square) part of the road a picture of the run with ``trace`` shows."""
        ...


@dataclass(frozen=True)
class EmbeddedDrawing:
    """An embedded map, drawn by the embedded renderer (the whole junction)."""

    jmap: Any

    @property
    def name(self) -> str:
        return str(self.jmap.name)

    def draw(self, ax: Any, limits: Limits | None = None) -> None:
        from sitcov.sim.embedded._render import draw_map

        draw_map(ax, self.jmap)

    def view(self, trace: Any) -> Limits | None:
        """Every actor's trajectory and the ego's route (the junction is small)."""
        from sitcov.sim.embedded._render import view_limits

        return view_limits(trace)  # type: ignore[return-value]


@dataclass(frozen=True)
class OpenDriveDrawing:
    """An OpenDRIVE file's lanes and lines (:func:`sitcov.roads.lane_outlines`)."""

    path: str
    lanes: tuple
    borders: tuple

    @property
    def name(self) -> str:
        return Path(self.path).name

    def visible(self, limits: Limits | None) -> tuple[list, list]:
        """The lanes and lines whose bounding box meets ``limits`` grown by :data:`MARGIN`
        (everything without limits)."""
        if limits is None:
            return list(self.lanes), list(self.borders)
        (x0, x1), (y0, y1) = limits
        x0, x1, y0, y1 = x0 - MARGIN, x1 + MARGIN, y0 - MARGIN, y1 + MARGIN

        def near(b: tuple[float, float, float, float]) -> bool:
            return b[0] <= x1 and b[2] >= x0 and b[1] <= y1 and b[3] >= y0

        return [x for x in self.lanes if near(x.bbox)], [x for x in self.borders if near(x.bbox)]

    def view(self, trace: Any) -> Limits | None:
        """:func:`run_view`: the ego's path and whoever came near it."""
        return run_view(trace)

    def draw(self, ax: Any, limits: Limits | None = None) -> None:
        from matplotlib.collections import LineCollection, PolyCollection

        lanes, borders = self.visible(limits)
        layers = (
            ([x for x in lanes if x.type not in HIDDEN_TYPES and not x.drivable
              and x.type != "sidewalk"], OTHER_LANE),
            ([x for x in lanes if x.type == "sidewalk"], SIDEWALK),
            ([x for x in lanes if x.drivable], ROAD),
        )  # fmt: skip
        for group, colour in layers:
            if group:
                ax.add_collection(
                    PolyCollection(
                        [x.polygon for x in group],
                        facecolors=colour,
                        edgecolors=colour,
                        linewidths=0.3,  # closes the hairline gaps between adjacent lanes
                        zorder=1,
                    )
                )
        for kind, (colour, width, style) in LINES.items():
            lines = [x.points for x in borders if x.kind == kind]
            if lines:
                ax.add_collection(
                    LineCollection(
                        lines, colors=colour, linewidths=width, linestyles=style, zorder=2
                    )
                )
        if limits is None and lanes:
            ax.autoscale_view()
        ax.set_aspect("equal")
        ax.set_facecolor(GRASS)


def run_view(trace: Any, near: float = NEAR, pad: float = PAD) -> Limits | None:
    """Square limits [m] around the ego's trajectory and route, and the rows of the other
    actors that came within ``near`` metres of the ego's trajectory or route."""
    import numpy as np

    meta = trace.meta or {}
    own = [(r[1], r[2]) for r in trace.ego or ()] + [
        (p[0], p[1]) for p in meta.get("ego_route") or ()
    ]
    if not own:
        return None
    ego = np.asarray(own, dtype=float)[:: max(1, len(own) // 400)]
    pts = [ego]
    for rows in [trace.ov or [], *(trace.actors or {}).values()]:
        if not rows:
            continue
        xy = np.asarray([(r[1], r[2]) for r in rows], dtype=float)
        d2 = ((xy[:, None, :] - ego[None, :, :]) ** 2).sum(axis=2).min(axis=1)
        pts.append(xy[d2 <= near * near])
    allp = np.vstack(pts)
    lo, hi = allp.min(axis=0), allp.max(axis=0)
    half = 0.5 * float(max(hi - lo)) + pad
    mx, my = 0.5 * (lo + hi)
    return (float(mx - half), float(mx + half)), (float(my - half), float(my + half))


def is_opendrive(ref: str) -> bool:
    """Whether ``ref`` names an OpenDRIVE file as a whole (not ``FILE.xodr#ID``, which is
    one junction imported as an embedded map)."""
    return str(ref).lower().endswith(".xodr")


@lru_cache(maxsize=4)
def _opendrive(path: str, mtime: float, size: int) -> OpenDriveDrawing:
    from sitcov.roads import lane_outlines, read_opendrive

    lanes, borders = lane_outlines(read_opendrive(path))
    return OpenDriveDrawing(path, tuple(lanes), tuple(borders))


def road_drawing(ref: str) -> RoadDrawing:
    """The drawing of road ``ref``: an OpenDRIVE file (parsed once per process and file
    version), else an embedded map by name or file.

    Raises:
        ConfigError: an OpenDRIVE file that is missing or unreadable (naming it), or an
            unknown map.
    """
    ref = str(ref)
    if is_opendrive(ref):
        path = Path(ref)
        try:
            st = path.stat()
        except OSError:
            raise ConfigError(
                file=ref, field="road", expected="the OpenDRIVE file the run was played on"
            ) from None
        return _opendrive(str(path.resolve()), st.st_mtime, st.st_size)
    from sitcov.sim.embedded import load_map

    return EmbeddedDrawing(load_map(ref))


def run_road(
    config: Mapping[str, Any] | None,
    meta: Mapping[str, Any] | None = None,
    metrics: Mapping[str, Any] | None = None,
) -> str:
    """The road a run of a campaign with stored ``config`` was played on.

    esmini backend: its ``road`` option (``--road``), else the road of the run's scenario
    file (``metrics["scenario"]`` picks it in a folder), else, for sitcov's own situations
    without ``--road`` (played on an embedded map's own OpenDRIVE export, in the same
    coordinates), that embedded map (``backend_options.map``, else the default); the
    OpenDRIVE file in the run's trace (``meta["map"]``) when none of these is known.
    Other backends: the trace's map, else the campaign's embedded map.
    """
    from sitcov.campaign._build import DEFAULT_EMBEDDED_MAP

    config = dict(config or {})
    options = config.get("backend_options") or {}
    options = options if isinstance(options, Mapping) else {}
    traced = (meta or {}).get("map")
    if config.get("backend") == "esmini":
        if options.get("road"):
            return str(options["road"])
        scenario, name = options.get("scenario"), (metrics or {}).get("scenario")
        road = _scenario_road(str(scenario) if scenario else None, str(name) if name else None)
        if road is not None:
            return road
        if not scenario:
            return str(options.get("map") or DEFAULT_EMBEDDED_MAP)
    if traced:
        return str(traced)
    return str(options.get("map") or DEFAULT_EMBEDDED_MAP)


@lru_cache(maxsize=64)  # the collision map asks once per collision
def _scenario_road(scenario: Any, name: Any = None) -> str | None:
    """The OpenDRIVE file of an esmini campaign's scenario file, or of file ``name`` (the
    run's ``metrics["scenario"]``) of its folder (None when neither is known, or the file
    names no road)."""
    if not scenario:
        return None
    if Path(str(scenario)).is_dir():
        if not name:
            return None
        scenario = Path(str(scenario)) / f"{name}.xosc"
    if not Path(str(scenario)).is_file():
        return None
    from sitcov.sim.esmini import ScenarioFile

    try:
        road = ScenarioFile(str(scenario)).road_file()
    except ConfigError:
        return None
    return str(road) if road is not None else None
