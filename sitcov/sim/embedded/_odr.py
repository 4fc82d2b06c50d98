"""A junction map as an OpenDRIVE road network (``sitcov.roads``), for export.

Every layout (leg junction, roundabout, merge) becomes the same shape: one road per leg,
its reference line from the leg's mouth outwards, the outbound lane ``-1`` right of it and
the inbound lane ``1`` left of it (right-hand traffic), sidewalks outside them when the map
draws sidewalks, the leg's crosswalk as a ``crosswalk`` object; and one junction whose
connecting roads are the map's movements: for movement ``X-Y`` the lanes between leg X's
inbound lane and leg Y's outbound lane (a turning arc, or entry curve + ring + exit curve
on a roundabout, or the ramp's curve, acceleration lane and taper on a merge), with the
reference line along the lane's centre (``laneOffset`` half a lane) and one lane ``-1``.
So a route through the exported file is exactly sitcov's route, and a position on a lane
is on the lane sitcov uses.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

from sitcov.roads import (
    ConnectionSpec,
    CrosswalkSpec,
    JunctionSpec,
    LaneSpec,
    LinkSpec,
    NetworkSpec,
    RoadSpec,
)
from sitcov.sim.embedded._map import JunctionMap

#: The junction's id; leg roads are 1..n, connecting roads JUNCTION_ID + 1...
JUNCTION_ID = 100


@dataclass(frozen=True)
class OdrIds:
    """Where sitcov's lanes are in the exported network.

    Attributes:
        legs: leg name -> road id (reference line from the mouth outwards; inbound lane 1,
            outbound lane -1).
        movements: movement ``X-Y`` -> connecting road id (lane -1, along the movement).
    """

    legs: dict[str, int]
    movements: dict[str, int]


def _mid(a: tuple[float, float], b: tuple[float, float]) -> tuple[float, float]:
    return (0.5 * (a[0] + b[0]), 0.5 * (a[1] + b[1]))


def _leg_road(jmap: JunctionMap, name: str, road_id: int, sidewalks: bool) -> RoadSpec:
    """Leg ``name``'s road: straight, from the mouth outwards."""
    w = jmap.lane_width
    lane_in = jmap.lane(f"{name}.in") if f"{name}.in" in jmap.graph else None
    lane_out = jmap.lane(f"{name}.out") if f"{name}.out" in jmap.graph else None
    lanes: list[LaneSpec] = []
    if lane_in is not None and lane_out is not None:
        points = (
            _mid(lane_out.points[0], lane_in.points[-1]),
            _mid(lane_out.points[-1], lane_in.points[0]),
        )
        offset = 0.0
        lanes += [LaneSpec(1, w), LaneSpec(-1, w)]
        if sidewalks:
            lanes += [LaneSpec(2, jmap.sidewalk_width, "sidewalk")]
            lanes += [LaneSpec(-2, jmap.sidewalk_width, "sidewalk")]
    elif lane_out is not None:
        points, offset = (lane_out.points[0], lane_out.points[-1]), 0.5 * w
        lanes.append(LaneSpec(-1, w))
    elif lane_in is not None:
        points, offset = (lane_in.points[-1], lane_in.points[0]), -0.5 * w
        lanes.append(LaneSpec(1, w))
    else:  # pragma: no cover - every leg of a valid map has a lane
        raise ValueError(f"leg {name} has no lane")
    crosswalks: tuple[CrosswalkSpec, ...] = ()
    leg = jmap.legs[name]
    if leg.crosswalk is not None:
        # s from the road's start (the mouth); the crossing spans both lanes
        s = leg.crosswalk.offset + 0.5 * leg.crosswalk.width
        crosswalks = (CrosswalkSpec(s, 0.0, leg.crosswalk.width, 2.0 * w),)
    return RoadSpec(
        road_id,
        tuple(points),
        tuple(lanes),
        lane_offset=offset,
        predecessor=LinkSpec("junction", JUNCTION_ID),
        crosswalks=crosswalks,
        name=f"leg {name}",
    )


def _movement_points(jmap: JunctionMap, move: str) -> tuple[list[tuple[float, float]], float]:
    """The movement's lane centre between the two legs' lanes, and its start heading."""
    a, _, b = move.partition("-")
    seq = jmap.lane_sequence(a, b)
    points: list[tuple[float, float]] = []
    for lane_id in seq[1:-1]:
        for p in jmap.lane(lane_id).points:
            if not points or math.dist(p, points[-1]) > 1e-6:
                points.append(p)
    inbound = jmap.lane(seq[0])
    (x0, y0), (x1, y1) = inbound.points[-2], inbound.points[-1]
    return points, math.atan2(y1 - y0, x1 - x0)


@functools.lru_cache(maxsize=16)
def road_network(jmap: JunctionMap) -> tuple[NetworkSpec, OdrIds]:
    """The OpenDRIVE network of ``jmap`` and where its legs and movements are in it."""
    sidewalks = bool(jmap.render_geometry()["sidewalks"])
    legs = {name: i + 1 for i, name in enumerate(jmap.legs)}
    roads = [_leg_road(jmap, name, legs[name], sidewalks) for name in jmap.legs]
    movements: dict[str, int] = {}
    connections: list[ConnectionSpec] = []
    for k, move in enumerate(jmap.movements):
        a, _, b = move.partition("-")
        road_id = JUNCTION_ID + 1 + k
        movements[move] = road_id
        points, heading = _movement_points(jmap, move)
        roads.append(
            RoadSpec(
                road_id,
                tuple(points),
                (LaneSpec(-1, jmap.lane_width, predecessor=1, successor=-1),),
                heading=heading,
                lane_offset=0.5 * jmap.lane_width,
                junction=JUNCTION_ID,
                predecessor=LinkSpec("road", legs[a], "start"),
                successor=LinkSpec("road", legs[b], "start"),
                name=f"movement {move}",
            )
        )
        connections.append(ConnectionSpec(k, legs[a], road_id, "start", ((1, -1),)))
    network = NetworkSpec(
        jmap.name,
        tuple(roads),
        (JunctionSpec(JUNCTION_ID, jmap.name, tuple(connections)),),
        meta={"sitcov_map": jmap.name, "sitcov_layout": jmap.LAYOUT},
    )
    return network, OdrIds(legs, movements)


def hero_route(
    jmap: JunctionMap, ids: OdrIds, move: str, start: tuple[float, float]
) -> tuple[tuple[int, int, float], ...]:
    """Lane waypoints (road id, lane id, s [m]) of movement ``move`` in the exported
    network, from ``start`` (the ego's spawn, on leg X's inbound lane): the spawn, the middle
    of the movement's connecting road, and 5 m into leg Y's outbound lane."""
    a, _, b = move.partition("-")
    network, _ = road_network(jmap)
    roads = {road.id: road for road in network.roads}
    leg = roads[ids.legs[a]]
    (x0, y0), (x1, y1) = leg.points[0], leg.points[-1]
    length = math.hypot(x1 - x0, y1 - y0)
    s = ((start[0] - x0) * (x1 - x0) + (start[1] - y0) * (y1 - y0)) / length
    connector = roads[ids.movements[move]]
    half = 0.5 * sum(
        math.dist(p, q) for p, q in zip(connector.points, connector.points[1:], strict=False)
    )
    exit_leg = roads[ids.legs[b]]
    exit_len = math.dist(exit_leg.points[0], exit_leg.points[-1])
    return (
        (leg.id, 1, min(max(s, 0.0), length)),
        (connector.id, -1, half),
        (exit_leg.id, -1, min(5.0, exit_len)),
    )
