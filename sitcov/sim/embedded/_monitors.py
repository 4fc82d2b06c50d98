"""Run monitors: small objects the run loop calls each step, each recording one fact.

Every world monitor has two methods: ``update(world) -> str | None``, called after each
control step (a string ends the run with that ``end_reason``), and ``report(run, actors,
world)``, called once at the end, which writes its facts into the run's metrics (``run``)
and per-actor metrics (``actors[name]``). The run loop knows nothing else about them, so a
new metric is a new monitor in the list (``default_monitors``), not a change of the loop.

- :class:`EgoRouteMonitor`: lane and road departure of the ego (below) and its largest
  lateral offset from its route.
- :class:`PETMonitor`, :class:`DistanceMonitor`, :class:`TTCMonitor`: per actor, the
  post-encroachment time at its conflict with the ego, the minimum box distance and the
  minimum constant-velocity TTC (``sitcov.sim._metrics``, docs/metrics.md), and the
  largest DRAC (:func:`proximity`).
- :class:`ProximityMonitor`: the built-in list's distance and TTC monitors in one (the
  same two facts, the same bits): one compiled call per actor and step (:func:`proximity`)
  instead of two monitors' Python loops.
- :class:`CollisionMonitor`: the ego's box overlaps an actor's: ends the run; records
  where (the overlap's centroid), the ego's heading then and the kind of road user hit.
- :class:`ActorCollisionMonitor`: two other actors' boxes overlap: recorded, both brake
  to a stop; the run goes on.
- :class:`LeaveMapRule`: an actor at the end of its route leaves the world.
- :class:`GoalMonitor`: the ego reached its goal: ends the run.
- :class:`~sitcov.sim.embedded._progress.ProgressMonitor`: the ego's route completion,
  time to goal, standstill and ``blocked`` time (``_progress.py``); it ends the run at the
  goal as :class:`GoalMonitor` does, in the built-in list instead of it.
- :class:`EarlyEndMonitor`: the ego's AEB latched and it stands, and no actor can still
  reach it: ends the run as ``stopped`` (docs/embedded.md, "End of a run").

The departure monitors record the first time [s] their event happens; they never end the
run nor decide a verdict (that is the campaign's judge, ``sitcov.sim.Judge``), so the
simulated facts are the same whatever counts as a failure.

- :class:`LaneDepartureMonitor`: the ego's lateral offset from its route exceeds a stated
  tolerance (the box reaches :data:`LANE_TOLERANCE` beyond its lane's edge).
- :class:`RoadDepartureMonitor`: a corner of the ego's box is outside the map's drivable
  area (:class:`DrivableArea`: the road surface of every leg plus the junction area). The
  exact corner test runs only when the box can reach the area's edge at all: each route
  point knows how far the road extends to its left and right (:func:`route_clearance`),
  and the box's lateral reach is bounded by its offset, its half width and its heading
  error, so on an ordinary lap the exact test never runs.
"""

from __future__ import annotations

import functools
import itertools
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from sitcov.sim._metrics import PET_ZONE, post_encroachment_time, time_to_collision
from sitcov.sim.embedded._collision import (
    _axes_overlap,
    _corners_to_box,
    box_distance,
    box_distance_flat,
    box_distance_flat_fn,
    box_on_area,
    box_on_area_fn,
    contact_point,
    corridor_gap,
    overlap,
)
from sitcov.sim.embedded._dynamics import G
from sitcov.sim.embedded._progress import _STILL2, GOAL_TOLERANCE, ProgressMonitor

#: How far the ego's box may reach beyond its lane's edge before it counts as a lane
#: departure [m] (a wheel over the marking is normal driving; half a metre is not).
LANE_TOLERANCE = 0.5
#: Slack on the cheap pre-test of the road monitor [m]: covers the route frame turning
#: under a box that is up to ~2.5 m long (curve radius >= 10 m: < 0.35 m) and the route's
#: 1 m point spacing.
CLEARANCE_SLACK = 0.5
#: Ego speed below which it counts as stopped [m/s].
STOPPED_SPEED = 0.05
#: Safety factor on the friction an actor needs to hold its lane (for the early end) [-].
LANE_HOLD_MARGIN = 1.5
#: Tracking margin of an actor around its route for the early end [m].
CORRIDOR_MARGIN = 1.0
#: Centre distance beyond which the box distance is evaluated every fourth step [m].
FAR = 15.0
#: Lateral search range and resolution of :func:`route_clearance` [m].
_REACH, _STEP = 10.0, 0.05
#: Arc length either side of a route point over which its clearance is the minimum [m]:
#: half a car's length and width plus one route segment (the ego lies between two points).
WINDOW = 4.0

Polygon = Sequence[tuple[float, float]]


class DrivableArea:
    """A union of convex counter-clockwise polygons (leg road surfaces, junction area).

    Args:
        polygons: each a list of (x, y) corners [m], counter-clockwise, convex.
    """

    def __init__(self, polygons: Sequence[Polygon]) -> None:
        self.polygons = [tuple((float(x), float(y)) for x, y in p) for p in polygons]
        # edges as (ax, ay, ex, ey): inside iff ex * (py - ay) - ey * (px - ax) >= 0
        self._edges = [
            [(a[0], a[1], b[0] - a[0], b[1] - a[1]) for a, b in zip(p, p[1:] + p[:1], strict=True)]
            for p in self.polygons
        ]
        #: the same edges flat with each polygon's end, as ``box_on_area`` takes them
        #: (float and int arrays for the compiled one), made at the first box test
        self._flat: tuple[bool, Any, Any] | None = None

    def contains(self, x: float, y: float, eps: float = 1e-6) -> bool:
        """Whether (x, y) lies on the drivable area (edges included)."""
        for edges in self._edges:
            for ax, ay, ex, ey in edges:
                if ex * (y - ay) - ey * (x - ax) < -eps:
                    break
            else:
                return True
        return False

    def contains_box(self, x: float, y: float, yaw: float, half_l: float, half_w: float) -> bool:
        """Whether all four corners of a box (centre, heading, half sizes) are on the area
        (:meth:`contains` of each corner, in one compiled call: ``_collision.box_on_area``)."""
        fn = box_on_area_fn()
        fast = fn is not box_on_area
        if self._flat is None or self._flat[0] != fast:
            flat = [v for edges in self._edges for edge in edges for v in edge]
            ends = list(itertools.accumulate(len(edges) for edges in self._edges))
            if fast:
                flat, ends = np.array(flat, dtype=np.float64), np.array(ends, dtype=np.int64)
            self._flat = (fast, flat, ends)
        _, edges, ends = self._flat
        return bool(fn(edges, ends, x, y, yaw, half_l, half_w))

    def contains_many(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Vectorised :meth:`contains` for arrays of points."""
        inside = np.zeros(np.shape(xs), dtype=bool)
        for edges in self._edges:
            ok = np.ones(np.shape(xs), dtype=bool)
            for ax, ay, ex, ey in edges:
                ok &= ex * (ys - ay) - ey * (xs - ax) >= -1e-6
            inside |= ok
        return inside


def route_clearance(area: DrivableArea, route: Any) -> tuple[list[float], list[float]]:
    """How far the drivable area extends left and right of each point of ``route`` [m].

    ``route`` is a ``Path`` (``xs``, ``ys``, ``hs``, ``ss``). Measured along each point's
    normal (to :data:`_REACH` at :data:`_STEP` resolution), then the minimum over
    :data:`WINDOW` metres of arc length either side, so that a box near point i but
    reaching along the route meets the nearest edge of its whole length. A point off the
    area has clearance 0 on both sides (the box is then always tested exactly).
    """
    x, y = np.asarray(route.xs)[:, None], np.asarray(route.ys)[:, None]
    h, ss = np.asarray(route.hs)[:, None], np.asarray(route.ss)
    t = np.arange(0.0, _REACH + _STEP, _STEP)[None, :]
    nx, ny = -np.sin(h), np.cos(h)
    out = []
    for side in (1.0, -1.0):
        inside = area.contains_many(x + side * t * nx, y + side * t * ny)
        first_out = np.where(inside.all(axis=1), inside.shape[1], np.argmin(inside, axis=1))
        clear = np.maximum(first_out - 1, 0) * _STEP
        lo = np.searchsorted(ss, ss - WINDOW, side="left")
        hi = np.searchsorted(ss, ss + WINDOW, side="right")
        out.append([float(clear[a:b].min()) for a, b in zip(lo, hi, strict=True)])
    # near an end of the route the box may reach beyond it: unless the road goes on
    # there, such points get no clearance (always the exact test)
    for end, sign, near in ((0, -1.0, ss < WINDOW), (-1, 1.0, ss > ss[-1] - WINDOW)):
        hx = float(x[end, 0] + sign * WINDOW * np.cos(h[end, 0]))
        hy = float(y[end, 0] + sign * WINDOW * np.sin(h[end, 0]))
        if not area.contains(hx, hy):
            for side in out:
                for i in np.flatnonzero(near):
                    side[i] = 0.0
    return out[0], out[1]


class LaneDepartureMonitor:
    """Records when the ego's lateral offset from its route first exceeds ``limit`` [m]."""

    __slots__ = ("limit", "time")

    def __init__(self, limit: float) -> None:
        self.limit = float(limit)
        self.time: float | None = None

    def update(self, t: float, x: float, y: float, yaw: float, i: int, lat: float) -> None:
        """One step: ego pose, its route segment ``i`` and signed lateral offset ``lat``."""
        if self.time is None and (lat > self.limit or -lat > self.limit):
            self.time = t


class RoadDepartureMonitor:
    """Records when a corner of the ego's box first leaves the drivable area.

    Args:
        area: the map's drivable area.
        hs: route headings per point [rad]; ``left``/``right``: :func:`route_clearance`.
        half_l, half_w: half the ego's length and width [m].
    """

    __slots__ = ("area", "half_l", "half_w", "hs", "left", "right", "time")

    def __init__(
        self,
        area: DrivableArea,
        hs: Sequence[float],
        left: Sequence[float],
        right: Sequence[float],
        half_l: float,
        half_w: float,
    ) -> None:
        self.area, self.hs, self.left, self.right = area, hs, left, right
        self.half_l, self.half_w = half_l, half_w
        self.time: float | None = None

    def update(self, t: float, x: float, y: float, yaw: float, i: int, lat: float) -> None:
        """One step (same arguments as :meth:`LaneDepartureMonitor.update`)."""
        if self.time is not None:
            return
        # lateral reach of the box in the route frame: <= half_w + half_l * |sin(yaw - h)|
        reach = self.half_w + self.half_l * abs(math.sin(yaw - self.hs[i])) + CLEARANCE_SLACK
        if lat + reach < self.left[i] and reach - lat < self.right[i]:
            return
        if not self.area.contains_box(x, y, yaw, self.half_l, self.half_w):
            self.time = t


# --- world monitors -------------------------------------------------------------------------


@functools.lru_cache(maxsize=256)
def _heading_trig(route: Any) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """sin and cos of each heading of ``route``: once per route, not per run (a map's
    routes are cached, so runs share them)."""
    return tuple(math.sin(h) for h in route.hs), tuple(math.cos(h) for h in route.hs)


class EgoRouteMonitor:
    """The ego's lateral offset from its route: lane and road departure, largest offset.

    Args:
        route: the ego's route. lane: :class:`LaneDepartureMonitor`. road:
            :class:`RoadDepartureMonitor`.
    """

    def __init__(self, route: Any, lane: LaneDepartureMonitor, road: RoadDepartureMonitor):
        self.xs, self.ys = route.xs, route.ys
        self.sin, self.cos = _heading_trig(route)
        self.lane, self.road = lane, road
        self.max_lat = 0.0
        # the road monitor's cheap pre-test, written out below (this runs every step)
        self._road = (road.hs, road.left, road.right, road.half_l, road.half_w)

    def update(self, world: Any) -> None:
        """Offset of the ego at its tracked segment; feed both departure monitors."""
        ego = world.ego
        b, i = ego.body, ego.hint
        lat = -(b.x - self.xs[i]) * self.sin[i] + (b.y - self.ys[i]) * self.cos[i]
        lane, road = self.lane, self.road
        # each records only its first departure; the lane monitor is called only when
        # its limit is exceeded (its own test, written out: this runs every step)
        if lane.time is None and (lat > lane.limit or -lat > lane.limit):
            lane.update(world.t, b.x, b.y, b.yaw, i, lat)
        if road.time is None:
            hs, left, right, half_l, half_w = self._road
            reach = half_w + half_l * abs(math.sin(b.yaw - hs[i])) + CLEARANCE_SLACK
            if not (lat + reach < left[i] and reach - lat < right[i]):
                road.update(world.t, b.x, b.y, b.yaw, i, lat)
        lat = -lat if lat < 0.0 else lat
        if lat > self.max_lat:
            self.max_lat = lat

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``ego_max_lateral_offset``, ``ego_left_lane``, the two departure times."""
        lane, road = self.lane.time, self.road.time
        run["ego_max_lateral_offset"] = self.max_lat
        run["ego_left_lane"] = lane is not None
        run["lane_departure_time"] = None if lane is None else round(lane, 10)
        run["road_departure_time"] = None if road is None else round(road, 10)


class PETMonitor:
    """Post-encroachment time per actor at its conflict zone with the ego.

    Zone entry and exit as :class:`~sitcov.sim._metrics.ZoneClock` defines them (the front
    reaches the zone's start, the rear passes its end), kept as plain numbers here because
    this runs every step.
    """

    def __init__(self, world: Any) -> None:
        ego = world.ego
        # per actor: [ego start, ego end, actor start, actor end, 4 times]
        self.zones: list[list[Any]] = []
        for a in world.actors:
            c = a.conflict
            if c is None:
                zone = [math.inf, math.inf, math.inf, math.inf]
            else:
                zone = [
                    c.s_ego,
                    min(c.s_ego_end, c.s_ego + PET_ZONE),
                    c.s_ov,
                    min(c.s_ov_end, c.s_ov + PET_ZONE),
                ]
            self.zones.append([*zone, None, None, None, None])
        self.half_e = ego.half_l
        self._pairs = list(zip(world.actors, self.zones, strict=True))

    def update(self, world: Any) -> None:
        """Entry and exit times of the ego and each active actor."""
        t, s_e, hl = world.t, world.ego.s, self.half_e
        for a, z in self._pairs:
            if z[5] is None:
                if z[4] is None and s_e + hl >= z[0]:
                    z[4] = t
                if s_e - hl > z[1]:
                    z[5] = t
            if a.active and z[7] is None:
                s, ha = a.s, a.half_l
                if z[6] is None and s + ha >= z[2]:
                    z[6] = t
                if s - ha > z[3]:
                    z[7] = t

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``pet`` per actor (0 for the actor the ego collided with)."""
        hit = world.collision
        for a, z in zip(world.actors, self.zones, strict=True):
            actors[a.name]["pet"] = post_encroachment_time((z[4], z[5]), (z[6], z[7]), hit is a)


class DistanceMonitor:
    """Minimum distance between the ego's box and each actor's box [m].

    The exact box distance is computed only when it can beat the minimum, and every
    fourth step while the centres are more than :data:`FAR` apart (< 3 m of closing in
    between cannot hide a minimum that matters); always when near.
    """

    def __init__(self, world: Any) -> None:
        self.best = [math.inf] * len(world.actors)
        self._distance = box_distance_flat_fn()  # compiled when numba is there (same bits)

    def update(self, world: Any) -> None:
        """Box distance to each active actor when it may be a new minimum."""
        ego = world.ego
        far_step = world.k & 3 == 0
        best, box_distance = self.best, self._distance
        for i, a in enumerate(world.actors):
            gap = a.gap  # inf while inactive
            if gap - (ego.radius + a.radius) < best[i] and (gap < FAR or far_step):
                e, b = ego.body, a.body
                d = box_distance(
                    e.x, e.y, e.yaw, ego.half_l, ego.half_w, b.x, b.y, b.yaw, a.half_l, a.half_w
                )
                if d < best[i]:
                    best[i] = d

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``min_distance`` per actor (None if never measured)."""
        for a, d in zip(world.actors, self.best, strict=True):
            actors[a.name]["min_distance"] = d if math.isfinite(d) else None


class TTCMonitor:
    """Minimum constant-velocity time-to-collision of the footprint discs per actor [s],
    and the largest DRAC (deceleration rate to avoid a crash, :func:`proximity`) [m/s^2]."""

    def __init__(self, world: Any) -> None:
        self.best: list[float | None] = [None] * len(world.actors)
        self.best_drac: list[float | None] = [None] * len(world.actors)

    def update(self, world: Any) -> None:
        """TTC of each active actor relative to the ego now (:func:`proximity`'s TTC)."""
        ego = world.ego
        e = ego.body
        ex, ey, eyaw, evx, evy = e.x, e.y, e.yaw, e.vx, e.vy
        best, best_drac = self.best, self.best_drac
        for i, a in enumerate(world.actors):
            if not a.active:
                continue
            b = a.body
            k = (0.0, 0.0, 0.0, 0.0, ego.disc + a.disc)
            _, ttc, drac = proximity(ex, ey, eyaw, evx, evy, b.x, b.y, b.yaw, b.vx, b.vy, k, False)
            if ttc >= 0.0 and (best[i] is None or ttc < best[i]):
                best[i] = ttc
            if drac >= 0.0 and (best_drac[i] is None or drac > best_drac[i]):
                best_drac[i] = drac

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``min_ttc`` and ``max_drac`` per actor, the run's ``max_drac`` (over all)."""
        for a, ttc, drac in zip(world.actors, self.best, self.best_drac, strict=True):
            actors[a.name]["min_ttc"] = ttc
            actors[a.name]["max_drac"] = drac
        run["max_drac"] = _largest(self.best_drac)


def proximity(
    ex: float,
    ey: float,
    eyaw: float,
    evx: float,
    evy: float,
    ax: float,
    ay: float,
    ayaw: float,
    avx: float,
    avy: float,
    k: Any,
    distance: bool,
) -> tuple[float, float]:
    """The box distance (when ``distance``, else inf), the disc TTC (-1: none) and the DRAC
    (-1: none) of the ego (pose, body-frame velocity) and an actor, as
    :class:`DistanceMonitor` and :class:`TTCMonitor` compute them (the same operations in
    the same order).

    DRAC, the deceleration rate to avoid a crash [m/s^2] (Cooper & Ferguson 1976; Archer
    2005, whose rear-end form ``(v_f - v_l)^2 / (2 gap)`` is the one-dimensional case):
    the constant deceleration of the relative velocity that stops the discs' relative
    motion just before they touch, ``|v_rel|^2 / (2 |v_rel| TTC) = |v_rel| / (2 TTC)``,
    for a TTC > 0 (none while the discs overlap or never close in); the definition of
    ``sitcov.analysis._criticality``, which computes it from a trace.

    ``k``: [ego half length, ego half width, actor half length, actor half width, sum of
    the footprint discs' radii] (one float array: one type check in the compiled call).
    """
    d = math.inf
    if distance:
        d = box_distance_flat(ex, ey, eyaw, k[0], k[1], ax, ay, ayaw, k[2], k[3])
    ce, se = math.cos(eyaw), math.sin(eyaw)
    wvx, wvy = evx * ce - evy * se, evx * se + evy * ce
    c, s = math.cos(ayaw), math.sin(ayaw)
    rvx = (avx * c - avy * s) - wvx
    rvy = (avx * s + avy * c) - wvy
    ttc = time_to_collision(ax - ex, ay - ey, rvx, rvy, k[4])
    if ttc is None:
        return d, -1.0, -1.0
    if ttc > 0.0:
        return d, ttc, hypot(rvx, rvy) / (2.0 * ttc)
    return d, ttc, -1.0


#: ``math.hypot`` under the name :func:`proximity` uses (``_jit.py`` binds the name to its
#: correctly rounded version in the compiled code: the same bits).
hypot = math.hypot


def proximity_route(
    rt: Any,
    i: int,
    ex: float,
    ey: float,
    eyaw: float,
    evx: float,
    evy: float,
    ax: float,
    ay: float,
    ayaw: float,
    avx: float,
    avy: float,
    k: Any,
    distance: bool,
) -> tuple[float, bool, float, float, float]:
    """The ego's offset from its route at segment ``i`` and the road monitor's cheap
    pre-test (:meth:`EgoRouteMonitor.update`'s operations), then :func:`proximity`:
    ``(lat, clear, d, ttc, drac)``, ``clear`` True when the ego's box lies within the
    road's clearance (no exact test needed). One compiled call per step for the fused
    update's first active actor instead of the offset's Python and the proximity call.

    ``rt``: the route's xs, ys, sines and cosines of the headings, the road monitor's
    headings, left and right clearances (:func:`route_rows`); ``k``: :func:`proximity`'s
    constants, then the road monitor's half length and half width of the ego.
    """
    lat = -(ex - rt[0][i]) * rt[2][i] + (ey - rt[1][i]) * rt[3][i]
    reach = k[6] + k[5] * abs(math.sin(eyaw - rt[4][i])) + CLEARANCE_SLACK
    clear = lat + reach < rt[5][i] and reach - lat < rt[6][i]
    d, ttc, drac = proximity(ex, ey, eyaw, evx, evy, ax, ay, ayaw, avx, avy, k, distance)
    return lat, clear, d, ttc, drac


#: :func:`route_rows`' arrays per the ids of the sequences they hold (held with them, so
#: the ids stay theirs): a map's routes and their clearances are cached, so runs share them.
_ROWS: dict[tuple[int, ...], tuple[tuple[Any, ...], Any]] = {}


def route_rows(monitor: EgoRouteMonitor, compiled: bool) -> Any:
    """:func:`proximity_route`'s ``rt`` for an :class:`EgoRouteMonitor`: its route's xs,
    ys, heading sines and cosines, then its road monitor's headings, left and right
    clearances; one float array for the ``compiled`` kernel (made once per such
    sequences, not per run), else a tuple of them."""
    hs, left, right = monitor._road[:3]
    rows = (monitor.xs, monitor.ys, monitor.sin, monitor.cos, hs, left, right)
    if not compiled:
        return rows
    key = tuple(map(id, rows))
    held = _ROWS.get(key)
    if held is None:
        if len(_ROWS) >= 256:
            _ROWS.clear()
        held = _ROWS[key] = (rows, np.array(rows, dtype=np.float64))
    return held[1]


_PROXIMITY: Any = None
_PROXIMITY_ROUTE: Any = None


def proximity_route_fn() -> Any:
    """:func:`proximity_route` compiled by numba when it is installed (the same bits),
    else itself. Loaded once per process, on first use."""
    global _PROXIMITY_ROUTE
    if _PROXIMITY_ROUTE is None:
        from sitcov._jit import compiled, typed_entry

        k = np.array([2.3, 0.9, 0.25, 0.25, 3.0, 2.3, 0.9])
        rt = np.array(
            [[0.0, 1.0], [0.0, 0.0], [0.0, 0.0], [1.0, 1.0], [0.0, 0.0]] + [[3.0] * 2] * 2
        )
        example = (rt, 0, 0.0, 0.0, 0.3, 5.0, 0.1, 4.0, 1.0, 1.2, 1.0, 0.0, k, True)
        helpers = (
            _axes_overlap,
            _corners_to_box,
            box_distance,
            box_distance_flat,
            time_to_collision,
            proximity,
        )
        fast = compiled(proximity_route, *example, helpers=helpers)
        _PROXIMITY_ROUTE = typed_entry(fast) or proximity_route
    return _PROXIMITY_ROUTE


def proximity_fn() -> Any:
    """:func:`proximity` compiled by numba when it is installed (the same bits), else
    itself. Loaded once per process, on first use."""
    global _PROXIMITY
    if _PROXIMITY is None:
        from sitcov._jit import compiled, typed_entry

        k = np.array([2.3, 0.9, 0.25, 0.25, 3.0])
        example = (0.0, 0.0, 0.3, 5.0, 0.1, 4.0, 1.0, 1.2, 1.0, 0.0, k, True)
        helpers = (
            _axes_overlap,
            _corners_to_box,
            box_distance,
            box_distance_flat,
            time_to_collision,
        )
        _PROXIMITY = typed_entry(compiled(proximity, *example, helpers=helpers)) or proximity
    return _PROXIMITY


class ProximityMonitor:
    """:class:`DistanceMonitor` and :class:`TTCMonitor` in one object (the built-in
    list's): per active actor one call of :func:`proximity`, compiled when numba is
    there, which computes both; the box distance under the distance monitor's rule (only
    when it may be a new minimum, every fourth step while farther than :data:`FAR`).
    Reports the same ``min_distance`` and ``min_ttc``.
    """

    def __init__(self, world: Any) -> None:
        ego = world.ego
        n = len(world.actors)
        self.best = [math.inf] * n
        self.best_ttc: list[float | None] = [None] * n
        self.best_drac: list[float | None] = [None] * n
        self._reach = [ego.radius + a.radius for a in world.actors]
        self._kernel = kernel = proximity_fn()
        # the constants as a float array for the compiled kernel, plain floats for Python
        pack = np.array if kernel is not proximity else tuple
        self._k = [
            pack((ego.half_l, ego.half_w, a.half_l, a.half_w, ego.disc + a.disc))
            for a in world.actors
        ]

    def update(self, world: Any) -> None:
        """Box distance (when it may be a new minimum) and TTC of each active actor."""
        e = world.ego.body
        ex, ey, eyaw, evx, evy = e.x, e.y, e.yaw, e.vx, e.vy
        far_step = world.k & 3 == 0
        best, best_ttc, best_drac = self.best, self.best_ttc, self.best_drac
        kernel = self._kernel
        for i, a in enumerate(world.actors):
            if not a.active:
                continue
            gap = a.gap
            near = gap - self._reach[i] < best[i] and (gap < FAR or far_step)
            b = a.body
            d, ttc, drac = kernel(
                ex, ey, eyaw, evx, evy, b.x, b.y, b.yaw, b.vx, b.vy, self._k[i], near
            )
            if d < best[i]:
                best[i] = d
            if ttc >= 0.0 and (best_ttc[i] is None or ttc < best_ttc[i]):
                best_ttc[i] = ttc
            if drac >= 0.0 and (best_drac[i] is None or drac > best_drac[i]):
                best_drac[i] = drac

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``min_distance`` (None if never measured), ``min_ttc`` and ``max_drac`` per
        actor; the run's ``max_drac`` (the largest over all actors)."""
        for a, d, ttc, drac in zip(
            world.actors, self.best, self.best_ttc, self.best_drac, strict=True
        ):
            actors[a.name]["min_distance"] = d if math.isfinite(d) else None
            actors[a.name]["min_ttc"] = ttc
            actors[a.name]["max_drac"] = drac
        run["max_drac"] = _largest(self.best_drac)


def _largest(values: Sequence[float | None]) -> float | None:
    """The largest of the values that are not None (None if there is none)."""
    return max((v for v in values if v is not None), default=None)


class CollisionMonitor:
    """The ego's box overlaps an active actor's box: the run ends as ``collision``.

    Records where: the centroid of the two boxes' overlap on the first step they overlap
    (:func:`contact_point`, map frame [m]), the ego's heading [rad] and speed [m/s] then,
    and the kind of the road user hit (the report's collision map draws them).
    """

    def __init__(self, world: Any) -> None:
        self.speed: float | None = None
        self.point: tuple[float, float] | None = None
        self.heading: float | None = None

    def update(self, world: Any) -> str | None:
        """``"collision"`` on the first overlap (sets ``world.collision``)."""
        ego = world.ego
        r = ego.radius
        for a in world.actors:
            if a.gap < r + a.radius and overlap(ego.box(), a.box()):  # gap: inf if inactive
                evx, evy = ego.velocity()
                vx, vy = a.velocity()
                self.speed = math.hypot(vx - evx, vy - evy)
                self.point = contact_point(ego.box(), a.box())
                self.heading = ego.body.yaw
                world.collision = a
                return "collision"
        return None

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``collided`` per actor; the relative speed of the impact; the run's
        ``collision_point`` ([x, y] or None), ``collision_heading`` (the ego's) and
        ``collision_kind`` (the hit road user's)."""
        for a in world.actors:
            actors[a.name]["collided"] = world.collision is a
        actors["_collision_speed"] = self.speed
        hit = world.collision
        run["collision_point"] = None if self.point is None else list(self.point)
        run["collision_heading"] = self.heading
        run["collision_kind"] = None if hit is None else hit.kind


class ActorCollisionMonitor:
    """Collisions between two actors other than the ego: recorded, never end the run.

    Both actors brake to a stop (``Actor.crashed``). Each pair is recorded once.
    """

    def __init__(self, world: Any) -> None:
        self.events: list[dict[str, Any]] = []
        self.seen: set[tuple[str, str]] = set()
        actors = world.actors
        # every pair once, in the order of the actors, with its squared reach
        self.pairs = [
            (a, b, (a.radius + b.radius) * (a.radius + b.radius))
            for i, a in enumerate(actors)
            for b in actors[i + 1 :]
        ]

    def update(self, world: Any) -> None:
        """Bounding circles first, boxes when those touch."""
        for a, b, reach2 in self.pairs:
            if not (a.active and b.active):
                continue
            ba, bb = a.body, b.body
            dx, dy = bb.x - ba.x, bb.y - ba.y
            if dx * dx + dy * dy > reach2 or (a.name, b.name) in self.seen:
                continue
            if overlap(a.box(), b.box()):
                self.seen.add((a.name, b.name))
                (avx, avy), (bvx, bvy) = a.velocity(), b.velocity()
                self.events.append(
                    {
                        "actors": [a.name, b.name],
                        "kinds": [a.kind, b.kind],
                        "time": round(world.t, 10),
                        "speed": math.hypot(bvx - avx, bvy - avy),
                    }
                )
                a.crashed = b.crashed = True

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """``actor_collisions``: a list of {actors, kinds, time, speed} (extended scenes)."""
        actors["_actor_collisions"] = self.events


class LeaveMapRule:
    """An actor within :data:`GOAL_TOLERANCE` of its route's end leaves the world."""

    def __init__(self, world: Any) -> None:
        self.ends = [a.route.length - GOAL_TOLERANCE for a in world.actors]
        self._pairs = list(zip(world.actors, self.ends, strict=True))

    def update(self, world: Any) -> None:
        """Deactivate actors at the end of their routes."""
        for a, end in self._pairs:
            if a.active and a.s >= end:
                a.active = False

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """Nothing to report."""


class GoalMonitor:
    """The ego is within :data:`GOAL_TOLERANCE` of its route's end: the run ends as ``goal``."""

    def __init__(self, world: Any) -> None:
        self.goal = world.ego.route.length - GOAL_TOLERANCE

    def update(self, world: Any) -> str | None:
        """``"goal"`` once reached."""
        return "goal" if world.ego.s >= self.goal else None

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """Nothing to report."""


class EarlyEndMonitor:
    """Ends a run as ``stopped`` once nothing can change any more.

    The ego's AEB has latched (``world.driver.latched``: an AEB that releases never ends a
    run early) and the ego stands; then the run
    is over when no active actor can still reach it. An actor cannot when it is
    ``clear`` (the stopped ego's box lies outside the corridor the actor will still sweep:
    its remaining route widened by half its width and :data:`CORRIDOR_MARGIN`, and the road
    holds it in its route's tightest curve at the speed it may still reach with a
    :data:`LANE_HOLD_MARGIN` safety factor; checked once, the ego no longer moves), or
    ``away`` (past its conflict zone and moving away), or ``stuck`` (its controller will
    never move it again, e.g. the timing law braked waiting for an ego that stands).

    The route progress facts must be those of the whole run, so the run also waits until
    the standing ego's path is clear (``progress.settled()``, ``_progress.py``).

    Args:
        enabled: False never ends a run early.
        progress: the run's ``ProgressMonitor`` (None: not waited for).
    """

    def __init__(self, world: Any, enabled: bool = True, progress: Any = None) -> None:
        self.enabled = enabled
        self.progress = progress
        self.clear: list[bool | None] = [None] * len(world.actors)
        self.zone_end = [
            math.inf if a.conflict is None else min(a.conflict.s_ov_end, a.conflict.s_ov + PET_ZONE)
            for a in world.actors
        ]

    def _clear(self, world: Any, a: Any) -> bool:
        v = a.controller.reach_speed(a)
        ego = world.ego
        return world.mu * G >= LANE_HOLD_MARGIN * v * v * a.route.max_curvature and (
            corridor_gap(a.route, a.s, ego.box()) > a.half_w + CORRIDOR_MARGIN
        )

    def update(self, world: Any) -> str | None:
        """``"stopped"`` when the ego stands latched and no actor can reach it."""
        if not self.enabled or not world.driver.latched:
            return None
        if world.ego.body.speed >= STOPPED_SPEED:
            return None
        for i, a in enumerate(world.actors):
            if self.clear[i] is None and a.active:
                self.clear[i] = self._clear(world, a)
        for i, a in enumerate(world.actors):
            if not a.active or self.clear[i]:
                continue
            away = a.s - a.half_l > self.zone_end[i] and a.gap > a.prev_gap
            if not (away or a.controller.stuck(a)):
                return None
        if self.progress is not None and not self.progress.settled():
            return None
        return "stopped"

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """Nothing to report."""


def default_monitors(
    world: Any,
    lane: LaneDepartureMonitor,
    road: RoadDepartureMonitor,
    early_end: bool,
    budget: float = 60.0,
) -> list[Any]:
    """The monitors of an embedded run, in the order the loop calls them (``budget``: the
    run's time limit [s], for the route progress facts; without ``early_end`` there is no
    early-end monitor)."""
    progress = ProgressMonitor(world, budget)  # also the goal monitor
    return [
        EgoRouteMonitor(world.ego.route, lane, road),
        PETMonitor(world),
        ProximityMonitor(world),
        CollisionMonitor(world),
        *([ActorCollisionMonitor(world)] if len(world.actors) > 1 else []),
        LeaveMapRule(world),
        progress,
        # a stack that can never latch (the built-in stack with its releasing AEB) never
        # ends a run early: no monitor to call every step
        *([EarlyEndMonitor(world, early_end, progress)] if early_end else []),
    ]


def fused_update(world: Any, monitors: Sequence[Any]) -> tuple[Any, list[Any]]:
    """The built-in monitors' per-step work in one call, when ``monitors`` starts with
    the list :func:`default_monitors` makes (exactly those classes, in that order):
    ``(update, rest)``, where ``update()`` does what the leading monitors' ``update(world)``
    calls do one after the other (the same operations in the same order on the same
    objects: their reports are unchanged) and ``rest`` are the monitors left to call
    after it. Any other list (a user's own, a subclass): ``(None, list(monitors))``, every
    monitor called through the public protocol.

    Why: the run loop calls the monitors on every step, and six Python calls that each
    look up the world, the ego and the actors again cost more than the work they do.
    """
    ms = list(monitors)
    n = len(ms)
    classes = [type(m) for m in ms[:7]]
    with_actor_pairs = classes[4:5] == [ActorCollisionMonitor]
    expected = [EgoRouteMonitor, PETMonitor, ProximityMonitor, CollisionMonitor]
    expected += [ActorCollisionMonitor] if with_actor_pairs else []
    expected.append(LeaveMapRule)
    k = len(expected)
    if classes[:k] != expected or n <= k or type(ms[k]) is not ProgressMonitor:
        return None, ms
    route, pet, prox, hit, leave, progress = ms[0], ms[1], ms[2], ms[3], ms[k - 1], ms[k]
    pairs = ms[4] if with_actor_pairs else None
    ego = world.ego
    body = ego.body
    xs, ys, sin, cos = route.xs, route.ys, route.sin, route.cos
    lane, road = route.lane, route.road
    hs, left, right, half_l, half_w = route._road
    lane_limit = lane.limit
    half_e = pet.half_e
    best, best_ttc, best_drac = prox.best, prox.best_ttc, prox.best_drac
    reach, consts, kernel = prox._reach, prox._k, prox._kernel
    # the first active actor's proximity call also gives the route offset (one call)
    kernel_r = proximity_route_fn()
    fast = kernel_r is not proximity_route
    rt = route_rows(route, fast)
    pack = np.array if fast else tuple
    consts_r = [pack((*c, half_l, half_w)) for c in consts]
    items = [(j, a, z) for j, (a, z) in enumerate(pet._pairs)]
    leave_pairs = leave._pairs
    progress_update, goal_s = progress.update, progress.goal_s
    sine = math.sin

    def update() -> str | None:
        b = body
        bx, by, yaw = b.x, b.y, b.yaw
        t = world.t
        i = ego.hint
        # PETMonitor.update, ProximityMonitor.update and CollisionMonitor's bounding
        # circles in one pass over the actors (each actor's state is its own: the same
        # values as three passes); the first active actor's call also gives
        # EgoRouteMonitor's offset and the road's pre-test (proximity_route)
        s_e = ego.s
        evx, evy = b.vx, b.vy
        far_step = world.k & 3 == 0
        touch = False
        lat = None
        for j, a, z in items:
            if z[5] is None:
                if z[4] is None and s_e + half_e >= z[0]:
                    z[4] = t
                if s_e - half_e > z[1]:
                    z[5] = t
            if not a.active:
                continue
            if z[7] is None:
                s, ha = a.s, a.half_l
                if z[6] is None and s + ha >= z[2]:
                    z[6] = t
                if s - ha > z[3]:
                    z[7] = t
            gap, r = a.gap, reach[j]  # r: the ego's radius plus the actor's
            near = gap - r < best[j] and (gap < FAR or far_step)
            o = a.body
            if lat is None:
                lat, clear, d, ttc, drac = kernel_r(
                    rt, i, bx, by, yaw, evx, evy, o.x, o.y, o.yaw, o.vx, o.vy, consts_r[j], near
                )
            else:
                d, ttc, drac = kernel(
                    bx, by, yaw, evx, evy, o.x, o.y, o.yaw, o.vx, o.vy, consts[j], near
                )
            if d < best[j]:
                best[j] = d
            if ttc >= 0.0 and (best_ttc[j] is None or ttc < best_ttc[j]):
                best_ttc[j] = ttc
            if drac >= 0.0 and (best_drac[j] is None or drac > best_drac[j]):
                best_drac[j] = drac
            if gap < r:
                touch = True
        # EgoRouteMonitor.update (after the actors' pass: neither reads the other's state)
        if lat is None:  # no active actor: the offset and pre-test here
            lat = -(bx - xs[i]) * sin[i] + (by - ys[i]) * cos[i]
            if road.time is None:
                r = half_w + half_l * abs(sine(yaw - hs[i])) + CLEARANCE_SLACK
                clear = lat + r < left[i] and r - lat < right[i]
        if lane.time is None and (lat > lane_limit or -lat > lane_limit):
            lane.update(t, bx, by, yaw, i, lat)
        if road.time is None and not clear:
            road.update(t, bx, by, yaw, i, lat)
        lat = -lat if lat < 0.0 else lat
        if lat > route.max_lat:
            route.max_lat = lat
        # CollisionMonitor.update: its own call once some actor's bounding circle touches
        if touch:
            reason = hit.update(world)
            if reason is not None:
                return reason
        if pairs is not None:
            pairs.update(world)
        # LeaveMapRule.update
        for a, end in leave_pairs:
            if a.active and a.s >= end:
                a.active = False
        # ProgressMonitor.update: the new best and the goal, and the moving ego's reset,
        # written out; its own call while the ego stands (which then finds no new best)
        if s_e > progress.best:
            progress.best = s_e
            if s_e >= goal_s:
                progress.goal_time = t
                return "goal"
        if b.vx * b.vx + b.vy * b.vy >= _STILL2:
            progress.clear_since = None
            return None
        return progress_update(world)

    return update, ms[k + 1 :]
