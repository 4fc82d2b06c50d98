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

from sitcov.errors import ConfigError
from sitcov.sim.embedded._monitors import DrivableArea, route_clearance
from sitcov.sim.embedded._path import Path, wrap_angle

MAPS_DIR = FsPath(__file__).parent / "maps"
#: Spacing of route points [m].
ROUTE_STEP = 1.0
#: Spacing used to find swept-path overlaps [m].
CONFLICT_STEP = 0.25


@dataclass(frozen=True)
class Leg:
    """One arm of the junction.

    Attributes:
        name: e.g. ``"B"``.
        heading: direction pointing away from the junction centre [rad].
        length: from the centre to the end of the leg [m].
        mouth: from the centre to where the leg's straight lanes meet the junction [m].
    """

    name: str
    heading: float
    length: float
    mouth: float


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


class JunctionMap:
    """A junction built from a map file's data.

    Args:
        data: the parsed map (see ``docs/embedded.md`` for the format).
        source: file name for error messages.

    Raises:
        ConfigError: naming the file, the field, the value and what was expected.
    """

    def __init__(self, data: Any, source: str = "<map>") -> None:
        if not isinstance(data, dict):
            raise ConfigError(
                file=source, field="(top level)", value=type(data).__name__, expected="a mapping"
            )
        unknown = set(data) - {
            "format",
            "name",
            "description",
            "lane_width",
            "legs",
            "spawns",
            "goal_distance",
            "switch_distances",
        }
        if unknown:
            raise ConfigError(
                file=source,
                field=sorted(unknown)[0],
                value=None,
                expected="one of format, name, description, lane_width, legs, "
                "spawns, goal_distance, switch_distances",
            )
        if data.get("format", 1) != 1:
            raise ConfigError(file=source, field="format", value=data.get("format"), expected="1")
        name = data.get("name")
        if not isinstance(name, str) or not name:
            raise ConfigError(file=source, field="name", value=name, expected="a non-empty string")
        self.name = name
        self.source = source
        self.lane_width = _number(data, "lane_width", source, "", 0.0)
        legs = data.get("legs")
        if not isinstance(legs, dict) or len(legs) < 2:
            raise ConfigError(
                file=source, field="legs", value=legs, expected="a mapping of at least two legs"
            )
        self.legs: dict[str, Leg] = {}
        for leg_name, leg in legs.items():
            where = f"legs.{leg_name}."
            if not isinstance(leg, dict):
                raise ConfigError(
                    file=source,
                    field=f"legs.{leg_name}",
                    value=leg,
                    expected="a mapping with heading_deg, length, mouth",
                )
            heading = _number(leg, "heading_deg", source, where)
            mouth = _number(leg, "mouth", source, where, self.lane_width)
            length = _number(leg, "length", source, where, mouth + 10.0)
            self.legs[str(leg_name)] = Leg(str(leg_name), math.radians(heading), length, mouth)
        self.goal_distance = _number(data, "goal_distance", source, "", 0.0)
        for leg in self.legs.values():
            if not leg.mouth < self.goal_distance < leg.length:
                raise ConfigError(
                    file=source,
                    field="goal_distance",
                    value=self.goal_distance,
                    expected=f"between leg {leg.name}'s mouth and length",
                )
        spawns = data.get("spawns")
        if not isinstance(spawns, dict) or set(spawns) != {"ego", "ov"}:
            raise ConfigError(
                file=source, field="spawns", value=spawns, expected="a mapping with keys ego and ov"
            )
        self.spawns: dict[str, dict[str, float]] = {}
        for role, table in spawns.items():
            if not isinstance(table, dict) or set(table) != set(self.legs):
                raise ConfigError(
                    file=source,
                    field=f"spawns.{role}",
                    value=table,
                    expected=f"a distance for each leg {sorted(self.legs)}",
                )
            self.spawns[role] = {}
            for leg_name, _ in table.items():
                dist = _number(table, leg_name, source, f"spawns.{role}.", 0.0)
                leg = self.legs[str(leg_name)]
                if not leg.mouth < dist < leg.length:
                    raise ConfigError(
                        file=source,
                        field=f"spawns.{role}.{leg_name}",
                        value=dist,
                        expected=f"a distance between {leg.mouth:g} and {leg.length:g} m",
                    )
                self.spawns[role][str(leg_name)] = dist
        self._lanes = self._build_lanes()
        self.graph: dict[str, tuple[str, ...]] = self._build_graph()
        self.switch_distances = self._switch_distances(data.get("switch_distances", {}))

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
            moves = [m.partition("-") for m in str(key).split("/")]
            if len(moves) != 2 or any(
                not sep or a not in self.legs or b not in self.legs or a == b for a, sep, b in moves
            ):
                raise ConfigError(
                    file=self.source,
                    field=f"switch_distances.{key}",
                    value=key,
                    expected=f'"EGO/OV" movements "X-Y" of legs {sorted(self.legs)}',
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

    @property
    def movements(self) -> tuple[str, ...]:
        """Every movement ``"X-Y"`` (from leg X to leg Y)."""
        return tuple(f"{a}-{b}" for a in self.legs for b in self.legs if a != b)

    def lane(self, lane_id: str) -> Path:
        """A lane's centre line: ``"B.in"``, ``"B.out"`` or a connector ``"B-L"``."""
        return self._lanes[lane_id]

    def _parse_move(self, move: str) -> tuple[str, str]:
        a, sep, b = str(move).partition("-")
        if not sep or a not in self.legs or b not in self.legs or a == b:
            raise ConfigError(
                field="movement",
                value=move,
                expected=f"'X-Y' with X != Y legs of {sorted(self.legs)}",
            )
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
        ea, eb = self._parse_move(ego_move)
        oa, ob = self._parse_move(ov_move)
        ego_full, ov_full = self.route(ea, eb), self.route(oa, ob)
        e0 = self._s_at_distance(ego_full, self.legs[ea], self.spawns["ego"][ea], True)
        e1 = self._s_at_distance(ego_full, self.legs[eb], self.goal_distance, False)
        o0 = self._s_at_distance(ov_full, self.legs[oa], self.spawns["ov"][oa], True)
        ego_route = ego_full.sub(e0, e1, ROUTE_STEP)
        ov_route = ov_full.sub(o0, ov_full.length, ROUTE_STEP)
        conflict = find_conflict(ego_route, ov_route, 0.5 * (width_ego + width_ov))
        return Scenario(ego_move, ov_move, ego_route, ov_route, conflict)

    def switch_distance(self, scenario: Scenario) -> float | None:
        """Ego's distance to the conflict point [m] at which the OV stops synchronising.

        The map's ``switch_distances`` entry for the situation if it has one (the shipped
        maps list the paper's twelve situations, derived from its Town03 trigger boxes);
        otherwise the ego's remaining distance when it crosses the mouth of its start leg,
        where the paper's boxes sit (just inside the junction entrance). None without a
        conflict.
        """
        key = f"{scenario.ego_move}/{scenario.ov_move}"
        if key in self.switch_distances:
            return self.switch_distances[key]
        if scenario.conflict is None:
            return None
        leg = self._parse_move(scenario.ego_move)[0]
        s_mouth = self.spawns["ego"][leg] - self.legs[leg].mouth
        return max(scenario.conflict.s_ego - s_mouth, 0.0)

    def render_geometry(self) -> dict[str, Any]:
        """Drawable geometry for renderers: road polygons, lane markings and kerbs [m]."""
        half = self.lane_width
        polygons: list[list[tuple[float, float]]] = []
        mouth_corners: list[tuple[float, float]] = []
        markings: list[dict[str, Any]] = []
        kerbs: list[list[tuple[float, float]]] = []
        for leg in self.legs.values():
            dx, dy, nx, ny = self._axis(leg)

            def at(along: float, side: float, dx=dx, dy=dy, nx=nx, ny=ny) -> tuple[float, float]:
                return (dx * along + nx * side, dy * along + ny * side)

            polygons.append(
                [
                    at(leg.mouth, -half),
                    at(leg.length, -half),
                    at(leg.length, half),
                    at(leg.mouth, half),
                ]
            )
            mouth_corners += [at(leg.mouth, -half), at(leg.mouth, half)]
            markings.append(
                {
                    "points": [at(leg.mouth, 0.0), at(leg.length, 0.0)],
                    "style": "dashed",
                    "color": "white",
                }
            )
            markings.append(
                {
                    "points": [at(leg.mouth, 0.0), at(leg.mouth, half)],
                    "style": "solid",
                    "color": "white",
                }
            )
            kerbs.append([at(leg.mouth, half), at(leg.length, half)])
            kerbs.append([at(leg.mouth, -half), at(leg.length, -half)])
        hull = _convex_hull(mouth_corners)
        polygons.append(hull)
        # kerbs of the junction box: hull edges that are not a leg mouth
        mouths = {
            frozenset((a, b)) for a, b in zip(mouth_corners[::2], mouth_corners[1::2], strict=False)
        }
        for a, b in zip(hull, hull[1:] + hull[:1], strict=False):
            if frozenset((a, b)) not in mouths:
                kerbs.append([a, b])
        return {"road_polygons": polygons, "markings": markings, "kerbs": kerbs}

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


def _convex_hull(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Counter-clockwise convex hull (monotone chain)."""
    pts = sorted(set((round(x, 9), round(y, 9)) for x, y in points))

    def cross(o, a, b) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    upper: list[tuple[float, float]] = []
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return lower[:-1] + upper[:-1]


def find_conflict(ego: Path, ov: Path, gap: float) -> Conflict | None:
    """First overlap of two swept paths: centre lines closer than ``gap`` [m].

    ``gap`` is the sum of the two half-widths. Returns None if the paths never come that
    close (the vehicles cannot meet when both follow their lanes).
    """
    e = np.asarray(ego.resampled(CONFLICT_STEP))
    o = np.asarray(ov.resampled(CONFLICT_STEP))
    d = np.hypot(e[:, None, 0] - o[None, :, 0], e[:, None, 1] - o[None, :, 1])
    close = d < gap
    ego_hit = np.flatnonzero(close.any(axis=1))
    ov_hit = np.flatnonzero(close.any(axis=0))
    if ego_hit.size == 0:
        return None
    se, so = ego.length / (len(e) - 1), ov.length / (len(o) - 1)
    i = int(ego_hit[0])
    return Conflict(
        point=(float(e[i, 0]), float(e[i, 1])),
        s_ego=i * se,
        s_ego_end=float(ego_hit[-1]) * se,
        s_ov=float(ov_hit[0]) * so,
        s_ov_end=float(ov_hit[-1]) * so,
    )


@functools.lru_cache(maxsize=16)
def load_map(source: str = "t-junction") -> JunctionMap:
    """Load a built-in map by name (``"t-junction"``, ``"cross"``, ...) or a YAML file path.

    Raises:
        ConfigError: unknown name, unreadable file or invalid content.
    """
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
