"""Map layouts beyond the leg junction: a single-lane roundabout and an on-ramp merge.

Both keep the leg model where it fits (straight legs with an inbound and an outbound lane
from the mouth to the end, spawn and goal distances from the centre along them) and
replace what lies between the mouths: a ring with entry and exit curves, or an
acceleration lane and a taper. Lanes are ``Path`` polylines, the lane graph links them,
and every ``JunctionMap`` query (routes, scenarios, conflicts, drivable area, render
geometry) works unchanged on top. Formats: ``docs/embedded.md``.
"""

from __future__ import annotations

import math
from typing import Any

from sitcov.errors import ConfigError
from sitcov.sim.embedded._map import (
    LAYOUTS,
    ROUTE_STEP,
    JunctionMap,
    _ccw,
    _connector,
    _number,
    _straight,
)
from sitcov.sim.embedded._path import Path, wrap_angle

#: Length of the road-surface pieces along curved lanes [m] (each piece is convex).
PIECE = 2.0
#: Sectors of the drawn ring.
RING_SECTORS = 96


def _section(section: Any, source: str, name: str, keys: dict[str, float | None]) -> dict:
    """A layout section: known keys only, numbers > 0, defaults where given."""
    if not isinstance(section, dict) or set(section) - set(keys):
        raise ConfigError(
            file=source, field=name, value=section, expected=f"a mapping with {', '.join(keys)}"
        )
    out = {}
    for key, default in keys.items():
        if key not in section and default is not None:
            out[key] = default
        else:
            out[key] = _number(section, key, source, f"{name}.", 0.0)
    return out


def _checked_connector(
    p0: tuple[float, float], h0: float, p1: tuple[float, float], h1: float, what: str, file: str
) -> Path:
    """A tangent straight-arc-straight curve; ConfigError if the poses do not allow one."""
    path = _connector(p0, h0, p1, h1)
    if abs(wrap_angle(path.hs[-2] - h1)) > math.radians(5.0):  # a chord of the arc
        raise ConfigError(
            file=file, field=what, value=None, expected="geometry that allows a tangent curve"
        )
    return path


def _strip(path: Path, half: float) -> list[list[tuple[float, float]]]:
    """Convex quadrilaterals covering ``half`` either side of ``path``, ~PIECE long each.

    Neighbouring pieces share the edge between them (along the bisector of their
    directions), so a curve is covered without gaps on its outer side.
    """
    n = max(1, math.ceil(path.length / PIECE))
    marks = [path.point_at(path.length * k / n)[:2] for k in range(n + 1)]
    dirs = [math.atan2(b[1] - a[1], b[0] - a[0]) for a, b in zip(marks, marks[1:], strict=False)]
    edges = []
    for k, (x, y) in enumerate(marks):
        h_in, h_out = dirs[max(k - 1, 0)], dirs[min(k, len(dirs) - 1)]
        half_turn = 0.5 * wrap_angle(h_out - h_in)
        h = h_in + half_turn
        r = half / math.cos(half_turn)
        edges.append(
            ((x + r * math.sin(h), y - r * math.cos(h)), (x - r * math.sin(h), y + r * math.cos(h)))
        )
    return [_ccw([a[0], b[0], b[1], a[1]]) for a, b in zip(edges, edges[1:], strict=False)]


def _arc(radius: float, phi0: float, phi1: float) -> Path:
    """Counter-clockwise arc of the circle ``radius`` about the origin from ``phi0`` to
    ``phi1`` [rad] (``phi1 > phi0``), points at most half a route step apart."""
    n = max(2, math.ceil((phi1 - phi0) * radius / (0.5 * ROUTE_STEP)))
    return Path.from_points(
        [
            (
                radius * math.cos(phi0 + (phi1 - phi0) * k / n),
                radius * math.sin(phi0 + (phi1 - phi0) * k / n),
            )
            for k in range(n + 1)
        ]
    )


class RoundaboutMap(JunctionMap):
    """A single-lane roundabout, circulating counter-clockwise (right-hand traffic).

    Section ``roundabout: {radius: m, entry_angle_deg: deg}``: the ring lane's centre-line
    radius, and how far round the ring (from each leg's axis) vehicles join it after
    entering and leave it before exiting. Route ``X-Y``: leg X's inbound lane, a right-hand
    entry curve onto the ring, the ring counter-clockwise, a right-hand exit curve, leg Y's
    outbound lane.
    """

    LAYOUT = "roundabout"

    def _parse_layout(self, section: Any) -> None:
        super()._parse_layout(section)
        spec = _section(
            section, self.source, "roundabout", {"radius": None, "entry_angle_deg": 30.0}
        )
        self.radius = spec["radius"]
        self.entry_angle = math.radians(spec["entry_angle_deg"])
        angles = sorted(leg.heading % (2 * math.pi) for leg in self.legs.values())
        gaps = [b - a for a, b in zip(angles, angles[1:] + [angles[0] + 2 * math.pi], strict=True)]
        if not 0.0 < 2.0 * self.entry_angle < min(gaps):
            raise ConfigError(
                file=self.source,
                field="roundabout.entry_angle_deg",
                value=spec["entry_angle_deg"],
                expected=f"less than half the smallest angle between legs "
                f"({math.degrees(min(gaps)) / 2:.0f} degrees)",
            )
        for leg in self.legs.values():
            if not leg.mouth > self.radius + self.lane_width:
                raise ConfigError(
                    file=self.source,
                    field=f"legs.{leg.name}.mouth",
                    value=leg.mouth,
                    expected=f"more than the ring radius + a lane width "
                    f"({self.radius + self.lane_width:g} m)",
                )

    def _ring_nodes(self) -> list[tuple[float, str, str]]:
        """(angle, "exit"|"entry", leg) around the ring, counter-clockwise from 0."""
        nodes = []
        for leg in self.legs.values():
            nodes.append(((leg.heading - self.entry_angle) % (2 * math.pi), "exit", leg.name))
            nodes.append(((leg.heading + self.entry_angle) % (2 * math.pi), "entry", leg.name))
        return sorted(nodes)

    def _ring_point(self, phi: float) -> tuple[float, float]:
        return self.radius * math.cos(phi), self.radius * math.sin(phi)

    def _build_lanes(self) -> dict[str, Path]:
        lanes = _leg_lanes(self, self.legs.values())
        for leg in self.legs.values():
            start = lanes[f"{leg.name}.in"]
            phi = leg.heading + self.entry_angle
            lanes[f"{leg.name}.enter"] = _checked_connector(
                (start.xs[-1], start.ys[-1]),
                leg.heading + math.pi,
                self._ring_point(phi),
                phi + 0.5 * math.pi,
                f"legs.{leg.name} (entry curve)",
                self.source,
            )
            end = lanes[f"{leg.name}.out"]
            phi = leg.heading - self.entry_angle
            lanes[f"{leg.name}.leave"] = _checked_connector(
                self._ring_point(phi),
                phi + 0.5 * math.pi,
                (end.xs[0], end.ys[0]),
                leg.heading,
                f"legs.{leg.name} (exit curve)",
                self.source,
            )
        nodes = self._ring_nodes()
        for i, (phi0, _, _) in enumerate(nodes):
            phi1 = nodes[(i + 1) % len(nodes)][0]
            phi1 += 2 * math.pi if phi1 <= phi0 else 0.0
            lanes[f"ring.{i}"] = _arc(self.radius, phi0, phi1)
        return lanes

    def _build_graph(self) -> dict[str, tuple[str, ...]]:
        graph: dict[str, list[str]] = {lane: [] for lane in self._lanes}
        nodes = self._ring_nodes()
        for i, (_, role, leg) in enumerate(nodes):
            nxt = (i + 1) % len(nodes)
            graph[f"ring.{i}"].append(f"ring.{nxt}")
            if nodes[nxt][1] == "exit":
                graph[f"ring.{i}"].insert(0, f"{nodes[nxt][2]}.leave")
            if role == "entry":
                graph[f"{leg}.in"].append(f"{leg}.enter")
                graph[f"{leg}.enter"].append(f"ring.{i}")
        for leg in self.legs:
            graph[f"{leg}.leave"].append(f"{leg}.out")
        return {k: tuple(v) for k, v in graph.items()}

    def render_geometry(self) -> dict[str, Any]:
        """Legs as at a junction, the ring as sectors of an annulus, entry/exit curves as
        strips; kerbs include the central island."""
        geo = self._legs_geometry()
        geo.pop("mouth_corners")
        half = 0.5 * self.lane_width
        r_in, r_out = self.radius - half, self.radius + half
        for k in range(RING_SECTORS):
            a0, a1 = 2 * math.pi * k / RING_SECTORS, 2 * math.pi * (k + 1) / RING_SECTORS
            geo["road_polygons"].append(
                [
                    (r_in * math.cos(a0), r_in * math.sin(a0)),
                    (r_out * math.cos(a0), r_out * math.sin(a0)),
                    (r_out * math.cos(a1), r_out * math.sin(a1)),
                    (r_in * math.cos(a1), r_in * math.sin(a1)),
                ]
            )
        for leg in self.legs:
            for lane in (f"{leg}.enter", f"{leg}.leave"):
                geo["road_polygons"] += _strip(self._lanes[lane], half)
                path = self._lanes[lane]
                geo["kerbs"].append(
                    list(_offset_points(path, half if lane.endswith("enter") else -half))
                )
        island = [
            (
                r_in * math.cos(2 * math.pi * k / RING_SECTORS),
                r_in * math.sin(2 * math.pi * k / RING_SECTORS),
            )
            for k in range(RING_SECTORS + 1)
        ]
        geo["kerbs"].append(island)
        return geo


def _offset_points(path: Path, offset: float) -> list[tuple[float, float]]:
    """The points of ``path`` moved ``offset`` to the left of each segment [m]."""
    return [
        (x - offset * math.sin(h), y + offset * math.cos(h))
        for x, y, h in zip(path.xs, path.ys, path.hs, strict=True)
    ]


def _leg_lanes(jmap: JunctionMap, legs: Any) -> dict[str, Path]:
    """Inbound and outbound straight lanes of two-way legs, right-hand traffic."""
    half = jmap.lane_width / 2.0
    lanes: dict[str, Path] = {}
    for leg in legs:
        dx, dy, nx, ny = jmap._axis(leg)
        lanes[f"{leg.name}.in"] = _straight(
            (dx * leg.length + nx * half, dy * leg.length + ny * half),
            (dx * leg.mouth + nx * half, dy * leg.mouth + ny * half),
        )
        lanes[f"{leg.name}.out"] = _straight(
            (dx * leg.mouth - nx * half, dy * leg.mouth - ny * half),
            (dx * leg.length - nx * half, dy * leg.length - ny * half),
        )
    return lanes


class MergeMap(JunctionMap):
    """An on-ramp joining a one-lane, one-way main road from the right.

    Section ``merge: {main_in: W, main_out: E, ramp: M, taper_length: m, ramp_radius: m}``.
    The main road runs from leg ``main_in`` straight through to leg ``main_out`` (opposite
    headings); its lane centre is the legs' axis. The origin is the nose of the merge:
    there the ramp lane runs parallel, one lane width right of the main lane, and over
    ``taper_length`` it shifts onto the main lane (a cosine taper). Before the nose the
    ramp is a parallel acceleration lane, before that a curve of ``ramp_radius`` from the
    ramp leg's heading. Distances along the ramp leg are from the nose along the ramp lane:
    its ``mouth`` is where the curve begins (so the acceleration lane is the mouth minus
    the curve's length). Only the two main legs and the ramp; no crosswalks.
    """

    LAYOUT = "merge"

    def _parse_layout(self, section: Any) -> None:
        names = {"main_in", "main_out", "ramp"}
        if not isinstance(section, dict) or not names <= set(section):
            raise ConfigError(
                file=self.source,
                field="merge",
                value=section,
                expected="a mapping with main_in, main_out, ramp (leg names), taper_length, "
                "ramp_radius",
            )
        roles = {k: section[k] for k in names}
        if sorted(map(str, roles.values())) != sorted(self.legs):
            raise ConfigError(
                file=self.source,
                field="merge",
                value=roles,
                expected=f"main_in, main_out and ramp naming the legs {sorted(self.legs)} "
                "once each",
            )
        spec = _section(
            {k: v for k, v in section.items() if k not in names},
            self.source,
            "merge",
            {"taper_length": 40.0, "ramp_radius": 60.0},
        )
        self.main_in, self.main_out, self.ramp = (
            self.legs[str(roles["main_in"])],
            self.legs[str(roles["main_out"])],
            self.legs[str(roles["ramp"])],
        )
        self.taper_length, self.ramp_radius = spec["taper_length"], spec["ramp_radius"]
        self.entry_legs = (self.main_in.name, self.ramp.name)
        self.exit_legs = (self.main_out.name,)
        for leg in self.legs.values():
            if leg.crosswalk is not None:
                raise ConfigError(
                    file=self.source,
                    field=f"legs.{leg.name}.crosswalk",
                    value="crosswalk",
                    expected="no crosswalk (a merge layout has none)",
                )
        main = self.main_out.heading
        if abs(wrap_angle(self.main_in.heading - main - math.pi)) > 1e-6:
            raise ConfigError(
                file=self.source,
                field=f"legs.{self.main_in.name}.heading_deg",
                value=math.degrees(self.main_in.heading),
                expected=f"opposite to {self.main_out.name} (a straight main road)",
            )
        turn = wrap_angle(self.ramp.heading - main)
        if not -math.radians(175) < turn < -math.radians(100):
            raise ConfigError(
                file=self.source,
                field=f"legs.{self.ramp.name}.heading_deg",
                value=math.degrees(self.ramp.heading),
                expected=f"a ramp from the right: {self.main_out.name}'s heading + 185 to 260 "
                "degrees",
            )
        if not self.main_out.mouth >= self.taper_length:
            raise ConfigError(
                file=self.source,
                field=f"legs.{self.main_out.name}.mouth",
                value=self.main_out.mouth,
                expected=f"at least the taper length ({self.taper_length:g} m)",
            )
        if self._accel_length() < 0.0:
            raise ConfigError(
                file=self.source,
                field=f"legs.{self.ramp.name}.mouth",
                value=self.ramp.mouth,
                expected=f"at least the ramp curve's length ({self._curve_length():.1f} m)",
            )

    def _frame(self, along: float, right: float) -> tuple[float, float]:
        """A point ``along`` the main road from the nose, ``right`` of its lane centre."""
        h = self.main_out.heading
        return (
            along * math.cos(h) + right * math.sin(h),
            along * math.sin(h) - right * math.cos(h),
        )

    def _ramp_turn(self) -> float:
        """Heading change from the ramp's inbound direction to the main road's [rad]."""
        return abs(wrap_angle(self.main_out.heading - (self.ramp.heading + math.pi)))

    def _curve_length(self) -> float:
        return self.ramp_radius * self._ramp_turn()

    def _accel_length(self) -> float:
        return self.ramp.mouth - self._curve_length()

    def _build_lanes(self) -> dict[str, Path]:
        w, e, m = self.main_in, self.main_out, self.ramp
        lw = self.lane_width
        lanes = {
            f"{w.name}.in": _straight(self._frame(-w.length, 0.0), self._frame(-w.mouth, 0.0)),
            f"{w.name}-{e.name}": _straight(self._frame(-w.mouth, 0.0), self._frame(e.mouth, 0.0)),
            f"{e.name}.out": _straight(self._frame(e.mouth, 0.0), self._frame(e.length, 0.0)),
        }
        # ramp: straight leg -> curve -> acceleration lane -> taper -> main lane
        accel = self._accel_length()
        corner_t = self.ramp_radius * math.tan(0.5 * self._ramp_turn())
        corner = self._frame(-accel - corner_t, lw)
        ux, uy = math.cos(m.heading), math.sin(m.heading)
        mouth_pt = (corner[0] + corner_t * ux, corner[1] + corner_t * uy)
        far = (mouth_pt[0] + (m.length - m.mouth) * ux, mouth_pt[1] + (m.length - m.mouth) * uy)
        lanes[f"{m.name}.in"] = _straight(far, mouth_pt)
        curve = _checked_connector(
            mouth_pt,
            m.heading + math.pi,
            self._frame(-accel, lw),
            e.heading,
            f"legs.{m.name} (ramp curve)",
            self.source,
        )
        n = max(2, math.ceil(self.taper_length / (0.5 * ROUTE_STEP)))
        taper = [
            self._frame(self.taper_length * k / n, lw * 0.5 * (1 + math.cos(math.pi * k / n)))
            for k in range(n + 1)
        ]
        points = list(curve.points) + [self._frame(0.0, lw)] + taper + [self._frame(e.mouth, 0.0)]
        lanes[f"{m.name}-{e.name}"] = Path.from_points(points)
        return lanes

    def _build_graph(self) -> dict[str, tuple[str, ...]]:
        w, e, m = self.main_in.name, self.main_out.name, self.ramp.name
        return {
            f"{w}.in": (f"{w}-{e}",),
            f"{m}.in": (f"{m}-{e}",),
            f"{w}-{e}": (f"{e}.out",),
            f"{m}-{e}": (f"{e}.out",),
            f"{e}.out": (),
        }

    def render_geometry(self) -> dict[str, Any]:
        """Main road, acceleration lane, taper and ramp as convex road pieces."""
        w, e, m = self.main_in, self.main_out, self.ramp
        half, lw = 0.5 * self.lane_width, self.lane_width
        f = self._frame
        accel = self._accel_length()
        polygons = [
            _ccw([f(-w.length, -half), f(e.length, -half), f(e.length, half), f(-w.length, half)]),
            _ccw([f(-accel, half), f(0.0, half), f(0.0, lw + half), f(-accel, lw + half)]),
        ]
        ramp_in, ramp_move = self._lanes[f"{m.name}.in"], self._lanes[f"{m.name}-{e.name}"]
        curve_end = ramp_move.project(*f(-accel, lw), hint=-1)[0]
        curve = ramp_move.sub(0.0, max(curve_end, 0.5), 0.5 * ROUTE_STEP)
        polygons += _strip(Path.from_points(ramp_in.points + curve.points), half)
        n = max(1, math.ceil(self.taper_length / PIECE))
        outer = [
            (self.taper_length * k / n, lw * 0.5 * (1 + math.cos(math.pi * k / n)) + half)
            for k in range(n + 1)
        ]
        for (a0, b0), (a1, b1) in zip(outer, outer[1:], strict=False):
            if b0 > half + 1e-9:
                polygons.append(_ccw([f(a0, half), f(a1, half), f(a1, max(b1, half)), f(a0, b0)]))
        markings = [
            {"points": [f(-accel, half), f(0.0, half)], "style": "dashed", "color": "white"},
        ]
        kerbs = [
            [f(-w.length, -half), f(e.length, -half)],
            [f(-w.length, half), f(-accel, half)],
            [f(self.taper_length, half), f(e.length, half)],
            [f(-accel, lw + half), f(0.0, lw + half)] + [f(a, b) for a, b in outer],
            _offset_points(ramp_in, half),
            _offset_points(ramp_in, -half),
        ]
        return {
            "road_polygons": polygons,
            "markings": markings,
            "kerbs": kerbs,
            "crosswalks": [],
            "sidewalks": [],
        }


LAYOUTS.update(roundabout=RoundaboutMap, merge=MergeMap)
