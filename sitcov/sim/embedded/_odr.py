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
            outbound lane -1); empty for a network of movement chains.
        movements: movement ``X-Y`` -> connecting road id (lane -1, along the movement).
        entry, exit: movement -> (road id, lane id) of the lane it starts on / ends on.
    """

    legs: dict[str, int]
    movements: dict[str, int]
    entry: dict[str, tuple[int, int]]
    exit: dict[str, tuple[int, int]]


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


def _has_leg_lanes(jmap: JunctionMap) -> bool:
    """Whether every leg has shared ``X.in`` / ``X.out`` lanes (the shipped layouts)."""
    return all(f"{leg}.in" in jmap.graph or f"{leg}.out" in jmap.graph for leg in jmap.legs)


@functools.lru_cache(maxsize=16)
def road_network(jmap: JunctionMap) -> tuple[NetworkSpec, OdrIds]:
    """The OpenDRIVE network of ``jmap`` and where its legs and movements are in it.

    Maps whose legs share an inbound and an outbound lane (the shipped layouts) become leg
    roads and a junction of movements (module docstring); maps whose lanes are given per
    movement (an imported junction) become one chain per movement: its inbound lane, its
    connecting lane in the junction, its outbound lane, one road each.
    """
    if not _has_leg_lanes(jmap):
        return _movement_chains(jmap)
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
    entry = {m: (legs[m.partition("-")[0]], 1) for m in movements}
    exit_ = {m: (legs[m.partition("-")[2]], -1) for m in movements}
    return network, OdrIds(legs, movements, entry, exit_)


def _movement_chains(jmap: JunctionMap) -> tuple[NetworkSpec, OdrIds]:
    """One inbound road, connecting road and outbound road per movement (reference lines
    along the lane centres, one lane -1 each)."""
    w = jmap.lane_width
    roads: list[RoadSpec] = []
    connections: list[ConnectionSpec] = []
    movements: dict[str, int] = {}
    entry: dict[str, tuple[int, int]] = {}
    exit_: dict[str, tuple[int, int]] = {}
    for k, move in enumerate(jmap.movements):
        a, _, b = move.partition("-")
        seq = jmap.lane_sequence(a, b)
        in_id, conn_id, out_id = 3 * k + 1, JUNCTION_ID + 1 + k, 3 * k + 3
        points, heading = _movement_points(jmap, move)
        roads += [
            RoadSpec(
                in_id, jmap.lane(seq[0]).points, (LaneSpec(-1, w, successor=-1),),
                lane_offset=0.5 * w, successor=LinkSpec("junction", JUNCTION_ID),
                name=f"{move} in",
            ),
            RoadSpec(
                conn_id, tuple(points), (LaneSpec(-1, w, predecessor=-1, successor=-1),),
                heading=heading, lane_offset=0.5 * w, junction=JUNCTION_ID,
                predecessor=LinkSpec("road", in_id, "end"),
                successor=LinkSpec("road", out_id, "start"), name=f"movement {move}",
            ),
            RoadSpec(
                out_id, jmap.lane(seq[-1]).points, (LaneSpec(-1, w, predecessor=-1),),
                lane_offset=0.5 * w, predecessor=LinkSpec("junction", JUNCTION_ID),
                name=f"{move} out",
            ),
        ]  # fmt: skip
        connections.append(ConnectionSpec(k, in_id, conn_id, "start", ((-1, -1),)))
        movements[move], entry[move], exit_[move] = conn_id, (in_id, -1), (out_id, -1)
    network = NetworkSpec(
        jmap.name,
        tuple(roads),
        (JunctionSpec(JUNCTION_ID, jmap.name, tuple(connections)),),
        meta={"sitcov_map": jmap.name, "sitcov_layout": jmap.LAYOUT},
    )
    return network, OdrIds({}, movements, entry, exit_)


def _length(points) -> float:
    return sum(math.dist(p, q) for p, q in zip(points, points[1:], strict=False))


def _project(points, p: tuple[float, float]) -> float:
    """Arc length along the polyline ``points`` of the point nearest ``p`` [m]."""
    best, best_s, s = math.inf, 0.0, 0.0
    for a, b in zip(points, points[1:], strict=False):
        seg = math.dist(a, b)
        if seg > 0:
            f = ((p[0] - a[0]) * (b[0] - a[0]) + (p[1] - a[1]) * (b[1] - a[1])) / seg**2
            f = min(max(f, 0.0), 1.0)
            d = math.dist(p, (a[0] + f * (b[0] - a[0]), a[1] + f * (b[1] - a[1])))
            if d < best:
                best, best_s = d, s + f * seg
        s += seg
    return best_s


def hero_route(
    jmap: JunctionMap, ids: OdrIds, move: str, start: tuple[float, float]
) -> tuple[tuple[int, int, float], ...]:
    """Lane waypoints (road id, lane id, s [m]) of movement ``move`` in the exported
    network, from ``start`` (the ego's spawn, on the movement's inbound lane): the spawn,
    the middle of the movement's connecting road, and 5 m into its outbound lane."""
    network, _ = road_network(jmap)
    roads = {road.id: road for road in network.roads}
    (in_id, in_lane), (out_id, out_lane) = ids.entry[move], ids.exit[move]
    inbound, outbound = roads[in_id], roads[out_id]
    connector = roads[ids.movements[move]]
    # reference lines run as the lanes' approximating polylines: s from the projection
    s = _project(inbound.points, start)
    exit_s = 5.0 if out_lane < 0 else _length(outbound.points) - 5.0
    return (
        (in_id, in_lane, min(max(s, 0.0), _length(inbound.points))),
        (connector.id, -1, 0.5 * _length(connector.points)),
        (out_id, out_lane, min(max(exit_s, 0.0), _length(outbound.points))),
    )
