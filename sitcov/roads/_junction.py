"""A junction of an OpenDRIVE network as the data of a sitcov map (``layout: lanes``).

Legs are the roads that meet the junction; routes are lane-level: for every movement
(entry leg X to exit leg Y) one connecting lane of the junction, with the incoming lane
followed ``extension`` metres back up its road and the outgoing lane as far down its road
(through neighbouring junctions on their straightest connecting lane where a road is
shorter). The map frame has its origin at the junction centre (the mean of the legs'
mouths) and is turned so that leg B points south (-y), as on the shipped maps; ``frame``
in the map data says how to go back to the file's coordinates. The format is in
``docs/roads.md``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path as FsPath

import numpy as np

from sitcov._geometry import convex_hull
from sitcov.errors import ConfigError
from sitcov.roads._opendrive import Crosswalk, Junction, Network
from sitcov.roads._walk import Stretch, cut_polyline, inside_section, lane_at_end, sample_lane, walk

#: How far routes run up and down the legs from the junction's mouths [m] (the shipped
#: maps' legs: 110 m from the centre, mouths at 12 m).
DEFAULT_EXTENSION = 100.0
#: Length of the drivable-area pieces along a road [m].
PIECE = 2.0
#: Default spawn distances from the centre [m]: the ego as on the shipped maps (Town03's
#: 72 m), the adversary 25 m (within Town03's 20-35 m).
EGO_SPAWN, OV_SPAWN = 72.0, 25.0
#: A mouth closer to the centre than a lane width is moved out to a lane width plus this [m]
#: (junctions where legs meet at a point, such as lane splits).
MIN_MOUTH_MARGIN = 0.5


@dataclass(frozen=True)
class LegInfo:
    """A road meeting the junction: its id, which end touches the junction, the outward
    heading [rad] and mouth point (reference line at the junction) in file coordinates,
    its driving lanes towards (``lanes_in``) and away from (``lanes_out``) the junction."""

    road: str
    contact: str
    heading: float
    mouth: tuple[float, float]
    lanes_in: tuple[int, ...]
    lanes_out: tuple[int, ...]
    name: str = ""


def junction_legs(net: Network, junction_id: str) -> list[LegInfo]:
    """Every road meeting junction ``junction_id``, named (see :func:`leg_names`)."""
    junction = _junction(net, junction_id)
    roads: dict[str, LegInfo] = {}
    for conn in junction.connections:
        for rid in (conn.incoming, _outgoing(net, conn.connecting, conn.contact_point)):
            if rid is None or rid in roads or rid not in net.roads:
                continue
            road = net.roads[rid]
            at_end = road.successor is not None and road.successor.element_id == junction_id
            s = road.length if at_end else 0.0
            x, y, h = road.at(s, 0.0)
            sec = road.sections[-1 if at_end else 0]
            right = tuple(i for i in sec.lane_ids(-1) if sec.lanes[i].drivable)
            left = tuple(i for i in sec.lane_ids(1) if sec.lanes[i].drivable)
            roads[rid] = LegInfo(
                rid,
                "end" if at_end else "start",
                h + math.pi if at_end else h,
                (x, y),
                right if at_end else left,
                left if at_end else right,
            )
    legs = list(roads.values())
    names = leg_names([leg.heading for leg in legs])
    return [LegInfo(**{**leg.__dict__, "name": n}) for leg, n in zip(legs, names, strict=True)]


def leg_names(headings: list[float]) -> list[str]:
    """Leg names from the outward headings [rad]: a T's stem is ``B`` and its arms ``L``/
    ``R`` as seen from the stem (the paper's names); four legs are ``B`` (nearest south),
    then ``R``, ``T``, ``L`` counter-clockwise; other counts ``A``, ``B``, ... counter-
    clockwise from the leg nearest south."""
    n = len(headings)
    south = -0.5 * math.pi
    if n == 3:
        pairs = [(i, j) for i in range(3) for j in range(i + 1, 3)]
        i, j = min(
            pairs,
            key=lambda p: abs(
                abs(math.remainder(headings[p[0]] - headings[p[1]], math.tau)) - math.pi
            ),
        )
        stem = ({0, 1, 2} - {i, j}).pop()
        inward = headings[stem] + math.pi
        names = [""] * 3
        names[stem] = "B"
        for k in (i, j):
            left = math.sin(headings[k] - inward) > 0
            names[k] = "L" if left else "R"
        if names[i] == names[j]:  # degenerate: both on one side
            names[i], names[j] = ("L", "R") if headings[i] > headings[j] else ("R", "L")
        return names
    order = sorted(range(n), key=lambda k: (headings[k] - south) % math.tau)
    letters = "BRTL" if n == 4 else "ABCDEFGHIJKMNOPQSUVWXYZ"
    names = [""] * n
    for rank, k in enumerate(order):
        names[k] = letters[rank]
    return names


def list_junctions(net: Network) -> list[dict]:
    """Every junction of the file: id, name, centre [m, file coordinates] and its legs
    (road, leg name, outward heading [deg], driving lanes in and out)."""
    out = []
    for jid, junction in net.junctions.items():
        try:
            legs = junction_legs(net, jid)
        except ConfigError:
            continue
        centre = junction_centre(legs) if legs else (math.nan, math.nan)
        out.append(
            {
                "id": jid,
                "name": junction.name,
                "centre": [round(float(centre[0]), 2) + 0.0, round(float(centre[1]), 2) + 0.0],
                "legs": [
                    {
                        "name": leg.name,
                        "road": leg.road,
                        "heading_deg": round(math.degrees(leg.heading) % 360.0, 1),
                        "lanes_in": len(leg.lanes_in),
                        "lanes_out": len(leg.lanes_out),
                    }
                    for leg in legs
                ],
            }
        )
    return out


def junction_centre(legs: list[LegInfo]) -> np.ndarray:
    """Where the legs' axes meet [m, file coordinates]: the point nearest (least squares)
    to every line through a leg's mouth along its heading; the mean of the mouths when the
    axes are (nearly) parallel or meet more than twice the mouths' spread away."""
    a, b = np.zeros((2, 2)), np.zeros(2)
    for leg in legs:
        n = np.array([-math.sin(leg.heading), math.cos(leg.heading)])
        a += np.outer(n, n)
        b += np.outer(n, n) @ np.asarray(leg.mouth)
    mean = np.mean([leg.mouth for leg in legs], axis=0)
    if np.linalg.cond(a) > 1e6:
        return mean
    point = np.linalg.solve(a, b)
    # nearly parallel axes (a lane split, a bend) meet far away: the mouths' mean instead
    spread = max(float(np.hypot(*(np.asarray(leg.mouth) - mean))) for leg in legs)
    return point if float(np.hypot(*(point - mean))) <= max(2.0 * spread, 5.0) else mean


def nearest_junction(net: Network, x: float, y: float) -> str:
    """The id of the junction whose centre is nearest (x, y) [m, file coordinates]."""
    rows = list_junctions(net)
    if not rows:
        raise ConfigError(file=net.source, field="junction", expected="a file with junctions")
    return min(rows, key=lambda r: math.hypot(r["centre"][0] - x, r["centre"][1] - y))["id"]


def _junction(net: Network, junction_id: str) -> Junction:
    if junction_id not in net.junctions:
        known = sorted(net.junctions, key=lambda k: (len(k), k))
        raise ConfigError(
            file=net.source,
            field="junction",
            value=junction_id,
            expected=f"a junction id of the file ({', '.join(known[:40])}"
            + (", ..." if len(known) > 40 else "")
            + ")",
        )
    return net.junctions[junction_id]


def _outgoing(net: Network, connecting: str, contact: str) -> str | None:
    road = net.roads.get(connecting)
    if road is None:
        return None
    link = road.successor if contact == "start" else road.predecessor
    return link.element_id if link is not None and link.element_type == "road" else None


@dataclass(frozen=True)
class _Route:
    """One movement's lanes before, through and after the junction (file coordinates)."""

    entry: str
    exit: str
    inbound: np.ndarray
    through: np.ndarray
    outbound: np.ndarray
    lanes: str


def junction_map_data(
    net: Network,
    junction_id: str,
    *,
    extension: float = DEFAULT_EXTENSION,
    legs: list[str] | None = None,
    name: str | None = None,
    mouth_crosswalks: bool = False,
) -> dict:
    """The data of a sitcov map (``layout: lanes``) for one junction of ``net``.

    Args:
        net: the parsed file.
        junction_id: the junction's id in the file.
        extension: how far routes run along the legs beyond the mouths [m].
        legs: keep only these legs (names as :func:`junction_legs` gives them); all by default.
        name: the map's name (default ``<file stem>-junction-<id>``).
        mouth_crosswalks: give every kept leg without a crosswalk object, but with a
            sidewalk on both sides at the junction, a crossing like the shipped maps' (3 m
            wide, from 1 m outside the mouth, kerb to kerb).

    Raises:
        ConfigError: unknown junction or leg, or a junction without two connected legs.
    """
    all_legs = junction_legs(net, junction_id)
    centre = junction_centre(all_legs)
    by_name = {leg.name: leg for leg in all_legs}
    if legs:
        unknown = [n for n in legs if n not in by_name]
        if unknown:
            raise ConfigError(
                file=net.source,
                field=f"junction {junction_id} legs",
                value=unknown[0],
                expected=f"one of {sorted(by_name)}",
            )
        by_name = {n: by_name[n] for n in legs}
    by_road = {leg.road: leg for leg in by_name.values()}
    rot = (-0.5 * math.pi - by_name["B"].heading) if "B" in by_name else 0.0
    cos_r, sin_r = math.cos(rot), math.sin(rot)

    def to_map(p: np.ndarray) -> np.ndarray:
        d = np.asarray(p, dtype=float).reshape(-1, 2) - centre
        return np.column_stack(
            [cos_r * d[:, 0] - sin_r * d[:, 1], sin_r * d[:, 0] + cos_r * d[:, 1]]
        )

    routes, stretches = _routes(net, junction_id, by_road, extension)
    if len({r.entry for r in routes}) < 1 or len(routes) < 2:
        raise ConfigError(
            file=net.source,
            field=f"junction {junction_id}",
            expected="a junction with at least two movements between its legs",
        )
    used = {r.entry for r in routes} | {r.exit for r in routes}
    lane_width = _median_lane_width(net, by_name.values())
    # the leg model wants mouths beyond a lane width: distances along a leg start there
    mouths = {
        n: max(float(np.hypot(*(by_name[n].mouth - centre))), lane_width + MIN_MOUTH_MARGIN)
        for n in used
    }
    lengths: dict[str, float] = {}
    for n in used:
        lines = [r.inbound for r in routes if r.entry == n] + [
            r.outbound for r in routes if r.exit == n
        ]
        lengths[n] = min([extension] + [_length(line) for line in lines])
    for n, avail in lengths.items():
        if avail < 20.0:
            raise ConfigError(
                file=net.source,
                field=f"junction {junction_id} leg {n} (road {by_name[n].road})",
                value=round(avail, 1),
                expected="lanes at least 20 m long beyond the junction",
            )
    map_routes = {}
    for r in routes:
        inbound = _cut_from_end(r.inbound, lengths[r.entry])
        outbound = _cut_start(r.outbound, lengths[r.exit])
        map_routes[f"{r.entry}-{r.exit}"] = {
            "lanes": r.lanes,
            "in": _rounded(to_map(inbound)),
            "through": _rounded(to_map(r.through)),
            "out": _rounded(to_map(outbound)),
        }
    sidewalk_width = _median_sidewalk_width(net, by_name.values())
    # the junction box: every connecting road of the junction, and the convex hull of
    # the legs' drivable edges at their mouths (as the shipped maps' junction area)
    stretches += [
        Stretch(r.id, 0.0, r.length) for r in net.roads.values() if r.junction == junction_id
    ]
    polygons, sidewalks = _surfaces(net, stretches)
    polygons.append(_mouth_hull(net, all_legs))
    extra = _mouth_crosswalks(net, by_name) if mouth_crosswalks else {}
    crosswalks = _crosswalks(net, junction_id, by_name, centre, mouths, lengths, extra)
    leg_data = {}
    for n in sorted(used):
        heading = math.degrees(by_name[n].heading + rot) % 360.0
        entry = {
            "heading_deg": round(heading, 3),
            "length": round(mouths[n] + lengths[n], 3),
            "mouth": round(mouths[n], 3),
        }
        if n in crosswalks:
            entry["crosswalk"] = crosswalks[n]["leg"]
        leg_data[n] = entry
    entries = sorted({r.entry for r in routes})
    exits = sorted({r.exit for r in routes})
    max_mouth = max(mouths.values())
    goal = min(35.0, min(mouths[n] + lengths[n] for n in exits) - 2.0)
    goal = max(goal, max_mouth + 3.0)
    spawns = {
        "ego": {n: round(min(EGO_SPAWN, mouths[n] + lengths[n] - 2.0), 3) for n in entries},
        "ov": {
            n: round(max(mouths[n] + 3.0, min(OV_SPAWN, mouths[n] + lengths[n] - 2.0)), 3)
            for n in entries
        },
    }
    stem = FsPath(net.source).stem
    return {
        "format": 2,
        "name": name or f"{stem}-junction-{junction_id}",
        "description": f"junction {junction_id} of {FsPath(net.source).name} (OpenDRIVE import), "
        f"legs " + ", ".join(f"{n} = road {by_name[n].road}" for n in sorted(used)),
        "layout": "lanes",
        "lane_width": round(lane_width, 3),
        "sidewalk_width": round(sidewalk_width, 3),
        "bike_offset": round(min(1.2, 0.5 * lane_width - 0.3), 3),
        "legs": leg_data,
        "spawns": spawns,
        "goal_distance": round(goal, 3),
        "lanes": {
            "source": {
                "file": FsPath(net.source).name,
                "junction": junction_id,
                "extension": extension,
            },
            "frame": {
                "origin": [round(float(centre[0]), 4), round(float(centre[1]), 4)],
                "rotation_deg": round(math.degrees(rot), 6),
            },
            "routes": map_routes,
            "road_polygons": [_rounded(to_map(np.array(p))) for p in polygons],
            "sidewalks": [_rounded(to_map(np.array(p))) for p in sidewalks],
            "crosswalks": {
                n: _rounded(to_map(np.array(c["outline"]))) for n, c in crosswalks.items()
            },
        },
    }


def _routes(
    net: Network, junction_id: str, by_road: dict[str, LegInfo], extension: float
) -> tuple[list[_Route], list[Stretch]]:
    """One lane-level route per movement between kept legs (see :func:`junction_map_data`)."""
    candidates: dict[tuple[str, str], list[tuple[int, object]]] = {}
    for conn in net.junctions[junction_id].connections:
        x = by_road.get(conn.incoming)
        out_road = _outgoing(net, conn.connecting, conn.contact_point)
        y = by_road.get(out_road or "")
        if x is None or y is None or x.road == y.road:
            continue
        for link in conn.lane_links:
            if link.from_lane in x.lanes_in:
                candidates.setdefault((x.name, y.name), []).append((link.from_lane, (conn, link)))
    routes: list[_Route] = []
    stretches: list[Stretch] = []
    for (a, b), options in sorted(candidates.items()):
        x = next(leg for leg in by_road.values() if leg.name == a)
        y = next(leg for leg in by_road.values() if leg.name == b)
        turn = math.remainder(y.heading - (x.heading + math.pi), math.tau)
        # a left turn from the innermost lane, straight on and right turns from the outermost
        pick = min if turn > 0.3 else max
        lane_in, (conn, link) = pick(options, key=lambda o: abs(o[0]))
        c = net.roads[conn.connecting]
        forward = conn.contact_point != "end"
        through, lane_c = sample_lane(
            c, link.to_lane, 0.0 if forward else c.length, c.length if forward else 0.0
        )
        if lane_c is None or len(through) < 2:
            continue
        lane_out = lane_at_end(c, lane_c, forward)
        if lane_out is None:
            continue
        inbound, s_in = walk(net, x.road, lane_in, x.contact == "end", extension)
        outbound, s_out = walk(net, y.road, lane_out, y.contact == "end", extension)
        if len(inbound) < 2 or len(outbound) < 2:
            continue
        stretches += s_in + s_out + [Stretch(c.id, 0.0, c.length)]
        routes.append(
            _Route(
                a,
                b,
                inbound[::-1],
                through,
                outbound,
                f"road {x.road} lane {lane_in} -> road {c.id} lane {link.to_lane} "
                f"-> road {y.road} lane {lane_out}",
            )
        )
    return routes, stretches


def _length(line: np.ndarray) -> float:
    return float(np.hypot(*np.diff(line, axis=0).T).sum()) if len(line) > 1 else 0.0


def _cut_start(line: np.ndarray, length: float) -> np.ndarray:
    return cut_polyline(line, length)


def _cut_from_end(line: np.ndarray, length: float) -> np.ndarray:
    return _cut_start(line[::-1], length)[::-1]


def _rounded(points: np.ndarray) -> list[list[float]]:
    return [[round(float(x), 3), round(float(y), 3)] for x, y in points]


def _merged(stretches: list[Stretch]) -> dict[str, list[tuple[float, float]]]:
    """Per road, the union of the s ranges crossed."""
    out: dict[str, list[tuple[float, float]]] = {}
    for st in sorted(stretches, key=lambda s: (s.road, s.s0)):
        ranges = out.setdefault(st.road, [])
        if ranges and st.s0 <= ranges[-1][1] + 1e-6:
            ranges[-1] = (ranges[-1][0], max(ranges[-1][1], st.s1))
        else:
            ranges.append((st.s0, st.s1))
    return out


def _surfaces(net: Network, stretches: list[Stretch]) -> tuple[list[list], list[list]]:
    """Convex road pieces (every driving lane of a road, side to side) and sidewalk pieces
    along the road stretches the routes cross, :data:`PIECE` metres long."""
    road_pieces: list[list] = []
    walk_pieces: list[list] = []
    for rid, ranges in _merged(stretches).items():
        road = net.roads[rid]
        for s0, s1 in ranges:
            for i, sec in enumerate(road.sections):
                a, b = max(s0, sec.s), min(s1, road.section_end(i))
                if b - a < 1e-6:
                    continue
                n = max(1, math.ceil((b - a) / PIECE))
                s = inside_section(road, i, np.linspace(a, b, n + 1))
                x, y, h = road.plan_view.evaluate(s)
                nx, ny = -np.sin(h), np.cos(h)
                drivable = [lid for lid, lane in sec.lanes.items() if lid and lane.drivable]
                if drivable:
                    ts = [t for lid in drivable for t in road.borders(i, lid, s)]
                    lo, hi = np.min(ts, axis=0), np.max(ts, axis=0)
                    road_pieces += _quads(x, y, nx, ny, lo, hi)
                for lid, lane in sec.lanes.items():
                    if lid and lane.type == "sidewalk":
                        inner, outer = road.borders(i, lid, s)
                        walk_pieces += _quads(
                            x, y, nx, ny, np.minimum(inner, outer), np.maximum(inner, outer)
                        )
    return road_pieces, walk_pieces


def _mouth_hull(net: Network, legs: list[LegInfo]) -> list[tuple[float, float]]:
    """Convex hull of the outermost drivable lane borders of every leg at the junction."""
    corners = []
    for leg in legs:
        road = net.roads[leg.road]
        i = len(road.sections) - 1 if leg.contact == "end" else 0
        s = np.array([road.length if leg.contact == "end" else 0.0])
        ts = [
            t[0]
            for lid, lane in road.sections[i].lanes.items()
            if lid and lane.drivable
            for t in road.borders(i, lid, inside_section(road, i, s))
        ]
        if ts:
            for t in (min(ts), max(ts)):
                x, y, _ = road.at(float(s[0]), float(t))
                corners.append((x, y))
    return convex_hull(corners)


def _quads(x, y, nx, ny, lo, hi) -> list[list[tuple[float, float]]]:
    out = []
    for k in range(len(x) - 1):
        pts = [
            (x[k] + lo[k] * nx[k], y[k] + lo[k] * ny[k]),
            (x[k + 1] + lo[k + 1] * nx[k + 1], y[k + 1] + lo[k + 1] * ny[k + 1]),
            (x[k + 1] + hi[k + 1] * nx[k + 1], y[k + 1] + hi[k + 1] * ny[k + 1]),
            (x[k] + hi[k] * nx[k], y[k] + hi[k] * ny[k]),
        ]
        if hi[k] - lo[k] < 1e-3 and hi[k + 1] - lo[k + 1] < 1e-3:
            continue
        out.append([(float(a), float(b)) for a, b in pts])
    return out


def _median_lane_width(net: Network, legs) -> float:
    widths = []
    for leg in legs:
        road = net.roads[leg.road]
        i = len(road.sections) - 1 if leg.contact == "end" else 0
        s = np.array([road.length if leg.contact == "end" else 0.0])
        for lid in leg.lanes_in + leg.lanes_out:
            inner, outer = road.borders(i, lid, s)
            widths.append(abs(float(outer[0] - inner[0])))
    return float(np.median(widths)) if widths else 3.5


def _median_sidewalk_width(net: Network, legs) -> float:
    widths = []
    for leg in legs:
        road = net.roads[leg.road]
        i = len(road.sections) - 1 if leg.contact == "end" else 0
        s = np.array([road.length if leg.contact == "end" else 0.0])
        for lid, lane in road.sections[i].lanes.items():
            if lid and lane.type == "sidewalk":
                inner, outer = road.borders(i, lid, s)
                widths.append(abs(float(outer[0] - inner[0])))
    return float(np.median(widths)) if widths else 2.0


#: A crossing added at a leg's mouth: from this far outside the junction [m], this wide [m]
#: (the shipped maps' crosswalks: offset 1 m, width 3 m).
MOUTH_CROSSWALK = (1.0, 3.0)


def _mouth_crosswalks(net: Network, by_name: dict[str, LegInfo]) -> dict[str, list[Crosswalk]]:
    """Per road, crossings at the mouths of legs with sidewalks on both sides: across every
    lane between the two sidewalks, :data:`MOUTH_CROSSWALK` from the junction."""
    out: dict[str, list[Crosswalk]] = {}
    offset, width = MOUTH_CROSSWALK
    for leg in by_name.values():
        road = net.roads[leg.road]
        at_end = leg.contact == "end"
        i = len(road.sections) - 1 if at_end else 0
        sec = road.sections[i]
        walks = [lid for lid, lane in sec.lanes.items() if lid and lane.type == "sidewalk"]
        if not (any(lid > 0 for lid in walks) and any(lid < 0 for lid in walks)):
            continue
        s_near = road.length - offset if at_end else offset
        s_far = s_near - width if at_end else s_near + width
        if min(s_near, s_far) < 0.0 or max(s_near, s_far) > road.length:
            continue
        s = inside_section(road, i, np.array([s_near, s_far]))
        inner = [road.borders(i, lid, s)[0] for lid in walks]
        lo = max((t for t in inner if t[0] < 0), key=lambda t: t[0])  # right kerb
        hi = min((t for t in inner if t[0] > 0), key=lambda t: t[0])  # left kerb
        corners = [
            road.at(float(s[k]), float(t[k]))[:2] for k, t in ((0, lo), (1, lo), (1, hi), (0, hi))
        ]
        ring = zip(corners, corners[1:] + corners[:1], strict=True)
        if sum(a[0] * b[1] - b[0] * a[1] for a, b in ring) < 0:
            corners = corners[::-1]
        out.setdefault(road.id, []).append(Crosswalk(f"mouth-{leg.name}", road.id, tuple(corners)))
    return out


def _crosswalks(net, junction_id, by_name, centre, mouths, lengths, extra=None) -> dict[str, dict]:
    """The crosswalk object nearest the junction on each leg (on the leg's road or a
    connecting road of the junction; ``extra`` adds crossings per road), with its place
    along the leg for the map."""
    found: dict[str, tuple[float, dict]] = {}
    for road in net.roads.values():
        near = road.junction == junction_id or road.id in {leg.road for leg in by_name.values()}
        if not near:
            continue
        for cw in road.crosswalks + (extra or {}).get(road.id, []):
            pts = np.array(cw.outline)
            c = pts.mean(axis=0) - centre
            best = None
            for n, leg in by_name.items():
                u = np.array([math.cos(leg.heading), math.sin(leg.heading)])
                along, across = float(c @ u), abs(float(c[0] * u[1] - c[1] * u[0]))
                if along > 0 and across < 0.5 * along + 8.0 and (best is None or across < best[1]):
                    best = (n, across, along, u)
            if best is None:
                continue
            n, _, along, u = best
            extent = pts @ u - centre @ u
            width = float(extent.max() - extent.min())
            offset = max(0.0, float(extent.min()) - mouths.get(n, 0.0))
            if n not in mouths or mouths[n] + offset + width > mouths[n] + lengths[n] - 10.0:
                continue
            if n not in found or along < found[n][0]:
                found[n] = (
                    along,
                    {"outline": pts, "leg": {"offset": round(offset, 3), "width": round(width, 3)}},
                )
    return {n: v[1] for n, v in found.items()}
