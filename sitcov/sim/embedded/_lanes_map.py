"""Maps with explicit lane geometry (``layout: lanes``): junctions imported from OpenDRIVE.

The leg model stays (names, outward headings, mouth and length as distances from the
junction centre, spawn and goal distances along the legs) but lanes are data, not
derived: each movement ``X-Y`` has its own inbound lane (``X-Y.in``, from the end of leg X
to its mouth), connecting lane (``X-Y``) and outbound lane (``X-Y.out``), as polylines in
the map frame, so two movements from one leg may start on different lanes. A distance
along a leg is the mouth plus the distance along the lane from the junction. The drivable
area, sidewalks and crosswalks are polygons of the file; a pedestrian crosses on the
crosswalk's long axis from ``sidewalk_width`` before the kerb to as far beyond the other.
Written by ``sitcov map import`` (``sitcov.roads``); the format is in ``docs/roads.md``.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.sim.embedded._map import LAYOUTS, ROUTE_STEP, JunctionMap, _ccw
from sitcov.sim.embedded._path import Path

#: How far from a crosswalk's centre its axis is searched for the road's edges [m].
_CROSS_REACH = 40.0


def _points(value: Any, source: str, where: str, n_min: int = 2) -> list[tuple[float, float]]:
    ok = isinstance(value, list) and len(value) >= n_min
    if ok:
        try:
            pts = [(float(p[0]), float(p[1])) for p in value if len(p) == 2]
        except (TypeError, ValueError, IndexError):
            pts = []
        ok = len(pts) == len(value) and all(math.isfinite(c) for p in pts for c in p)
    if not ok:
        raise ConfigError(
            file=source,
            field=where,
            value=None,
            expected=f"a list of at least {n_min} [x, y] points",
        )
    return pts


class LanesMap(JunctionMap):
    """A junction whose lanes, drivable area, sidewalks and crosswalks are given as data."""

    LAYOUT = "lanes"

    def _parse_layout(self, section: Any) -> None:
        src = self.source
        if not isinstance(section, dict) or not isinstance(section.get("routes"), dict):
            raise ConfigError(
                file=src,
                field="lanes",
                value=None,
                expected="a mapping with routes (see docs/roads.md)",
            )
        self.frame = section.get("frame", {})
        self.origin_info = section.get("source", {})
        self._route_data: dict[str, tuple[list, list, list]] = {}
        for move, data in section["routes"].items():
            a, _, b = str(move).partition("-")
            if a not in self.legs or b not in self.legs or a == b or not isinstance(data, dict):
                raise ConfigError(
                    file=src,
                    field=f"lanes.routes.{move}",
                    value=move,
                    expected=f'"X-Y" with X != Y legs of this map {sorted(self.legs)} and in, '
                    "through, out point lists",
                )
            self._route_data[str(move)] = tuple(  # type: ignore[assignment]
                _points(data.get(k), src, f"lanes.routes.{move}.{k}")
                for k in ("in", "through", "out")
            )
        self.entry_legs = tuple(sorted({m.split("-")[0] for m in self._route_data}))
        self.exit_legs = tuple(sorted({m.split("-")[1] for m in self._route_data}))
        self._polygons = [
            _points(p, src, f"lanes.road_polygons[{i}]", 3)
            for i, p in enumerate(section.get("road_polygons", []))
        ]
        if not self._polygons:
            raise ConfigError(
                file=src, field="lanes.road_polygons", expected="the drivable area's polygons"
            )
        self._sidewalks = [
            _points(p, src, f"lanes.sidewalks[{i}]", 3)
            for i, p in enumerate(section.get("sidewalks", []))
        ]
        crosswalks = section.get("crosswalks", {}) or {}
        self._crosswalks = {
            str(n): _points(p, src, f"lanes.crosswalks.{n}", 3) for n, p in crosswalks.items()
        }
        for n in self._crosswalks:
            if n not in self.legs or self.legs[n].crosswalk is None:
                raise ConfigError(
                    file=src,
                    field=f"lanes.crosswalks.{n}",
                    value=n,
                    expected="a leg of this map with a crosswalk entry",
                )

    @functools.cached_property
    def movements(self) -> tuple[str, ...]:
        """The movements the file has a route for."""
        return tuple(sorted(self._route_data))

    def _build_lanes(self) -> dict[str, Path]:
        lanes: dict[str, Path] = {}
        for move, (inbound, through, outbound) in self._route_data.items():
            lanes[f"{move}.in"] = Path.from_points(_dedup(inbound))
            lanes[move] = Path.from_points(_dedup(through))
            lanes[f"{move}.out"] = Path.from_points(_dedup(outbound))
            a, b = move.split("-")
            for lane, leg in ((f"{move}.in", a), (f"{move}.out", b)):
                want = self.legs[leg].length - self.legs[leg].mouth
                if abs(lanes[lane].length - want) > 0.05:
                    raise ConfigError(
                        file=self.source,
                        field=f"lanes.routes.{move}.{lane.rsplit('.', 1)[-1]}",
                        value=round(lanes[lane].length, 3),
                        expected=f"a lane as long as leg {leg} beyond its mouth ({want:.3f} m)",
                    )
        return lanes

    def _build_graph(self) -> dict[str, tuple[str, ...]]:
        graph: dict[str, tuple[str, ...]] = {}
        for move in self._route_data:
            graph[f"{move}.in"] = (move,)
            graph[move] = (f"{move}.out",)
            graph[f"{move}.out"] = ()
        return graph

    def lane_sequence(self, from_leg: str, to_leg: str) -> list[str]:
        """The movement's own inbound, connecting and outbound lanes."""
        move = f"{from_leg}-{to_leg}"
        self._parse_move(move)
        return [f"{move}.in", move, f"{move}.out"]

    def render_geometry(self) -> dict[str, Any]:
        """The file's road pieces, its sidewalks and crosswalks; kerbs along the routes'
        outer edges are not drawn (the road pieces' outline shows them)."""
        return {
            "road_polygons": [_ccw(list(p)) for p in self._polygons],
            "markings": [],
            "kerbs": [],
            "crosswalks": [_ccw(list(p)) for p in self._crosswalks.values()],
            "sidewalks": [_ccw(list(p)) for p in self._sidewalks],
        }

    @functools.lru_cache(maxsize=32)  # noqa: B019 - maps live for the process
    def crosswalk_route(self, leg_name: str, side: str) -> tuple[Path, float, float]:
        """A pedestrian's path across leg ``leg_name``'s crosswalk and where it steps onto
        and off the road (arc lengths [m]); ``side`` L starts at the kerb on the left as
        seen facing the junction from the leg."""
        pts = np.asarray(self._crosswalks[leg_name])
        centre = pts.mean(axis=0)
        heading = self.legs[leg_name].heading
        # the walking direction: from the left kerb to the right one, facing the centre
        across = np.array([-math.sin(heading), math.cos(heading)])
        if side == "R":
            across = -across
        t = np.arange(-_CROSS_REACH, _CROSS_REACH + 1e-9, 0.25)
        xs, ys = centre[0] + t * across[0], centre[1] + t * across[1]
        on = self.drivable_area.contains_many(xs, ys)
        mid = int(np.argmin(np.abs(t)))
        if not on[mid]:
            raise ConfigError(
                file=self.source,
                field=f"lanes.crosswalks.{leg_name}",
                value=None,
                expected="a crosswalk whose centre lies on the road",
            )
        lo = mid
        while lo > 0 and on[lo - 1]:
            lo -= 1
        hi = mid
        while hi < len(t) - 1 and on[hi + 1]:
            hi += 1
        t0, t1 = t[lo] - self.sidewalk_width, t[hi] + self.sidewalk_width
        n = max(1, math.ceil((t1 - t0) / ROUTE_STEP))
        path = Path.from_points(
            [
                (centre[0] + v * across[0], centre[1] + v * across[1])
                for v in np.linspace(t0, t1, n + 1)
            ]
        )
        return path, float(t[lo] - t0), float(t[hi] - t0)


def _dedup(points: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Points without consecutive repeats (a zero-length segment has no heading)."""
    out = [points[0]]
    for p in points[1:]:
        if math.dist(p, out[-1]) > 1e-6:
            out.append(p)
    return out


LAYOUTS.update(lanes=LanesMap)
