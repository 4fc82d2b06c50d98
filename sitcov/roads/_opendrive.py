"""Reading an OpenDRIVE file (1.4 to 1.6) into plain data: roads, lanes, junctions, crosswalks.

Parsed with the standard library's ``xml.etree`` (no third-party reader was both light and
faithful enough: see ``docs/roads.md``). What is read: the plan view (line, arc, spiral,
poly3, paramPoly3 with ``pRange`` arcLength or normalized), lane offsets, lane sections with
their lanes (id, type, width polynomials per ``sOffset``, predecessor/successor links), road
links, junctions with their connections and lane links, and crosswalk objects (with or
without an outline). Ignored: elevation, superelevation and lateral shape (the world is
flat), road marks, signals, lane ``<border>`` records (a file using them is refused with a
clear error), speed records, user data.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path as FsPath

import numpy as np

from sitcov.errors import ConfigError
from sitcov.roads._geometry import Arc, Geometry, Line, ParamPoly3, PlanView, Spiral, poly3

#: Lane types that carry vehicles (the drivable area and the routes).
DRIVING_TYPES = frozenset({"driving", "entry", "exit", "onRamp", "offRamp", "connectingRamp"})


@dataclass(frozen=True)
class Poly:
    """A cubic in a local coordinate ``ds`` from ``start`` [m]: a + b ds + c ds^2 + d ds^3."""

    start: float
    a: float
    b: float
    c: float
    d: float


def eval_polys(polys: tuple[Poly, ...], s: np.ndarray) -> np.ndarray:
    """Piecewise cubics (sorted by start) at ``s``: each from its start to the next one's."""
    out = np.zeros_like(s, dtype=float)
    if not polys:
        return out
    starts = np.array([p.start for p in polys])
    idx = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(polys) - 1)
    for i in np.unique(idx):
        p, m = polys[i], idx == i
        ds = s[m] - p.start
        out[m] = p.a + ds * (p.b + ds * (p.c + ds * p.d))
    return out


@dataclass(frozen=True)
class Lane:
    """One lane of a lane section.

    Attributes:
        id: OpenDRIVE lane id (positive left of the reference line, negative right).
        type: ``driving``, ``sidewalk``, ``biking``, ``shoulder``, ...
        widths: width polynomials, ``start`` relative to the section's start [m].
        predecessor, successor: linked lane ids in the neighbouring section/road, or None.
    """

    id: int
    type: str
    widths: tuple[Poly, ...]
    predecessor: int | None
    successor: int | None

    @property
    def drivable(self) -> bool:
        return self.type in DRIVING_TYPES


@dataclass(frozen=True)
class LaneSection:
    """Lanes from ``s`` [m] to the next section (``single_side`` sections are read too)."""

    s: float
    lanes: dict[int, Lane]

    def lane_ids(self, side: int) -> list[int]:
        """Lane ids on one side (``side`` -1: right, +1: left), from the centre outwards."""
        return sorted((i for i in self.lanes if i * side > 0), key=abs)


@dataclass(frozen=True)
class RoadLink:
    """A road's predecessor or successor: ``element_type`` road|junction, its id, and the
    contact point (``start``/``end``) on a linked road."""

    element_type: str
    element_id: str
    contact_point: str | None


@dataclass(frozen=True)
class Crosswalk:
    """A crosswalk object: its outline in world coordinates [m] (counter-clockwise)."""

    id: str
    road: str
    outline: tuple[tuple[float, float], ...]


@dataclass
class Road:
    """A road: reference line, lane offset, lane sections, links, crosswalks."""

    id: str
    name: str
    length: float
    junction: str
    plan_view: PlanView
    lane_offset: tuple[Poly, ...]
    sections: list[LaneSection]
    predecessor: RoadLink | None = None
    successor: RoadLink | None = None
    crosswalks: list[Crosswalk] = field(default_factory=list)

    def section_index(self, s: float) -> int:
        """Index of the lane section containing ``s``."""
        starts = [sec.s for sec in self.sections]
        return max(0, int(np.searchsorted(starts, s, side="right")) - 1)

    def section_end(self, index: int) -> float:
        """Where section ``index`` ends [m]."""
        return self.sections[index + 1].s if index + 1 < len(self.sections) else self.length

    def borders(self, index: int, lane_id: int, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Lateral offsets ``t`` [m] of a lane's inner and outer border at road ``s``
        (in section ``index``), lane offset included."""
        sec = self.sections[index]
        side = 1 if lane_id > 0 else -1
        t = eval_polys(self.lane_offset, s)
        inner = t.copy()
        for lid in sec.lane_ids(side):
            w = eval_polys(sec.lanes[lid].widths, s - sec.s)
            if lid == lane_id:
                return inner, inner + side * w
            inner = inner + side * w
        raise KeyError(lane_id)

    def points(
        self, index: int, lane_id: int, s: np.ndarray, where: float = 0.5
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World (x, y, road heading) of a lane at ``s``: ``where`` 0 = inner border,
        0.5 = centre line, 1 = outer border."""
        inner, outer = self.borders(index, lane_id, s)
        t = inner + where * (outer - inner)
        x, y, h = self.plan_view.evaluate(s)
        return x - t * np.sin(h), y + t * np.cos(h), h

    def at(self, s: float, t: float) -> tuple[float, float, float]:
        """World (x, y, heading) of the point ``t`` [m] left of the reference line at ``s``."""
        x, y, h = self.plan_view.evaluate(np.array([s]))
        return float(x[0] - t * math.sin(h[0])), float(y[0] + t * math.cos(h[0])), float(h[0])


@dataclass(frozen=True)
class LaneLink:
    """A junction lane link: lane ``from_lane`` of the incoming road -> ``to_lane`` of the
    connecting road."""

    from_lane: int
    to_lane: int


@dataclass(frozen=True)
class Connection:
    """A junction connection: incoming road -> connecting road (entered at
    ``contact_point``: ``start`` or ``end``) with its lane links."""

    id: str
    incoming: str
    connecting: str
    contact_point: str
    lane_links: tuple[LaneLink, ...]


@dataclass(frozen=True)
class Junction:
    """A junction: id, name and connections."""

    id: str
    name: str
    connections: tuple[Connection, ...]


@dataclass
class Network:
    """A parsed OpenDRIVE file."""

    source: str
    roads: dict[str, Road]
    junctions: dict[str, Junction]


class _Reader:
    """Attribute access that raises ConfigError naming the file and the element."""

    def __init__(self, source: str) -> None:
        self.source = source

    def num(self, el: ET.Element, key: str, where: str, default: float | None = None) -> float:
        raw = el.get(key)
        if raw is None and default is not None:
            return default
        try:
            value = float(raw)  # type: ignore[arg-type]
        except (TypeError, ValueError):
            value = math.nan
        if not math.isfinite(value):
            raise ConfigError(
                file=self.source, field=f"{where}@{key}", value=raw, expected="a finite number"
            )
        return value

    def text(self, el: ET.Element, key: str, where: str) -> str:
        raw = el.get(key)
        if raw is None or raw == "":
            raise ConfigError(file=self.source, field=f"{where}@{key}", expected="a value")
        return raw

    def poly(self, el: ET.Element, start_key: str, where: str) -> Poly:
        return Poly(
            self.num(el, start_key, where, 0.0),
            *(self.num(el, k, where, 0.0) for k in "abcd"),
        )


def read_opendrive(path: str | FsPath) -> Network:
    """Parse an OpenDRIVE file.

    Raises:
        ConfigError: unreadable file, not OpenDRIVE XML, or an element with a missing or
            bad attribute (the message names the file and the element, e.g.
            ``road[id=5]/planView/geometry[2]@length``).
    """
    source = str(path)
    try:
        root = ET.parse(source).getroot()
    except OSError as exc:
        raise ConfigError(
            file=source, field="(file)", expected=f"a readable file ({exc.strerror})"
        ) from None
    except ET.ParseError as exc:
        raise ConfigError(f"{source}: not valid XML: {exc}") from None
    if root.tag != "OpenDRIVE":
        raise ConfigError(
            file=source, field="(root element)", value=root.tag, expected="<OpenDRIVE>"
        )
    rd = _Reader(source)
    roads: dict[str, Road] = {}
    for k, el in enumerate(root.findall("road")):
        road = _road(rd, el, f"road[{k}]")
        roads[road.id] = road
    junctions: dict[str, Junction] = {}
    for el in root.findall("junction"):
        jid = rd.text(el, "id", "junction")
        where = f"junction[id={jid}]"
        conns = []
        for c in el.findall("connection"):
            cwhere = f"{where}/connection[id={c.get('id')}]"
            links = tuple(
                LaneLink(
                    int(rd.num(ll, "from", cwhere + "/laneLink")),
                    int(rd.num(ll, "to", cwhere + "/laneLink")),
                )
                for ll in c.findall("laneLink")
            )
            conn = Connection(
                c.get("id", ""),
                rd.text(c, "incomingRoad", cwhere),
                rd.text(c, "connectingRoad", cwhere),
                c.get("contactPoint", "start"),
                links,
            )
            for rid in (conn.incoming, conn.connecting):
                if rid not in roads:
                    raise ConfigError(
                        file=source, field=cwhere, value=rid, expected="a road id of the file"
                    )
            conns.append(conn)
        junctions[jid] = Junction(jid, el.get("name", ""), tuple(conns))
    return Network(source, roads, junctions)


def _road(rd: _Reader, el: ET.Element, where: str) -> Road:
    rid = rd.text(el, "id", where)
    where = f"road[id={rid}]"
    length = rd.num(el, "length", where)
    records: list[Geometry] = []
    for k, g in enumerate(el.findall("planView/geometry")):
        records.append(_geometry(rd, g, f"{where}/planView/geometry[{k}]"))
    if not records:
        raise ConfigError(
            file=rd.source, field=f"{where}/planView", expected="at least one <geometry>"
        )
    offsets = tuple(
        sorted(
            (rd.poly(o, "s", f"{where}/lanes/laneOffset") for o in el.findall("lanes/laneOffset")),
            key=lambda p: p.start,
        )
    )
    sections = [
        _section(rd, sec, f"{where}/lanes/laneSection[{k}]")
        for k, sec in enumerate(el.findall("lanes/laneSection"))
    ]
    if not sections:
        raise ConfigError(
            file=rd.source, field=f"{where}/lanes", expected="at least one <laneSection>"
        )
    sections.sort(key=lambda sec: sec.s)
    road = Road(
        rid,
        el.get("name", ""),
        length,
        el.get("junction", "-1"),
        PlanView(records),
        offsets,
        sections,
        _link(el.find("link/predecessor")),
        _link(el.find("link/successor")),
    )
    for k, obj in enumerate(el.findall("objects/object")):
        if obj.get("type", "").lower() == "crosswalk" or obj.get("name", "").lower() == "crosswalk":
            road.crosswalks.append(_crosswalk(rd, road, obj, f"{where}/objects/object[{k}]"))
    return road


def _link(el: ET.Element | None) -> RoadLink | None:
    if el is None or el.get("elementId") is None:
        return None
    return RoadLink(el.get("elementType", "road"), el.get("elementId", ""), el.get("contactPoint"))


def _geometry(rd: _Reader, g: ET.Element, where: str) -> Geometry:
    pose = (
        rd.num(g, "s", where),
        rd.num(g, "x", where),
        rd.num(g, "y", where),
        rd.num(g, "hdg", where),
        rd.num(g, "length", where),
    )
    if len(g) != 1:
        raise ConfigError(
            file=rd.source, field=where, expected="one of line, arc, spiral, poly3, paramPoly3"
        )
    kind = g[0]
    sub = f"{where}/{kind.tag}"
    if kind.tag == "line":
        return Line(*pose)
    if kind.tag == "arc":
        return Arc(*pose, curvature=rd.num(kind, "curvature", sub))
    if kind.tag == "spiral":
        return Spiral(
            *pose, curv_start=rd.num(kind, "curvStart", sub), curv_end=rd.num(kind, "curvEnd", sub)
        )
    if kind.tag == "poly3":
        return poly3(*pose, *(rd.num(kind, k, sub) for k in "abcd"))
    if kind.tag == "paramPoly3":
        p_range = kind.get("pRange", "normalized")
        if p_range not in ("normalized", "arcLength"):
            raise ConfigError(
                file=rd.source,
                field=f"{sub}@pRange",
                value=p_range,
                expected="normalized | arcLength",
            )
        return ParamPoly3(
            *pose,
            u_coef=tuple(rd.num(kind, f"{k}U", sub) for k in "abcd"),  # type: ignore[arg-type]
            v_coef=tuple(rd.num(kind, f"{k}V", sub) for k in "abcd"),  # type: ignore[arg-type]
            p_max=1.0 if p_range == "normalized" else pose[4],
        )
    raise ConfigError(
        file=rd.source,
        field=sub,
        value=kind.tag,
        expected="one of line, arc, spiral, poly3, paramPoly3",
    )


def _section(rd: _Reader, sec: ET.Element, where: str) -> LaneSection:
    lanes: dict[int, Lane] = {}
    for side in ("left", "center", "right"):
        for el in sec.findall(f"{side}/lane"):
            lid = int(rd.num(el, "id", f"{where}/{side}/lane"))
            lwhere = f"{where}/{side}/lane[id={lid}]"
            if el.find("border") is not None and el.find("width") is None:
                raise ConfigError(
                    file=rd.source,
                    field=f"{lwhere}/border",
                    expected="<width> records (lane <border> records are not supported)",
                )
            widths = tuple(
                sorted(
                    (rd.poly(w, "sOffset", f"{lwhere}/width") for w in el.findall("width")),
                    key=lambda p: p.start,
                )
            )
            pred, succ = el.find("link/predecessor"), el.find("link/successor")
            lanes[lid] = Lane(
                lid,
                el.get("type", "none"),
                widths,
                int(rd.num(pred, "id", f"{lwhere}/link/predecessor")) if pred is not None else None,
                int(rd.num(succ, "id", f"{lwhere}/link/successor")) if succ is not None else None,
            )
    return LaneSection(rd.num(sec, "s", where), lanes)


def _crosswalk(rd: _Reader, road: Road, obj: ET.Element, where: str) -> Crosswalk:
    """A crosswalk's outline in world coordinates: its ``cornerRoad``/``cornerLocal``
    outline, or the ``length`` x ``width`` rectangle about its origin."""
    s, t = rd.num(obj, "s", where), rd.num(obj, "t", where, 0.0)
    ox, oy, road_h = road.at(s, t)
    hdg = road_h + rd.num(obj, "hdg", where, 0.0)
    cos_h, sin_h = math.cos(hdg), math.sin(hdg)

    def local(u: float, v: float) -> tuple[float, float]:
        return ox + u * cos_h - v * sin_h, oy + u * sin_h + v * cos_h

    corners: list[tuple[float, float]] = []
    outline = obj.find("outline")
    if outline is None:
        outline = obj.find("outlines/outline")
    if outline is not None:
        for c in outline:
            if c.tag == "cornerRoad":
                x, y, _ = road.at(
                    rd.num(c, "s", where + "/cornerRoad"), rd.num(c, "t", where + "/cornerRoad")
                )
                corners.append((x, y))
            elif c.tag == "cornerLocal":
                u, v = (
                    rd.num(c, "u", where + "/cornerLocal"),
                    rd.num(c, "v", where + "/cornerLocal"),
                )
                corners.append(
                    (
                        ox + u * math.cos(hdg) - v * math.sin(hdg),
                        oy + u * math.sin(hdg) + v * math.cos(hdg),
                    )
                )
    if len(corners) < 3:
        length, width = rd.num(obj, "length", where), rd.num(obj, "width", where)
        corners = [
            (ox + u * math.cos(hdg) - v * math.sin(hdg), oy + u * math.sin(hdg) + v * math.cos(hdg))
            for u, v in (
                (-length / 2, -width / 2),
                (length / 2, -width / 2),
                (length / 2, width / 2),
                (-length / 2, width / 2),
            )
        ]
    area = sum(
        a[0] * b[1] - b[0] * a[1] for a, b in zip(corners, corners[1:] + corners[:1], strict=True)
    )
    if area < 0:
        corners = corners[::-1]
    return Crosswalk(obj.get("id", ""), road.id, tuple(corners))
