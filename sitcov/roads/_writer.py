"""OpenDRIVE 1.4 out: a road network given as plain geometry, written as ``.xodr``.

The road layer knows nothing of sitcov's maps: a caller (``sitcov.sim.embedded._odr`` for
the shipped YAML maps) describes its roads as reference polylines with lanes, links and
junction connections, and :func:`xodr_text` writes what OpenDRIVE players (esmini, CARLA)
load. Each reference polyline becomes a G1-continuous chain of ``line`` and ``arc``
geometries through every given point (an arc spline: each piece is the arc tangent to the
previous piece that ends on the next point), so polylines sampled from straight lines and
circular arcs come out as those lines and arcs; neighbouring pieces of the same curvature
are merged. Units: metres, radians; OpenDRIVE's frame (x east, y north, heading
counter-clockwise from x).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from xml.sax.saxutils import quoteattr

#: Pieces whose curvatures differ by less than this are merged into one [1/m].
MERGE_CURVATURE = 1e-4
#: Below this heading change a piece is a straight line [rad].
STRAIGHT = 1e-9


@dataclass(frozen=True)
class LinkSpec:
    """A road's predecessor or successor: another road (``contact``: ``start`` | ``end``)
    or a junction (``element="junction"``, no contact point)."""

    element: str
    id: int
    contact: str | None = None


@dataclass(frozen=True)
class LaneSpec:
    """One lane of a road's single lane section.

    Attributes:
        id: OpenDRIVE lane id: negative right of the reference line (driving along it in
            right-hand traffic), positive left; numbered outwards from 1.
        width: constant width [m].
        type: ``driving``, ``sidewalk``, ``shoulder``, ``border``...
        predecessor, successor: the linked lane id on the preceding / succeeding road.
    """

    id: int
    width: float
    type: str = "driving"
    predecessor: int | None = None
    successor: int | None = None


@dataclass(frozen=True)
class CrosswalkSpec:
    """A pedestrian crossing on a road: a ``crosswalk`` object.

    Attributes:
        s: centre along the reference line [m]; ``t`` lateral offset of its centre [m].
        length: extent along the road [m]; ``width`` across it [m].
    """

    s: float
    t: float
    length: float
    width: float


@dataclass(frozen=True)
class RoadSpec:
    """A road: a reference polyline and its lanes.

    Attributes:
        id: unique road id.
        points: the reference line's points (x, y) [m], at least two.
        heading: the reference line's heading at its first point [rad]; None: the first
            segment's direction.
        lanes: the lanes (``id`` 0, the centre lane, is written by the writer).
        lane_offset: lateral shift of the centre lane from the reference line [m]
            (positive: left), so a reference line may run along a lane's centre.
        junction: the junction this road connects lanes in, or -1.
        predecessor, successor: links at the start / end of the reference line.
        crosswalks: pedestrian crossings on the road.
        name: a readable name.
    """

    id: int
    points: tuple[tuple[float, float], ...]
    lanes: tuple[LaneSpec, ...]
    heading: float | None = None
    lane_offset: float = 0.0
    junction: int = -1
    predecessor: LinkSpec | None = None
    successor: LinkSpec | None = None
    crosswalks: tuple[CrosswalkSpec, ...] = ()
    name: str = ""


@dataclass(frozen=True)
class ConnectionSpec:
    """A junction connection: lanes of ``incoming`` continue on ``connecting``.

    Attributes:
        contact: where the connecting road touches the incoming one (``start``/``end`` of
            the connecting road).
        lane_links: (incoming lane id, connecting lane id) pairs.
    """

    id: int
    incoming: int
    connecting: int
    contact: str
    lane_links: tuple[tuple[int, int], ...]


@dataclass(frozen=True)
class JunctionSpec:
    """A junction and its connections."""

    id: int
    name: str
    connections: tuple[ConnectionSpec, ...]


@dataclass(frozen=True)
class NetworkSpec:
    """Everything an ``.xodr`` file holds."""

    name: str
    roads: tuple[RoadSpec, ...]
    junctions: tuple[JunctionSpec, ...] = ()
    meta: dict[str, str] = field(default_factory=dict)


@dataclass(frozen=True)
class Piece:
    """One planView geometry: a line (``curvature`` 0) or an arc, from (x, y, hdg)."""

    s: float
    x: float
    y: float
    hdg: float
    length: float
    curvature: float


def _wrap(angle: float) -> float:
    return math.atan2(math.sin(angle), math.cos(angle))


def arc_spline(points: Sequence[tuple[float, float]], heading: float | None = None) -> list[Piece]:
    """Lines and arcs through every point of ``points``, tangent to each other.

    The first piece leaves the first point at ``heading`` (default: towards the second
    point); each next piece is the circular arc (or line) tangent to the end of the one
    before that ends on the next point. Consecutive pieces whose curvatures differ by less
    than :data:`MERGE_CURVATURE` are merged (their length-weighted mean curvature).

    Raises:
        ValueError: fewer than two distinct points.
    """
    pts = [points[0]]
    for p in points[1:]:
        if math.dist(p, pts[-1]) > 1e-6:
            pts.append(p)
    if len(pts) < 2:
        raise ValueError("a reference line needs two distinct points")
    h = heading if heading is not None else math.atan2(pts[1][1] - pts[0][1], pts[1][0] - pts[0][0])
    raw: list[Piece] = []
    s = 0.0
    for (x0, y0), (x1, y1) in zip(pts, pts[1:], strict=False):
        chord = math.hypot(x1 - x0, y1 - y0)
        dh = _wrap(math.atan2(y1 - y0, x1 - x0) - h)
        if abs(dh) < STRAIGHT:
            length, k = chord, 0.0
        else:
            length, k = chord * dh / math.sin(dh), 2.0 * math.sin(dh) / chord
        raw.append(Piece(s, x0, y0, h, length, k))
        s += length
        h = _wrap(h + 2.0 * dh)
    merged: list[Piece] = [raw[0]]
    for piece in raw[1:]:
        last = merged[-1]
        if abs(piece.curvature - last.curvature) < MERGE_CURVATURE:
            total = last.length + piece.length
            k = (last.curvature * last.length + piece.curvature * piece.length) / total
            merged[-1] = Piece(last.s, last.x, last.y, last.hdg, total, k)
        else:
            merged.append(piece)
    return merged


def piece_end(piece: Piece) -> tuple[float, float, float]:
    """(x, y, heading) at the end of a piece."""
    k, length = piece.curvature, piece.length
    if abs(k) < 1e-12:
        return (
            piece.x + length * math.cos(piece.hdg),
            piece.y + length * math.sin(piece.hdg),
            piece.hdg,
        )
    h1 = piece.hdg + k * length
    return (
        piece.x + (math.sin(h1) - math.sin(piece.hdg)) / k,
        piece.y - (math.cos(h1) - math.cos(piece.hdg)) / k,
        _wrap(h1),
    )


def _f(value: float) -> str:
    """A number as written: 12 significant digits, no trailing noise."""
    text = f"{value:.12g}"
    return "0" if text == "-0" else text


def _link_xml(tag: str, link: LinkSpec | None) -> str:
    if link is None:
        return ""
    contact = f' contactPoint="{link.contact}"' if link.contact else ""
    return f'<{tag} elementType="{link.element}" elementId="{link.id}"{contact}/>'


def _lane_xml(lane: LaneSpec) -> list[str]:
    links = ""
    if lane.predecessor is not None:
        links += f'<predecessor id="{lane.predecessor}"/>'
    if lane.successor is not None:
        links += f'<successor id="{lane.successor}"/>'
    mark = "solid" if lane.type != "driving" else "broken"
    return [
        f'          <lane id="{lane.id}" type="{lane.type}" level="false">',
        f"            <link>{links}</link>" if links else "            <link/>",
        f'            <width sOffset="0" a="{_f(lane.width)}" b="0" c="0" d="0"/>',
        f'            <roadMark sOffset="0" type="{mark}" weight="standard" color="standard" '
        'width="0.12"/>',
        "          </lane>",
    ]


def _road_xml(road: RoadSpec) -> list[str]:
    pieces = arc_spline(road.points, road.heading)
    length = sum(p.length for p in pieces)
    out = [
        f'  <road name={quoteattr(road.name or str(road.id))} length="{_f(length)}" '
        f'id="{road.id}" junction="{road.junction}">'
    ]
    link = _link_xml("predecessor", road.predecessor) + _link_xml("successor", road.successor)
    out.append(f"    <link>{link}</link>" if link else "    <link/>")
    out.append('    <type s="0" type="town"><speed max="50" unit="km/h"/></type>')
    out.append("    <planView>")
    for p in pieces:
        shape = "<line/>" if p.curvature == 0.0 else f'<arc curvature="{_f(p.curvature)}"/>'
        out.append(
            f'      <geometry s="{_f(p.s)}" x="{_f(p.x)}" y="{_f(p.y)}" hdg="{_f(p.hdg)}" '
            f'length="{_f(p.length)}">{shape}</geometry>'
        )
    out.append("    </planView>")
    out.append(
        '    <elevationProfile><elevation s="0" a="0" b="0" c="0" d="0"/></elevationProfile>'
    )
    out.append("    <lateralProfile/>")
    out.append("    <lanes>")
    if road.lane_offset:
        out.append(f'      <laneOffset s="0" a="{_f(road.lane_offset)}" b="0" c="0" d="0"/>')
    out.append('      <laneSection s="0">')
    left = sorted((lane for lane in road.lanes if lane.id > 0), key=lambda lane: -lane.id)
    right = sorted((lane for lane in road.lanes if lane.id < 0), key=lambda lane: -lane.id)
    if left:
        out.append("        <left>")
        for lane in left:
            out += _lane_xml(lane)
        out.append("        </left>")
    out.append("        <center>")
    out.append('          <lane id="0" type="none" level="false"><link/>')
    out.append(
        '            <roadMark sOffset="0" type="broken" weight="standard" color="standard" '
        'width="0.12"/>'
    )
    out.append("          </lane>")
    out.append("        </center>")
    if right:
        out.append("        <right>")
        for lane in right:
            out += _lane_xml(lane)
        out.append("        </right>")
    out.append("      </laneSection>")
    out.append("    </lanes>")
    if road.crosswalks:
        out.append("    <objects>")
        for i, cw in enumerate(road.crosswalks):
            out.append(
                f'      <object type="crosswalk" name="crosswalk" id="{road.id * 100 + i}" '
                f's="{_f(cw.s)}" t="{_f(cw.t)}" zOffset="0" validLength="0" orientation="none" '
                f'length="{_f(cw.length)}" width="{_f(cw.width)}" height="0" hdg="0" pitch="0" '
                'roll="0"/>'
            )
        out.append("    </objects>")
    out.append("  </road>")
    return out


def _junction_xml(junction: JunctionSpec) -> list[str]:
    out = [f'  <junction name={quoteattr(junction.name)} id="{junction.id}">']
    for c in junction.connections:
        out.append(
            f'    <connection id="{c.id}" incomingRoad="{c.incoming}" '
            f'connectingRoad="{c.connecting}" contactPoint="{c.contact}">'
        )
        for a, b in c.lane_links:
            out.append(f'      <laneLink from="{a}" to="{b}"/>')
        out.append("    </connection>")
    out.append("  </junction>")
    return out


def xodr_text(network: NetworkSpec) -> str:
    """The OpenDRIVE 1.4 document of ``network`` (deterministic: same network, same text)."""
    xs = [x for road in network.roads for x, _ in road.points]
    ys = [y for road in network.roads for _, y in road.points]
    lines = [
        '<?xml version="1.0" encoding="UTF-8"?>',
        "<OpenDRIVE>",
        f'  <header revMajor="1" revMinor="4" name={quoteattr(network.name)} version="1.00" '
        f'date="2024-01-01T00:00:00" north="{_f(max(ys))}" south="{_f(min(ys))}" '
        f'east="{_f(max(xs))}" west="{_f(min(xs))}" vendor="sitcov">',
    ]
    if network.meta:
        for key, value in sorted(network.meta.items()):
            lines.append(f"    <userData code={quoteattr(key)} value={quoteattr(value)}/>")
    lines.append("  </header>")
    for road in network.roads:
        lines += _road_xml(road)
    for junction in network.junctions:
        lines += _junction_xml(junction)
    lines.append("</OpenDRIVE>")
    return "\n".join(lines) + "\n"


def write_xodr(network: NetworkSpec, path: str | Path) -> Path:
    """Write ``network`` as an OpenDRIVE file; the path written."""
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(xodr_text(network), encoding="utf-8")
    return out
