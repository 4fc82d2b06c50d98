"""Junction maps as data: legs, lanes, turning arcs, the lane graph and conflict points.

A map file (YAML) names the junction's legs by their outward heading; everything else
(lane centre lines, turning paths, routes, conflict points, drawable geometry) is derived
here, so a skewed T or a four-way cross is a new file, not new code. Right-hand traffic:
the inbound lane of a leg lies right of the road axis as seen by a vehicle approaching
the junction. The file format is documented in ``docs/embedded.md``.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from pathlib import Path as FsPath
from typing import Any

import numpy as np
import yaml

from sitcov._geometry import convex_hull
from sitcov.errors import ConfigError
from sitcov.sim.embedded._monitors import DrivableArea, route_clearance
from sitcov.sim.embedded._path import Path, wrap_angle

MAPS_DIR = FsPath(__file__).parent / "maps"
#: Spacing of route points [m].
ROUTE_STEP = 1.0
#: Spacing used to find swept-path overlaps [m].
CONFLICT_STEP = 0.25
#: Sidewalk width when a map file gives none [m] (a common urban footway).
DEFAULT_SIDEWALK_WIDTH = 2.0
#: Cyclists ride this far right of the lane centre when a map file gives none [m]: on a
#: 3.5 m lane the bike (0.6 m wide) keeps 0.25 m to the kerb and clears a car (1.61 m) on
#: the lane centre, as a cyclist keeping right does.
DEFAULT_BIKE_OFFSET = 1.2


@dataclass(frozen=True)
class Leg:
    """One arm of the junction.

    Attributes:
        name: e.g. ``"B"``.
        heading: direction pointing away from the junction centre [rad].
        length: from the centre to the end of the leg [m].
        mouth: from the centre to where the leg's straight lanes meet the junction [m].
        crosswalk: the leg's pedestrian crossing, or None if it has none.
    """

    name: str
    heading: float
    length: float
    mouth: float
    crosswalk: Crosswalk | None = None


@dataclass(frozen=True)
class Crosswalk:
    """A pedestrian crossing across both lanes of a leg.

    Attributes:
        offset: from the leg's mouth outwards to the crossing's near edge [m].
        width: along the leg [m]; pedestrians walk on its centre line.
    """

    offset: float
    width: float


@dataclass(frozen=True)
class Conflict:
    """Where two routes' swept paths (vehicle width) overlap.

    Attributes:
        point: the first overlapping point along the ego's route (x, y) [m].
        s_ego, s_ego_end: arc lengths on the ego route where the overlap starts/ends [m].
        s_ov, s_ov_end: the same on the OV route [m].
    """

    point: tuple[float, float]
    s_ego: float
    s_ego_end: float
    s_ov: float
    s_ov_end: float


@dataclass(frozen=True)
class Scenario:
    """The two routes of an intersection situation, cut to spawn and goal, and their conflict."""

    ego_move: str
    ov_move: str
    ego_route: Path
    ov_route: Path
    conflict: Conflict | None


def _number(data: dict[str, Any], key: str, file: str, where: str, lo: float = -math.inf) -> float:
    value = data.get(key)
    if isinstance(value, bool) or not isinstance(value, int | float) or not value > lo:
        bound = f" > {lo:g}" if lo > -math.inf else ""
        raise ConfigError(
            file=file, field=f"{where}{key}", value=value, expected=f"a number{bound}"
        )
    return float(value)


def _optional(data: dict[str, Any], key: str, default: float, file: str) -> float:
    """An optional positive number: ``default`` when the key is absent."""
    return default if key not in data else _number(data, key, file, "", 0.0)


class JunctionMap:
    """A junction built from a map file's data.

    Args:
        data: the parsed map (see ``docs/embedded.md`` for the format).
        source: file name for error messages.

    Raises:
        ConfigError: naming the file, the field, the value and what was expected.
    """

    #: The map's ``layout`` (subclasses: ``roundabout``, ``merge``).
    LAYOUT = "junction"
    #: Top-level keys every layout accepts; a layout adds its own section (``roundabout``...).
    KEYS = (
        "format",
        "name",
        "description",
        "layout",
        "lane_width",
        "sidewalk_width",
        "bike_offset",
        "legs",
        "spawns",
        "goal_distance",
        "switch_distances",
        "switch_distance_max",
    )

    def __new__(cls, data: Any = None, source: str = "<map>") -> JunctionMap:
        """Pick the class of the file's ``layout`` (so ``JunctionMap(data)`` builds any map)."""
        if cls is JunctionMap and isinstance(data, dict):
            cls = LAYOUTS.get(data.get("layout", "junction"), cls)
        return super().__new__(cls)

    def __init__(self, data: Any, source: str = "<map>") -> None:
        if not isinstance(data, dict):
            raise ConfigError(
                file=source, field="(top level)", value=type(data).__name__, expected="a mapping"
            )
        keys = self.KEYS + ((self.LAYOUT,) if self.LAYOUT != "junction" else ())
        unknown = set(data) - set(keys)
        if unknown:
            raise ConfigError(
                file=source,
                field=sorted(unknown)[0],
                value=None,
                expected="one of " + ", ".join(keys),
            )
        if data.get("format", 1) not in (1, 2):
            raise ConfigError(
                file=source, field="format", value=data.get("format"), expected="1 or 2"
            )
        if data.get("layout", "junction") != self.LAYOUT:
            raise ConfigError(
                file=source,
                field="layout",
                value=data.get("layout"),
                expected=" | ".join(LAYOUTS),
            )
        name = data.get("name")
        if not isinstance(name, str) or not name:
            raise ConfigError(file=source, field="name", value=name, expected="a non-empty string")
        self.name = name
        self.source = source
        self.lane_width = _number(data, "lane_width", source, "", 0.0)
        self.sidewalk_width = _optional(data, "sidewalk_width", DEFAULT_SIDEWALK_WIDTH, source)
        self.bike_offset = _optional(data, "bike_offset", DEFAULT_BIKE_OFFSET, source)
        if not self.bike_offset < 0.5 * self.lane_width:
            raise ConfigError(
                file=source,
                field="bike_offset",
                value=self.bike_offset,
                expected=f"a number in (0, {0.5 * self.lane_width:g}) (half the lane width)",
            )
        self.legs: dict[str, Leg] = self._parse_legs(data.get("legs"))
        self._parse_layout(data.get(self.LAYOUT, {}))
        self.goal_distance = _number(data, "goal_distance", source, "", 0.0)
        for leg_name in self.exit_legs:
            leg = self.legs[leg_name]
            if not leg.mouth < self.goal_distance < leg.length:
                raise ConfigError(
                    file=source,
                    field="goal_distance",
                    value=self.goal_distance,
                    expected=f"between leg {leg.name}'s mouth and length",
                )
        self.spawns = self._parse_spawns(data.get("spawns"))
        self._lanes = self._build_lanes()
        self.graph: dict[str, tuple[str, ...]] = self._build_graph()
        self.switch_distances = self._switch_distances(data.get("switch_distances", {}))
        self.switch_distance_max = _optional(data, "switch_distance_max", math.inf, source)

    def _parse_legs(self, legs: Any) -> dict[str, Leg]:
        source = self.source
        if not isinstance(legs, dict) or len(legs) < 2:
            raise ConfigError(
                file=source, field="legs", value=legs, expected="a mapping of at least two legs"
            )
        out: dict[str, Leg] = {}
        for leg_name, leg in legs.items():
            where = f"legs.{leg_name}."
            if not isinstance(leg, dict) or set(leg) - {
                "heading_deg",
                "length",
                "mouth",
                "crosswalk",
            }:
                raise ConfigError(
                    file=source,
                    field=f"legs.{leg_name}",
                    value=leg,
                    expected="a mapping with heading_deg, length, mouth (optional crosswalk)",
                )
            heading = _number(leg, "heading_deg", source, where)
            mouth = _number(leg, "mouth", source, where, self.lane_width)
            length = _number(leg, "length", source, where, mouth + 10.0)
            crosswalk = None
            if "crosswalk" in leg:
                cw = leg["crosswalk"]
                if not isinstance(cw, dict) or set(cw) != {"offset", "width"}:
                    raise ConfigError(
                        file=source,
                        field=f"{where}crosswalk",
                        value=cw,
                        expected="a mapping {offset: m outside the mouth, width: m}",
                    )
                crosswalk = Crosswalk(
                    _number(cw, "offset", source, f"{where}crosswalk.", -1e-9),
                    _number(cw, "width", source, f"{where}crosswalk.", 0.0),
                )
                if mouth + crosswalk.offset + crosswalk.width > length - 10.0:
                    raise ConfigError(
                        file=source,
                        field=f"{where}crosswalk",
                        value=cw,
                        expected="a crossing ending at least 10 m before the leg's end "
                        f"({length:g} m)",
                    )
            out[str(leg_name)] = Leg(str(leg_name), math.radians(heading), length, mouth, crosswalk)
        return out

    def _parse_layout(self, section: Any) -> None:
        """Read the layout's own section (none for a junction); sets entry and exit legs."""
        self.entry_legs: tuple[str, ...] = tuple(self.legs)
        self.exit_legs: tuple[str, ...] = tuple(self.legs)

    def _parse_spawns(self, spawns: Any) -> dict[str, dict[str, float]]:
        source = self.source
        if not isinstance(spawns, dict) or set(spawns) != {"ego", "ov"}:
            raise ConfigError(
                file=source, field="spawns", value=spawns, expected="a mapping with keys ego and ov"
            )
        out: dict[str, dict[str, float]] = {}
        for role, table in spawns.items():
            if not isinstance(table, dict) or set(table) != set(self.entry_legs):
                raise ConfigError(
                    file=source,
                    field=f"spawns.{role}",
                    value=table,
                    expected=f"a distance for each entry leg {sorted(self.entry_legs)}",
                )
            out[role] = {}
            for leg_name in table:
                dist = _number(table, leg_name, source, f"spawns.{role}.", 0.0)
                leg = self.legs[str(leg_name)]
                if not leg.mouth < dist < leg.length:
                    raise ConfigError(
                        file=source,
                        field=f"spawns.{role}.{leg_name}",
                        value=dist,
                        expected=f"a distance between {leg.mouth:g} and {leg.length:g} m",
                    )
                out[role][str(leg_name)] = dist
        return out

    def _switch_distances(self, table: Any) -> dict[str, float]:
        """Validate ``switch_distances``: ``"EGO/OV"`` (movements of this map) -> metres."""
        if not isinstance(table, dict):
            raise ConfigError(
                file=self.source,
                field="switch_distances",
                value=table,
                expected='a mapping "EGO/OV" (e.g. "L-B/R-B") -> distance [m]',
            )
        out: dict[str, float] = {}
        for key in table:
            moves = str(key).split("/")
            if len(moves) != 2 or any(m not in self.movements for m in moves):
                raise ConfigError(
                    file=self.source,
                    field=f"switch_distances.{key}",
                    value=key,
                    expected=f'"EGO/OV" movements of this map {list(self.movements)}',
                )
            out[str(key)] = _number(table, key, self.source, "switch_distances.", 0.0)
        return out

    # --- construction ---------------------------------------------------------------------

    def _axis(self, leg: Leg) -> tuple[float, float, float, float]:
        """Unit vector along the leg (outwards) and its left normal."""
        dx, dy = math.cos(leg.heading), math.sin(leg.heading)
        return dx, dy, -dy, dx

    def _build_lanes(self) -> dict[str, Path]:
        half = self.lane_width / 2.0
        lanes: dict[str, Path] = {}
        for leg in self.legs.values():
            dx, dy, nx, ny = self._axis(leg)
            # inbound: towards the centre, right-hand traffic -> on the +normal side
            far_in = (dx * leg.length + nx * half, dy * leg.length + ny * half)
            near_in = (dx * leg.mouth + nx * half, dy * leg.mouth + ny * half)
            lanes[f"{leg.name}.in"] = _straight(far_in, near_in)
            near_out = (dx * leg.mouth - nx * half, dy * leg.mouth - ny * half)
            far_out = (dx * leg.length - nx * half, dy * leg.length - ny * half)
            lanes[f"{leg.name}.out"] = _straight(near_out, far_out)
        for a in self.legs.values():
            for b in self.legs.values():
                if a.name != b.name:
                    start = lanes[f"{a.name}.in"]
                    end = lanes[f"{b.name}.out"]
                    lanes[f"{a.name}-{b.name}"] = _connector(
                        (start.xs[-1], start.ys[-1]),
                        a.heading + math.pi,
                        (end.xs[0], end.ys[0]),
                        b.heading,
                    )
        return lanes

    def _build_graph(self) -> dict[str, tuple[str, ...]]:
        graph: dict[str, list[str]] = {lane: [] for lane in self._lanes}
        for a in self.legs:
            for b in self.legs:
                if a != b:
                    graph[f"{a}.in"].append(f"{a}-{b}")
                    graph[f"{a}-{b}"].append(f"{b}.out")
        return {k: tuple(v) for k, v in graph.items()}

    # --- queries --------------------------------------------------------------------------

    @functools.cached_property
    def movements(self) -> tuple[str, ...]:
        """Every movement ``"X-Y"`` (from entry leg X to exit leg Y, X != Y)."""
        return tuple(f"{a}-{b}" for a in self.entry_legs for b in self.exit_legs if a != b)

    def lane(self, lane_id: str) -> Path:
        """A lane's centre line: ``"B.in"``, ``"B.out"`` or a connector ``"B-L"``."""
        return self._lanes[lane_id]

    def _parse_move(self, move: str) -> tuple[str, str]:
        if move not in self.movements:
            raise ConfigError(
                field="movement",
                value=move,
                expected=f"a movement of {self.name}: {list(self.movements)}",
            )
        a, _, b = str(move).partition("-")
        return a, b

    def lane_sequence(self, from_leg: str, to_leg: str) -> list[str]:
        """Lanes from ``from_leg``'s inbound lane to ``to_leg``'s outbound lane (graph search)."""
        self._parse_move(f"{from_leg}-{to_leg}")
        start, goal = f"{from_leg}.in", f"{to_leg}.out"
        frontier, parent = [start], {start: ""}
        while frontier:
            node = frontier.pop(0)
            if node == goal:
                seq = [node]
                while parent[seq[-1]]:
                    seq.append(parent[seq[-1]])
                return seq[::-1]
            for nxt in self.graph[node]:
                if nxt not in parent:
                    parent[nxt] = node
                    frontier.append(nxt)
        raise ConfigError(
            field="movement", value=f"{from_leg}-{to_leg}", expected="a connected route"
        )

    @functools.lru_cache(maxsize=64)  # noqa: B019 - maps live for the process
    def route(self, from_leg: str, to_leg: str) -> Path:
        """The lane path from the end of ``from_leg`` to the end of ``to_leg``, ~1 m spacing."""
        points: list[tuple[float, float]] = []
        for lane_id in self.lane_sequence(from_leg, to_leg):
            points.extend(self._lanes[lane_id].points)
        full = Path.from_points(points)
        return full.sub(0.0, full.length, ROUTE_STEP)

    def _s_at_distance(self, path: Path, leg: Leg, distance: float, inbound: bool) -> float:
        """Arc length on ``path`` where it is ``distance`` from the centre along ``leg``."""
        if inbound:
            return leg.length - distance
        return path.length - (leg.length - distance)

    @functools.lru_cache(maxsize=256)  # noqa: B019
    def scenario(
        self, ego_move: str, ov_move: str, width_ego: float = 1.61, width_ov: float = 1.61
    ) -> Scenario:
        """Ego route (spawn -> goal), OV route (spawn -> end of its exit leg) and their conflict."""
        ego_route, ov_route = self.ego_path(ego_move), self.ov_path(ov_move)
        conflict = route_conflict(ego_route, ov_route, 0.5 * (width_ego + width_ov))
        return Scenario(ego_move, ov_move, ego_route, ov_route, conflict)

    @functools.lru_cache(maxsize=64)  # noqa: B019
    def ego_path(self, move: str) -> Path:
        """The ego's route for ``move``: from its spawn to its goal."""
        a, b = self._parse_move(move)
        full = self.route(a, b)
        s0 = self._s_at_distance(full, self.legs[a], self.spawns["ego"][a], True)
        s1 = self._s_at_distance(full, self.legs[b], self.goal_distance, False)
        return full.sub(s0, s1, ROUTE_STEP)

    @functools.lru_cache(maxsize=64)  # noqa: B019
    def ov_path(self, move: str) -> Path:
        """The OV's route for ``move``: from its spawn to the end of its exit leg."""
        a, b = self._parse_move(move)
        full = self.route(a, b)
        s0 = self._s_at_distance(full, self.legs[a], self.spawns["ov"][a], True)
        return full.sub(s0, full.length, ROUTE_STEP)

    def switch_distance(self, scenario: Scenario, *, table: bool = True) -> float | None:
        """Ego's distance to the conflict point [m] at which the OV stops synchronising.

        The map's ``switch_distances`` entry for the situation if it has one (the shipped
        maps list the paper's twelve situations, derived from its Town03 trigger boxes);
        otherwise the ego's remaining distance when it crosses the mouth of its start leg,
        where the paper's boxes sit (just inside the junction entrance), at most the map's
        ``switch_distance_max`` (a roundabout's conflicts lie far round the ring). None
        without a conflict. ``table=False`` skips the ``switch_distances`` entries: they
        were measured for the paper's car-car situations, not for a cyclist or pedestrian
        on the same movements.
        """
        key = f"{scenario.ego_move}/{scenario.ov_move}"
        if table and key in self.switch_distances:
            return self.switch_distances[key]
        if scenario.conflict is None:
            return None
        leg = self._parse_move(scenario.ego_move)[0]
        s_mouth = self.spawns["ego"][leg] - self.legs[leg].mouth
        return min(max(scenario.conflict.s_ego - s_mouth, 0.0), self.switch_distance_max)

    def render_geometry(self) -> dict[str, Any]:
        """Drawable geometry for renderers [m]: ``road_polygons`` (convex, the drivable
        area), ``markings``, ``kerbs``, and the pedestrian surfaces ``crosswalks`` and
        ``sidewalks`` (convex polygons, not drivable)."""
        geo = self._legs_geometry()
        mouth_corners = geo.pop("mouth_corners")
        hull = convex_hull([(round(x, 9), round(y, 9)) for x, y in mouth_corners])
        geo["road_polygons"].append(hull)
        # kerbs of the junction box: hull edges that are not a leg mouth
        mouths = {
            frozenset((a, b)) for a, b in zip(mouth_corners[::2], mouth_corners[1::2], strict=False)
        }
        for a, b in zip(hull, hull[1:] + hull[:1], strict=False):
            if frozenset((a, b)) not in mouths:
                geo["kerbs"].append([a, b])
        return geo

    def _legs_geometry(self) -> dict[str, Any]:
        """Every two-way leg's surface (mouth to end), markings, kerbs, crossing, sidewalks."""
        half = self.lane_width
        geo: dict[str, Any] = {
            "road_polygons": [],
            "markings": [],
            "kerbs": [],
            "crosswalks": [],
            "sidewalks": [],
            "mouth_corners": [],
        }
        for leg in self.legs.values():
            dx, dy, nx, ny = self._axis(leg)

            def at(along: float, side: float, dx=dx, dy=dy, nx=nx, ny=ny) -> tuple[float, float]:
                return (dx * along + nx * side, dy * along + ny * side)

            def box(a0: float, a1: float, b0: float, b1: float) -> list[tuple[float, float]]:
                return [at(a0, b0), at(a1, b0), at(a1, b1), at(a0, b1)]

            geo["road_polygons"].append(box(leg.mouth, leg.length, -half, half))
            geo["mouth_corners"] += [at(leg.mouth, -half), at(leg.mouth, half)]
            geo["markings"].append(
                {
                    "points": [at(leg.mouth, 0.0), at(leg.length, 0.0)],
                    "style": "dashed",
                    "color": "white",
                }
            )
            geo["markings"].append(
                {
                    "points": [at(leg.mouth, 0.0), at(leg.mouth, half)],
                    "style": "solid",
                    "color": "white",
                }
            )
            geo["kerbs"].append([at(leg.mouth, half), at(leg.length, half)])
            geo["kerbs"].append([at(leg.mouth, -half), at(leg.length, -half)])
            walk = self.sidewalk_width
            geo["sidewalks"].append(box(leg.mouth, leg.length, half, half + walk))
            geo["sidewalks"].append(box(leg.mouth, leg.length, -half - walk, -half))
            if leg.crosswalk is not None:
                a0 = leg.mouth + leg.crosswalk.offset
                geo["crosswalks"].append(box(a0, a0 + leg.crosswalk.width, -half, half))
        for key in ("crosswalks", "sidewalks"):
            geo[key] = [_ccw(p) for p in geo[key]]
        return geo

    @functools.cached_property
    def drivable_area(self) -> DrivableArea:
        """The road surface: every leg's two lanes plus the junction area (the convex hull
        of the leg mouths), derived from the legs as the drawn road polygons are."""
        return DrivableArea(self.render_geometry()["road_polygons"])

    @functools.lru_cache(maxsize=64)  # noqa: B019 - maps live for the process
    def clearance(self, route: Path) -> tuple[list[float], list[float]]:
        """Left and right extent of the drivable area around each point of ``route`` [m]
        (see ``sitcov.sim.embedded._monitors.route_clearance``)."""
        return route_clearance(self.drivable_area, route)


#: ``layout`` name -> map class. ``_layouts`` registers the roundabout and the merge when
#: the package is imported (``sitcov/sim/embedded/__init__.py``), so this module needs
#: not import the subclasses built on it.
LAYOUTS: dict[str, type[JunctionMap]] = {"junction": JunctionMap}


def _straight(a: tuple[float, float], b: tuple[float, float]) -> Path:
    n = max(1, math.ceil(math.dist(a, b) / ROUTE_STEP))
    return Path.from_points(
        [(a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n) for k in range(n + 1)]
    )


def _connector(p0: tuple[float, float], h0: float, p1: tuple[float, float], h1: float) -> Path:
    """Straight - circular arc - straight from pose (p0, h0) to (p1, h1), tangent at both ends."""
    turn = wrap_angle(h1 - h0)
    if abs(turn) < 1e-3:
        return _straight(p0, p1)
    u0 = (math.cos(h0), math.sin(h0))
    u1 = (math.cos(h1), math.sin(h1))
    # p0 + a*u0 = p1 - b*u1  (the tangent lines meet at a corner)
    det = u0[0] * u1[1] - u0[1] * u1[0]
    rx, ry = p1[0] - p0[0], p1[1] - p0[1]
    a = (rx * u1[1] - ry * u1[0]) / det
    b = (u0[0] * ry - u0[1] * rx) / det
    if a <= 0 or b <= 0:
        return _straight(p0, p1)
    t = min(a, b)
    radius = t / math.tan(abs(turn) / 2.0)
    start = (p0[0] + (a - t) * u0[0], p0[1] + (a - t) * u0[1])
    side = 1.0 if turn > 0 else -1.0
    cx, cy = start[0] - side * u0[1] * radius, start[1] + side * u0[0] * radius
    phi0 = math.atan2(start[1] - cy, start[0] - cx)
    n = max(4, math.ceil(abs(turn) * radius / (0.5 * ROUTE_STEP)))
    arc = [
        (cx + radius * math.cos(phi0 + turn * k / n), cy + radius * math.sin(phi0 + turn * k / n))
        for k in range(n + 1)
    ]
    end = arc[-1]
    points = [p0] if a - t > 1e-6 else []
    points += arc
    if math.dist(end, p1) > 1e-6:
        points += _straight(end, p1).points[1:]
    return Path.from_points(points)


def _ccw(polygon: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """``polygon`` in counter-clockwise order (shoelace sign)."""
    area = sum(
        a[0] * b[1] - b[0] * a[1] for a, b in zip(polygon, polygon[1:] + polygon[:1], strict=True)
    )
    return polygon if area >= 0 else polygon[::-1]


def overlap_matrix(
    e: np.ndarray, o: np.ndarray, gap: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Distances between the points of two sampled paths that can be closer than ``gap``.

    Only points inside the other path's bounding box widened by ``gap`` are compared (the
    rest cannot be close), which keeps long routes cheap. Returns (distances, close, ego
    indices, other indices): the matrices are over the kept points only.
    """

    def inside(p: np.ndarray, q: np.ndarray) -> np.ndarray:
        lo, hi = q.min(axis=0) - gap, q.max(axis=0) + gap
        return np.flatnonzero(((p >= lo) & (p <= hi)).all(axis=1))

    ie, io = inside(e, o), inside(o, e)
    es, os_ = e[ie], o[io]
    d = np.hypot(es[:, None, 0] - os_[None, :, 0], es[:, None, 1] - os_[None, :, 1])
    return d, d < gap, ie, io


def find_conflict(ego: Path, ov: Path, gap: float) -> Conflict | None:
    """First overlap of two swept paths: centre lines closer than ``gap`` [m].

    ``gap`` is the sum of the two half-widths. Returns None if the paths never come that
    close (the vehicles cannot meet when both follow their lanes).
    """
    e = np.asarray(ego.resampled(CONFLICT_STEP))
    o = np.asarray(ov.resampled(CONFLICT_STEP))
    _, close, ie, io = overlap_matrix(e, o, gap)
    rows = np.flatnonzero(close.any(axis=1))
    if rows.size == 0:
        return None
    # the first overlapping stretch along the ego's route, and the OV points close to it
    # (routes that meet twice, as on a roundabout, pair the same encounter on both)
    first = last = int(rows[0])
    while last + 1 < len(ie) and ie[last + 1] == ie[last] + 1 and close[last + 1].any():
        last += 1
    ov_hit = io[close[first : last + 1].any(axis=0)]
    se, so = ego.length / (len(e) - 1), ov.length / (len(o) - 1)
    i = int(ie[first])
    return Conflict(
        point=(float(e[i, 0]), float(e[i, 1])),
        s_ego=i * se,
        s_ego_end=float(ie[last]) * se,
        s_ov=float(ov_hit[0]) * so,
        s_ov_end=float(ov_hit[-1]) * so,
    )


def route_conflict(ego: Path, ov: Path, gap: float) -> Conflict | None:
    """The conflict the adversary times its arrival at: :func:`find_conflict`, except when
    one route starts inside the other's swept path (both on the same lane: a following or
    diverging pair). There the first overlap is the OV's own spawn point, where nothing can
    be timed; the conflict is instead where the ego leaves the shared stretch (where the
    routes split, or the ego's goal if they never do), so an OV that arrives there with
    the ego is one the ego runs into from behind.
    """
    conflict = find_conflict(ego, ov, gap)
    if conflict is None or (conflict.s_ov > CONFLICT_STEP and conflict.s_ego > CONFLICT_STEP):
        return conflict
    e = np.asarray(ego.resampled(CONFLICT_STEP))
    o = np.asarray(ov.resampled(CONFLICT_STEP))
    d, close, ie, io = overlap_matrix(e, o, gap)
    rows = np.flatnonzero(close.any(axis=1))
    last = int(rows[0])
    while last + 1 < len(ie) and ie[last + 1] == ie[last] + 1 and close[last + 1].any():
        last += 1
    j = int(io[np.argmin(np.where(close[last], d[last], np.inf))])
    i = int(ie[last])
    s_e, s_o = i * ego.length / (len(e) - 1), j * ov.length / (len(o) - 1)
    return Conflict(
        point=(float(e[i, 0]), float(e[i, 1])), s_ego=s_e, s_ego_end=s_e, s_ov=s_o, s_ov_end=s_o
    )


@functools.lru_cache(maxsize=16)
def load_map(source: str = "t-junction") -> JunctionMap:
    """Load a built-in map by name (``"t-junction"``, ``"cross"``, ...), a YAML file path,
    or an OpenDRIVE file: ``FILE.xodr`` (its only junction) or ``FILE.xodr#ID`` (junction
    ``ID``), imported on the fly (``sitcov.roads``, ``docs/roads.md``).

    Raises:
        ConfigError: unknown name, unreadable file or invalid content.
    """
    if ".xodr" in str(source).lower():
        return JunctionMap(*_xodr_map_data(str(source)))
    path = FsPath(source)
    if not path.suffix:
        path = MAPS_DIR / f"{source}.yaml"
        if not path.exists():
            known = sorted(p.stem for p in MAPS_DIR.glob("*.yaml"))
            raise ConfigError(field="map", value=source, expected=f"one of {known} or a YAML file")
    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except OSError as exc:
        raise ConfigError(
            file=str(path), field="map", value=None, expected=f"a readable file ({exc.strerror})"
        ) from None
    except (yaml.YAMLError, ValueError, RecursionError) as exc:  # bad UTF-8, deep nesting
        raise ConfigError(f"{path}: not valid YAML: {' '.join(str(exc).split())}") from None
    return JunctionMap(data, source=str(path))


def _xodr_map_data(source: str) -> tuple[dict[str, Any], str]:
    """The map data of ``FILE.xodr[#JUNCTION]`` and the source name for messages."""
    from sitcov.roads import junction_map_data, list_junctions, read_opendrive

    file, _, junction = source.partition("#")
    net = read_opendrive(file)
    if not junction:
        ids = [row["id"] for row in list_junctions(net)]
        if len(ids) != 1:
            raise ConfigError(
                file=file,
                field="junction",
                value=None,
                expected=f"FILE.xodr#ID naming one of its {len(ids)} junctions "
                f"({', '.join(ids[:20])}{', ...' if len(ids) > 20 else ''}; "
                "`sitcov map import FILE --list` lists them)",
            )
        junction = ids[0]
    return junction_map_data(net, junction), f"{file}#{junction}"
