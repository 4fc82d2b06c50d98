"""Outlines of every lane of an OpenDRIVE network, for top-down drawings of a whole road.

``junction_map_data`` keeps only the stretches one junction's routes cross; a drawing of
a run on a user's road (the esmini backend) needs every lane near the run instead. This
samples each lane of each section into a closed polygon (its inner border forward, its
outer border back) and the lines between lanes, each with its bounding box so that a
drawing can keep only what lies in its view (a town has thousands of lanes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sitcov.roads._opendrive import Network, Road
from sitcov.roads._walk import inside_section

#: Sample spacing along a road's reference line [m] (arcs and spirals look smooth at
#: junction scale; a 1 km road gives 500 points per border).
STEP = 2.0


@dataclass(frozen=True)
class LaneOutline:
    """One lane of one lane section: ``type`` its OpenDRIVE lane type (``driving``,
    ``sidewalk``, ``shoulder``, ...), ``drivable`` whether it is a driving lane,
    ``junction`` whether its road is a junction's connecting road, ``polygon`` an (n, 2)
    array [m], ``bbox`` (x0, y0, x1, y1) [m]."""

    road: str
    lane: int
    type: str
    drivable: bool
    junction: bool
    polygon: np.ndarray
    bbox: tuple[float, float, float, float]


@dataclass(frozen=True)
class LaneBorder:
    """A line along a road: ``kind`` ``lane`` (between two driving lanes of one direction),
    ``centre`` (between driving lanes of opposite directions) or ``edge`` (the outer side
    of the outermost driving lane); ``points`` an (n, 2) array [m], ``bbox`` as above.
    Connecting roads inside junctions have none (they overlap each other)."""

    road: str
    kind: str
    points: np.ndarray
    bbox: tuple[float, float, float, float]


def _bbox(points: np.ndarray) -> tuple[float, float, float, float]:
    lo, hi = points.min(axis=0), points.max(axis=0)
    return float(lo[0]), float(lo[1]), float(hi[0]), float(hi[1])


def _section_samples(road: Road, index: int, step: float) -> np.ndarray:
    a, b = road.sections[index].s, road.section_end(index)
    n = max(1, math.ceil((b - a) / step))
    return inside_section(road, index, np.linspace(a, b, n + 1))


def lane_outlines(net: Network, step: float = STEP) -> tuple[list[LaneOutline], list[LaneBorder]]:
    """Every lane of ``net`` as a polygon, and the lines between lanes (see
    :class:`LaneBorder`), sampled every ``step`` metres along each road [m]."""
    lanes: list[LaneOutline] = []
    borders: list[LaneBorder] = []
    for road in net.roads.values():
        in_junction = road.junction not in ("", "-1")
        for i, sec in enumerate(road.sections):
            if road.section_end(i) - sec.s < 1e-6:
                continue
            s = _section_samples(road, i, step)
            x, y, h = road.plan_view.evaluate(s)
            nx, ny = -np.sin(h), np.cos(h)

            def line(t: np.ndarray, x=x, y=y, nx=nx, ny=ny) -> np.ndarray:
                return np.column_stack((x + t * nx, y + t * ny))

            drivable_sides = set()
            for lid, lane in sec.lanes.items():
                if lid == 0:
                    continue
                inner, outer = road.borders(i, lid, s)
                if np.all(np.abs(outer - inner) < 1e-3):
                    continue
                poly = np.vstack((line(inner), line(outer)[::-1]))
                lanes.append(
                    LaneOutline(
                        road.id, lid, lane.type, lane.drivable, in_junction, poly, _bbox(poly)
                    )
                )
                if lane.drivable:
                    drivable_sides.add(1 if lid > 0 else -1)
            if in_junction:
                continue
            for side in (-1, 1):
                ids = sec.lane_ids(side)
                for k, lid in enumerate(ids):
                    if not sec.lanes[lid].drivable:
                        continue
                    _, outer = road.borders(i, lid, s)
                    nxt = sec.lanes[ids[k + 1]] if k + 1 < len(ids) else None
                    kind = "lane" if nxt is not None and nxt.drivable else "edge"
                    pts = line(outer)
                    borders.append(LaneBorder(road.id, kind, pts, _bbox(pts)))
            if drivable_sides == {-1, 1}:
                pts = line(road.borders(i, sec.lane_ids(1)[0], s)[0])
                borders.append(LaneBorder(road.id, "centre", pts, _bbox(pts)))
    return lanes, borders
