"""Routes per kind of road user: what path a car, cyclist or pedestrian follows on a map.

Cars (and trucks) drive a movement ``"X-Y"`` on the lane centre line. Cyclists ride the same
movement ``bike_offset`` metres right of the lane centre (the map's data). Pedestrians walk a
crosswalk: ``"X<leg><side>"``, e.g. ``"XBL"`` = the crossing on leg B, starting from the kerb
on the left as seen facing the junction from that leg, ``"XBR"`` the other direction. A
pedestrian's path runs on the crosswalk's centre line from the outer edge of one sidewalk
to the outer edge of the other: it crosses the sidewalk (``sidewalk_width``, the approach
before the kerb), both lanes and the far sidewalk, so a pedestrian controller has room to
approach and stop at the kerb (:func:`kerb_positions`).
"""

from __future__ import annotations

import functools
import math

from sitcov.errors import ConfigError
from sitcov.sim.embedded._map import ROUTE_STEP, JunctionMap, Leg
from sitcov.sim.embedded._path import Path, wrap_angle

#: Kinds of road user and the kind whose routes they take.
KINDS = ("car", "truck", "cyclist", "pedestrian")


def route_names(map: JunctionMap, kind: str) -> tuple[str, ...]:  # noqa: A002
    """Every route name an actor of ``kind`` can take on ``map``, in a fixed order.

    Movements for cars, trucks and cyclists; ``X<leg>L``/``X<leg>R`` for pedestrians on
    every leg that has a crosswalk (none on a map without crosswalks).
    """
    _check_kind(kind)
    if kind == "pedestrian":
        return tuple(
            f"X{leg.name}{side}" for leg in map.legs.values() if leg.crosswalk for side in "LR"
        )
    return map.movements


@functools.lru_cache(maxsize=512)
def actor_route(map: JunctionMap, kind: str, route: str) -> Path:  # noqa: A002
    """The path an actor of ``kind`` follows for ``route`` on ``map`` (whole route; cached:
    maps live for the process and paths are immutable).

    Raises:
        ConfigError: unknown kind, or a route name this map does not have for the kind.
    """
    _check_kind(kind)
    if route not in route_names(map, kind):
        raise ConfigError(
            field=f"route ({kind})",
            value=route,
            expected=f"one of {list(route_names(map, kind))} on map {map.name}",
        )
    if kind == "pedestrian":
        if hasattr(map, "crosswalk_route"):  # a map with crosswalk polygons (layout: lanes)
            return map.crosswalk_route(route[1:-1], route[-1])[0]
        return _crosswalk_path(map, map.legs[route[1:-1]], route[-1])
    path = map.route(*route.split("-", 1))
    if kind == "cyclist":
        return offset_path(path, -map.bike_offset)
    return path


def kerb_positions(map: JunctionMap, route: str) -> tuple[float, float]:  # noqa: A002
    """Arc lengths [m] on a pedestrian route where it steps onto and off the road."""
    actor_route(map, "pedestrian", route)  # validates the name
    if hasattr(map, "crosswalk_route"):
        _, on, off = map.crosswalk_route(route[1:-1], route[-1])
        return on, off
    return map.sidewalk_width, map.sidewalk_width + 2.0 * map.lane_width


def start_key(kind: str, route: str) -> tuple[str, str]:
    """Where an actor starts: two actors with the same key would spawn on each other.

    Vehicles and cyclists start on their entry leg's lane, pedestrians at their kerb.
    """
    _check_kind(kind)
    if kind == "pedestrian":
        return kind, route
    return ("car" if kind == "truck" else kind), route.split("-", 1)[0]


def offset_path(path: Path, offset: float) -> Path:
    """``path`` moved sideways by ``offset`` [m] (positive to the left), parallel at corners.

    Each point moves along the bisector of its two segments' normals, scaled so that both
    segments end up exactly ``offset`` away (a parallel curve of the polyline).
    """
    points = []
    n = len(path.xs)
    for i in range(n):
        h_in = path.hs[i - 1] if i > 0 else path.hs[0]
        h_out = path.hs[i] if i < n - 1 else path.hs[-1]
        half = 0.5 * wrap_angle(h_out - h_in)
        h = h_in + half
        scale = offset / max(math.cos(half), 0.2)
        points.append((path.xs[i] - scale * math.sin(h), path.ys[i] + scale * math.cos(h)))
    return Path.from_points(points)


def _crosswalk_path(map: JunctionMap, leg: Leg, side: str) -> Path:  # noqa: A002
    """Across the near sidewalk, both lanes and the far sidewalk on the crosswalk's centre
    line, points :data:`ROUTE_STEP` apart."""
    assert leg.crosswalk is not None
    along = leg.mouth + leg.crosswalk.offset + 0.5 * leg.crosswalk.width
    reach = map.lane_width + map.sidewalk_width  # the sidewalks' outer edges
    # left as seen facing the junction from the leg is the -normal side (normal = left of
    # the outward heading)
    sign = -1.0 if side == "L" else 1.0
    dx, dy = math.cos(leg.heading), math.sin(leg.heading)
    nx, ny = -dy, dx
    n = max(1, math.ceil(2.0 * reach / ROUTE_STEP))
    return Path.from_points(
        [
            (dx * along + nx * b, dy * along + ny * b)
            for b in (sign * reach * (1.0 - 2.0 * k / n) for k in range(n + 1))
        ]
    )


def _check_kind(kind: str) -> None:
    if kind not in KINDS:
        raise ConfigError(field="kind", value=kind, expected=" | ".join(KINDS))
