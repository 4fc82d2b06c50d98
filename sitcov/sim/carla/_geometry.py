"""Frames, routes on CARLA's lane graph, and box distances.

CARLA (Unreal) is left-handed: x forward, y to the right, yaw [deg] turning from +x towards
+y. sitcov's stacks and metrics use a right-handed plane (yaw counter-clockwise, steer
positive = left). The mapping is a mirror in y: ``(x, y, yaw) -> (x, -y, -yaw)``; a CARLA
steer command is therefore the negated sitcov steer.

Routes come from the map's own lane graph (``Map.get_waypoint`` and ``Waypoint.next``): the
PyPI wheel does not ship CARLA's ``agents`` package, so its GlobalRoutePlanner is not
available; a best-first search over waypoints does the same job for one junction.
"""

from __future__ import annotations

import heapq
import math
from typing import Any

from sitcov.errors import ConfigError

#: Spacing of route points [m], as RunInfo.route promises (~1 m).
ROUTE_STEP = 1.0
#: Cap on waypoints expanded by the route search (a few km of lanes).
MAX_EXPANSIONS = 20000


def to_sitcov(x: float, y: float, yaw_deg: float) -> tuple[float, float, float]:
    """CARLA position [m] and yaw [deg] -> sitcov (x [m], y [m], yaw [rad, CCW])."""
    return x, -y, -math.radians(yaw_deg)


def carla_transform(carla: Any, x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> Any:
    """A ``carla.Transform`` at (x, y, z) [m] with heading ``yaw`` [deg], CARLA frame."""
    return carla.Transform(
        carla.Location(x=x, y=y, z=z), carla.Rotation(pitch=0.0, yaw=yaw, roll=0.0)
    )


def steer_to_carla(steer: float) -> float:
    """sitcov steer (positive = left) -> carla.VehicleControl.steer (positive = right)."""
    return -max(-1.0, min(1.0, steer))


def plan_route(
    carla_map: Any, start: Any, goal: tuple[float, float], *, tolerance: float = 3.0
) -> list[tuple[float, float]]:
    """Points (CARLA frame) about 1 m apart along the lane graph from ``start`` to ``goal``.

    Args:
        carla_map: a ``carla.Map``.
        start: a ``carla.Location`` (projected onto the nearest driving lane).
        goal: (x, y) [m]; the search ends within ``tolerance`` [m] of it.

    Raises:
        ConfigError: the goal cannot be reached from the start on the lane graph.
    """
    gx, gy = goal
    first = carla_map.get_waypoint(start)
    counter = 0
    frontier: list[tuple[float, int, float, Any, tuple | None]] = []
    parents: dict[tuple, tuple | None] = {}
    points: dict[tuple, tuple[float, float]] = {}

    def key(wp: Any) -> tuple:
        return (wp.road_id, wp.section_id, wp.lane_id, round(wp.s / ROUTE_STEP))

    def push(wp: Any, cost: float, parent: tuple | None) -> None:
        nonlocal counter
        k = key(wp)
        if k in parents:
            return
        loc = wp.transform.location
        parents[k] = parent
        points[k] = (loc.x, loc.y)
        counter += 1
        heapq.heappush(frontier, (cost + math.hypot(gx - loc.x, gy - loc.y), counter, cost, wp, k))

    push(first, 0.0, None)
    while frontier and counter < MAX_EXPANSIONS:
        _, _, cost, wp, k = heapq.heappop(frontier)
        x, y = points[k]
        if math.hypot(gx - x, gy - y) <= tolerance:
            path = []
            node: tuple | None = k
            while node is not None:
                path.append(points[node])
                node = parents[node]
            path.reverse()
            return path
        for nxt in wp.next(ROUTE_STEP):
            push(nxt, cost + ROUTE_STEP, k)
    loc = first.transform.location
    raise ConfigError(
        f"no route on the lane graph from ({loc.x:.1f}, {loc.y:.1f}) to "
        f"({gx:.1f}, {gy:.1f}): check the map file's spawn points and goals"
    )


def box_corners(
    x: float, y: float, yaw: float, half_length: float, half_width: float
) -> list[tuple[float, float]]:
    """Corners of an oriented box (any consistent frame; yaw [rad])."""
    c, s = math.cos(yaw), math.sin(yaw)
    return [
        (x + c * dx - s * dy, y + s * dx + c * dy)
        for dx, dy in (
            (half_length, half_width),
            (-half_length, half_width),
            (-half_length, -half_width),
            (half_length, -half_width),
        )
    ]


def _overlap(a: list[tuple[float, float]], b: list[tuple[float, float]]) -> bool:
    for poly in (a, b):
        for i in range(4):
            x1, y1 = poly[i]
            x2, y2 = poly[(i + 1) % 4]
            nx, ny = y1 - y2, x2 - x1
            pa = [nx * px + ny * py for px, py in a]
            pb = [nx * px + ny * py for px, py in b]
            if max(pa) < min(pb) or max(pb) < min(pa):
                return False
    return True


def _point_segment(px: float, py: float, a: tuple, b: tuple) -> float:
    ax, ay = a
    dx, dy = b[0] - ax, b[1] - ay
    den = dx * dx + dy * dy
    t = 0.0 if den == 0 else max(0.0, min(1.0, ((px - ax) * dx + (py - ay) * dy) / den))
    return math.hypot(px - ax - t * dx, py - ay - t * dy)


def box_distance(a: list[tuple[float, float]], b: list[tuple[float, float]]) -> float:
    """Distance [m] between two convex quadrilaterals (0 when they overlap)."""
    if _overlap(a, b):
        return 0.0
    best = math.inf
    for p, q in ((a, b), (b, a)):
        for px, py in p:
            for i in range(4):
                best = min(best, _point_segment(px, py, q[i], q[(i + 1) % 4]))
    return best
