"""Following one lane along the road network, away from a junction or through one.

A walk starts at one end of a road on one lane and moves along it (its lane links across
sections, its road links to the next road, and through a junction on the straightest
connecting road that continues the lane) until it has covered the length asked for or
the lane ends. It returns the lane's centre line and the stretches of road it crossed
(for the drivable area).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sitcov.roads._opendrive import Network, Road

#: Spacing of the sampled lane centre lines [m].
STEP = 1.0


@dataclass(frozen=True)
class Stretch:
    """Part of a road a walk crossed: road id and the s range [m]."""

    road: str
    s0: float
    s1: float


def lane_at_end(road: Road, lane_id: int, forward: bool) -> int | None:
    """The lane id a lane continues as beyond the road's end (forward) or start."""
    sec = road.sections[-1 if forward else 0]
    lane = sec.lanes.get(lane_id)
    if lane is None:
        return None
    return lane.successor if forward else lane.predecessor


def inside_section(road: Road, index: int, s: np.ndarray) -> np.ndarray:
    """``s`` kept just inside section ``index``'s end: at the end itself, records that
    start there (the next lane offset, the next section's widths) would already apply, as
    they do in esmini; a road's own end is kept."""
    if index + 1 < len(road.sections):
        return np.minimum(s, road.section_end(index) - 1e-7)
    return s


def sample_lane(
    road: Road, lane_id: int, s_from: float, s_to: float
) -> tuple[np.ndarray, int | None]:
    """Centre-line points of a lane from ``s_from`` to ``s_to`` (either direction), following
    its lane links across sections; returns the points (about half a step apart) and the
    lane id in the last section reached (None where the lane ends before ``s_to``)."""
    forward = s_to >= s_from
    lo, hi = min(s_from, s_to), max(s_from, s_to)
    order = range(len(road.sections)) if forward else range(len(road.sections) - 1, -1, -1)
    pieces: list[np.ndarray] = []
    lid: int | None = lane_id
    prev: int | None = None
    for i in order:
        a, b = max(road.sections[i].s, lo), min(road.section_end(i), hi)
        if b - a < 1e-9 and not (lo == hi and a <= lo <= b):
            continue
        if prev is not None:
            lane = road.sections[prev].lanes.get(lid) if lid is not None else None
            lid = (lane.successor if forward else lane.predecessor) if lane else None
        prev = i
        if lid is None or lid not in road.sections[i].lanes:
            return (np.concatenate(pieces) if pieces else np.zeros((0, 2))), None
        n = max(1, math.ceil((b - a) / (0.5 * STEP)))
        s = np.linspace(a, b, n + 1) if forward else np.linspace(b, a, n + 1)
        x, y, _ = road.points(i, lid, inside_section(road, i, s))
        pts = np.column_stack([x, y])
        pieces.append(pts if not pieces else pts[1:])
    return (np.concatenate(pieces) if pieces else np.zeros((0, 2))), lid


def walk(
    net: Network, road_id: str, lane_id: int, from_end: bool, length: float
) -> tuple[np.ndarray, list[Stretch]]:
    """Follow lane ``lane_id`` of road ``road_id`` from its start (``from_end`` False, moving
    along s) or its end (moving against s) for ``length`` metres.

    Returns the lane's centre line (N x 2 points, about half a metre apart, possibly
    shorter than ``length`` where the lane ends) and the road stretches crossed.
    """
    points: list[np.ndarray] = []
    stretches: list[Stretch] = []
    covered = 0.0
    road, lid, forward = net.roads[road_id], lane_id, not from_end
    for _ in range(64):  # roads visited at most
        s_from = 0.0 if forward else road.length
        remaining = length - covered
        s_to = min(road.length, remaining) if forward else max(0.0, road.length - remaining)
        pts, end_lid = sample_lane(road, lid, s_from, s_to)
        if len(pts) > 1:
            points.append(pts if not points else pts[1:])
            covered += float(np.hypot(*np.diff(pts, axis=0).T).sum())
            stretches.append(Stretch(road.id, min(s_from, s_to), max(s_from, s_to)))
        if end_lid is None or covered >= length - 1e-6 or s_to not in (0.0, road.length):
            break
        nxt = _next(net, road, end_lid, forward, points[-1])
        if nxt is None:
            break
        road, lid, forward = nxt
    line = np.concatenate(points) if points else np.zeros((0, 2))
    return cut_polyline(line, length), stretches


def cut_polyline(line: np.ndarray, length: float) -> np.ndarray:
    """The first ``length`` metres of a polyline (the last point interpolated)."""
    if len(line) < 2:
        return line
    seg = np.hypot(*np.diff(line, axis=0).T)
    cum = np.concatenate(([0.0], np.cumsum(seg)))
    if cum[-1] <= length:
        return line
    k = int(np.searchsorted(cum, length))
    f = (length - cum[k - 1]) / max(seg[k - 1], 1e-12)
    end = line[k - 1] + f * (line[k] - line[k - 1])
    return np.vstack([line[:k], end])


def _next(
    net: Network, road: Road, lane_id: int, forward: bool, pts: np.ndarray
) -> tuple[Road, int, bool] | None:
    """The road, lane and direction a walk continues on past the end of ``road``."""
    link = road.successor if forward else road.predecessor
    if link is None:
        return None
    here = "end" if forward else "start"
    if link.element_type == "road":
        nxt = net.roads.get(link.element_id)
        if nxt is None:
            return None
        next_lane = lane_at_end(road, lane_id, forward)
        if next_lane is None:
            return None
        return nxt, next_lane, link.contact_point != "end"
    # a junction: the straightest connecting road that continues this lane
    heading = math.atan2(pts[-1, 1] - pts[-2, 1], pts[-1, 0] - pts[-2, 0]) if len(pts) > 1 else 0.0
    best: tuple[float, Road, int, bool] | None = None
    for cand in net.roads.values():
        if cand.junction != link.element_id:
            continue
        for at_start, clink in ((True, cand.predecessor), (False, cand.successor)):
            if clink is None or clink.element_type != "road" or clink.element_id != road.id:
                continue
            if clink.contact_point not in (None, here):
                continue
            sec = cand.sections[0 if at_start else -1]
            for lid, lane in sec.lanes.items():
                linked = lane.predecessor if at_start else lane.successor
                if linked != lane_id:
                    continue
                # the connecting road's chord, in the direction it is driven from here
                s = np.array([0.0, cand.length]) if at_start else np.array([cand.length, 0.0])
                x, y, _ = cand.plan_view.evaluate(s)
                chord = math.atan2(y[1] - y[0], x[1] - x[0])
                turn = abs(math.remainder(chord - heading, math.tau))
                if best is None or turn < best[0]:
                    best = (turn, cand, lid, at_start)
    if best is None:
        return None
    return best[1], best[2], best[3]
