"""Routes per kind of road user (MINIMAL version by helper ``world``; ``roads`` owns this module).

``actor_route(map, kind, route)`` is the shared interface (docs/embedded.md, "Scene"):

- ``car`` / ``truck``: a movement ``"L-B"``, the lane centre line (``JunctionMap.route``);
- ``cyclist``: a movement, ridden :data:`CYCLIST_OFFSET` right of the lane centre;
- ``pedestrian``: ``"X<leg><L|R>"``, the crosswalk across ``<leg>``
  :data:`CROSSWALK_OUTSIDE` metres outside the leg's mouth, from the kerb on the left
  (``L``, as seen facing the junction from that leg) or the right (``R``) to the other
  kerb, starting and ending :data:`SIDEWALK` metres onto the sidewalk.

The version of helper ``roads`` (crosswalks and bike positions as map data) replaces this
one with the same signature.
"""

from __future__ import annotations

import math

from sitcov.errors import ConfigError
from sitcov.sim.embedded._map import ROUTE_STEP, JunctionMap
from sitcov.sim.embedded._path import Path

#: Kinds of road user with a route.
KINDS = ("car", "truck", "cyclist", "pedestrian")
#: A cyclist rides this far right of the lane centre [m] (a 3.5 m lane leaves ~0.45 m
#: between a 0.6 m wide bicycle and the kerb).
CYCLIST_OFFSET = 1.0
#: Offset points closer than this to the previous one are dropped (no kinks) [m].
MIN_SPACING = 0.3
#: Crosswalk centre line: this far outside the leg's mouth [m].
CROSSWALK_OUTSIDE = 2.0
#: A crosswalk route starts and ends this far beyond the kerb, on the sidewalk [m].
SIDEWALK = 1.5


def actor_route(map: JunctionMap, kind: str, route: str) -> Path:  # noqa: A002 - interface name
    """The path a road user of ``kind`` follows for the route name ``route``.

    Raises:
        ConfigError: unknown kind, or a route name that does not fit the kind and map.
    """
    if kind in ("car", "truck"):
        return map.route(*map._parse_move(route))
    if kind == "cyclist":
        return _offset(map.route(*map._parse_move(route)), -CYCLIST_OFFSET)
    if kind == "pedestrian":
        return _crosswalk(map, route)
    raise ConfigError(field="kind", value=kind, expected=" | ".join(KINDS))


def _offset(path: Path, lateral: float) -> Path:
    """``path`` shifted ``lateral`` metres to its left (negative: right) along its normals
    (at a point, the normal of the mean of the headings arriving and leaving)."""
    pts = []
    hs = path.hs
    for i, (x, y) in enumerate(zip(path.xs, path.ys, strict=True)):
        h_in, h_out = hs[max(i - 1, 0)], hs[i]
        h = math.atan2(math.sin(h_in) + math.sin(h_out), math.cos(h_in) + math.cos(h_out))
        px, py = x - lateral * math.sin(h), y + lateral * math.cos(h)
        if not pts or math.hypot(px - pts[-1][0], py - pts[-1][1]) > MIN_SPACING:
            pts.append((px, py))
    full = Path.from_points(pts)
    return full.sub(0.0, full.length, ROUTE_STEP)


def _crosswalk(map: JunctionMap, route: str) -> Path:  # noqa: A002
    name = str(route)
    if len(name) != 3 or name[0] != "X" or name[1] not in map.legs or name[2] not in "LR":
        raise ConfigError(
            field="route",
            value=route,
            expected=f"'X<leg><L|R>' with a leg of {sorted(map.legs)}",
        )
    leg = map.legs[name[1]]
    dx, dy = math.cos(leg.heading), math.sin(leg.heading)
    nx, ny = -dy, dx  # left normal of the outward axis: the inbound lane's side
    along = leg.mouth + CROSSWALK_OUTSIDE
    reach = map.lane_width + SIDEWALK
    # facing the junction from the leg, the left kerb is on the -normal side
    side = -1.0 if name[2] == "L" else 1.0
    start = (dx * along + side * reach * nx, dy * along + side * reach * ny)
    end = (dx * along - side * reach * nx, dy * along - side * reach * ny)
    full = Path.from_points([start, end])
    return full.sub(0.0, full.length, ROUTE_STEP)
