"""Controllers of the road users other than the ego: what each does every control step.

A controller turns the world's state into ``(throttle, brake, steer)`` for its actor's body
(``_bodies.py``); lateral control follows the actor's route (:func:`steer_on_route`).
Every controller brakes for what its actor's watcher sees on its path (:func:`react`, the
IDM of ``_yielding``); how it sees the ego is the controller's choice.

- :class:`TimingController`: the paper's timing law (``sitcov.sim._adversary``) for a car
  that shares a conflict with the ego: wait until the ego moves, regulate the arrival
  time at the conflict to the ego's, then cruise on at 15 km/h ("arrive when the ego
  arrives, then continue"). Before its switch it ignores the ego, after it it brakes for
  an ego standing in its path; it yields to other road users throughout.
- :class:`PacedController`: a timed pedestrian or cyclist: starts when, at its own speed,
  it arrives with the ego, and keeps to speeds people go.
- :class:`ScriptedController`: background traffic: cruise at a speed, optionally stop at
  an arc length for a while (or for good), then go on; yields to and follows everyone.
- :class:`CrossingController`: pedestrian behaviours on a crosswalk: ``cross`` (start to
  cross when the ego is ``time`` seconds from the crosswalk), ``kerb`` (walk up to the kerb
  then and stop there for good), ``hesitate`` (walk up to the kerb, pause, then cross).

Controllers read the world through the :class:`~sitcov.sim.embedded._actors.Actor` they
drive and the world (``world.ego``, ``world.ego_speed``, ``world.ego_decel``,
``world.actors``, ``world.t``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import replace
from math import cos, sin
from typing import TYPE_CHECKING, Any

import numpy as np

from sitcov.sim._adversary import AdversaryController, AdversaryParams, pure_pursuit, timing_law
from sitcov.sim.embedded._dynamics import (
    DT,
    SUBSTEPS,
    Vehicle,
    _constants,
    default_params,
    integrate,
    integrate_tracked,
)
from sitcov.sim.embedded._path import _bisect_right, _point_at
from sitcov.sim.embedded._path import _track as track
from sitcov.sim.embedded._yielding import (
    EGO_ALL,
    EGO_NEVER,
    EGO_STANDING,
    REACH,
    SLOW,
    STANDING,
    STOP_HORIZON,
    limit,
)

if TYPE_CHECKING:
    from sitcov.sim.embedded._actors import Actor

#: ``math.hypot`` under the name :func:`_timed_car` uses (``_jit.py`` compiles that code
#: with the name bound to its correctly rounded version: the same bits).
hypot = math.hypot

#: An ego braking harder than this [m/s^2] may stand within ``STOP_HORIZON`` of ``SLOW``:
#: a timed car after its switch looks whether it stands in its path.
EGO_BRAKING = SLOW / STOP_HORIZON
#: ... if the ego is this close (centre to centre) [m]: a car looks this far ahead
NEAR = REACH["car"] + 10.0
#: Speed P-gain of scripted and pedestrian controllers [1/(m/s)].
SPEED_GAIN = 0.5


def steer_on_route(actor: Actor, lookahead: float) -> float:
    """Steer command in [-1, 1] that follows ``actor.route`` from its arc length.

    Cars and bicycles: pure pursuit of the route point ``lookahead`` metres ahead, from the
    rear axle; a pedestrian turns towards that point at its turn rate.
    """
    return lateral_controller(actor)(lookahead)


def lateral_controller(actor: Actor, dt: float = 0.05) -> Callable[[float], float]:
    """``lookahead -> steer`` for ``actor`` (see :func:`steer_on_route`), its constants bound
    once: controllers call it every step."""
    body, point_at = actor.body, actor.route.point_at
    cos, sin = math.cos, math.sin
    if actor.kind == "car":
        lr, wb, steer_max = body.p.lr, body.p.wheelbase, body.p.steer_max
        kernel = _car_kernel()
        pts = _car_points(actor.route, kernel is not _car_steer)

        def car(lookahead: float) -> float:
            return kernel(pts, actor.s + lookahead, body.x, body.y, body.yaw, lr, wb, steer_max)

        return car
    spec = body.spec
    if actor.kind == "cyclist":
        half, wb, steer_max = 0.5 * spec.wheelbase, spec.wheelbase, spec.steer_max

        def bicycle(lookahead: float) -> float:
            tx, ty, _ = point_at(actor.s + lookahead)
            yaw = body.yaw
            c, s = cos(yaw), sin(yaw)
            delta = pure_pursuit(body.x - half * c, body.y - half * s, yaw, tx, ty, wb)
            return max(-1.0, min(1.0, delta / steer_max))

        return bicycle
    turn = spec.turn_rate * dt

    def walker(lookahead: float) -> float:
        tx, ty, _ = point_at(actor.s + lookahead)
        err = math.atan2(ty - body.y, tx - body.x) - body.yaw
        err = math.atan2(sin(err), cos(err))
        return max(-1.0, min(1.0, err / turn))

    return walker


def _car_steer(
    pts: Any, s: float, x: float, y: float, yaw: float, lr: float, wb: float, steer_max: float
) -> float:
    """A car's steer command in [-1, 1]: pure pursuit from its rear axle (``lr`` behind
    the centre (x, y)) of the route point at arc length ``s``, over ``steer_max``.
    ``pts``: the route's (xs, ys, hs, ss)."""
    tx, ty, _ = _point_at(pts[0], pts[1], pts[2], pts[3], s)
    c, sn = cos(yaw), sin(yaw)
    return pure_pursuit(x - lr * c, y - lr * sn, yaw, tx, ty, wb) / steer_max


_CAR: Any = None


def _car_kernel() -> Any:
    """:func:`_car_steer` compiled by numba when it is installed (``_jit.py``; the same
    bits), else itself. Loaded once per process."""
    global _CAR
    if _CAR is None:
        from sitcov._jit import compiled, typed_entry

        pts = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        example = (pts, 1.5, 0.0, 0.1, 0.2, 1.4, 2.7, 0.6)
        helpers = (("bisect_right", _bisect_right), _point_at, pure_pursuit)
        _CAR = typed_entry(compiled(_car_steer, *example, helpers=helpers)) or _car_steer
    return _CAR


def _timed_car(
    pts: Any,
    k: Any,
    phase: int,
    ego_s: float,
    ego_speed: float,
    s: float,
    x: float,
    y: float,
    yaw: float,
    vx: float,
    vy: float,
) -> tuple[int, float, float, float]:
    """A timed car's step (:class:`TimingController`): the law (``timing_law``) from the
    car's speed, then its steering (:func:`_car_steer`) at the law's look-ahead:
    ``(phase, throttle, brake, steer)``. One compiled call per step instead of the law's
    Python and the steering's kernel call.

    ``k``: ``law_constants`` then (conflict start on the ego's route, on the car's route,
    look-ahead time, minimum look-ahead, lr, wheelbase, steer_max).
    """
    speed = hypot(vx, vy)  # Vehicle.speed
    phase, thr, brk = timing_law(phase, k, k[7] - ego_s, ego_speed, k[8] - s, speed)
    ahead = k[9] * speed
    steer = _car_steer(pts, s + (ahead if ahead > k[10] else k[10]), x, y, yaw, k[11], k[12], k[13])
    return phase, thr, brk, steer


_TIMED: Any = None


def _timed_kernel() -> Any:
    """:func:`_timed_car` compiled by numba when it is installed (the same bits), else
    itself. Loaded once per process."""
    global _TIMED
    if _TIMED is None:
        from sitcov._jit import compiled, typed_entry

        pts = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        k = np.array([3.0, 20.0, 4.2, 0.5, 0.5, 0.1, 1.0, 30.0, 25.0, 0.8, 4.0, 1.4, 2.7, 0.6])
        example = (pts, k, 1, 5.0, 3.0, 2.0, 0.0, 0.1, 0.2, 3.0, 0.01)
        helpers = (("bisect_right", _bisect_right), _point_at, pure_pursuit, _car_steer, timing_law)
        _TIMED = typed_entry(compiled(_timed_car, *example, helpers=helpers)) or _timed_car
    return _TIMED


#: How many of :func:`_timed_car_move`'s ``kk`` are the law's ``k`` (the rest: the
#: body's ``kc``).
TIMED_K = 14


def _timed_car_move(
    pts: Any,
    kk: Any,
    phase: int,
    ego_s: float,
    ego_speed: float,
    s: float,
    x: float,
    y: float,
    yaw: float,
    vx: float,
    vy: float,
    r: float,
    hint: int,
    mu: float,
    lateral_accel: float,
    dt: float,
    substeps: int,
    react: int,
) -> tuple[int, float, float, float, int, float, float, float, float, float, float, float, int]:
    """A timed car's whole step when its watcher has no say: :func:`_timed_car`, then its
    body moved under that command as ``Vehicle.step`` moves it on its route (the same
    clamps, ``integrate_tracked``, or only the tracking while it stands with no drive).
    ``(phase, throttle, brake, steer, moved, x, y, yaw, vx, vy, r, s, segment)``.

    ``react``: bit 1 if the watcher must be asked in the law's phase 1, bit 2 in phase 2
    (:meth:`TimingController.drive`); then nothing moves (``moved`` 0: the caller asks and
    moves the body). ``moved``: 1 stood (tracked only), 2 integrated. ``kk``: the law's
    ``k`` (:data:`TIMED_K` values, as :func:`_timed_car` takes them) then the body's
    constants ``kc``, in one array (numba unboxes each array argument on every call, the
    dearest part of it); ``pts``: the route's (xs, ys, hs, ss) as :func:`_timed_car` takes
    them, then its points as ``Vehicle.step`` passes them (``route``: xs, ys, ss), in one
    array (:func:`_car_move_points`); the body's steering angle is ``steer`` clamped to
    [-1, 1] times ``k[13]`` (its ``steer_max``). One compiled call per step instead of two
    and their Python in between.
    """
    k, kc = kk[:TIMED_K], kk[TIMED_K:]
    route = pts[4:]
    phase, thr, brk, steer = _timed_car(pts, k, phase, ego_s, ego_speed, s, x, y, yaw, vx, vy)
    if (phase == 2 and react & 2) or (phase == 1 and react & 1):
        return phase, thr, brk, steer, 0, x, y, yaw, vx, vy, r, s, hint
    throttle = 0.0 if thr < 0.0 else (1.0 if thr > 1.0 else thr)
    if throttle == 0.0 and vx == 0.0 and vy == 0.0 and r == 0.0:
        s, i = track(route, x, y, hint)
        return phase, thr, brk, steer, 1, x, y, yaw, vx, vy, r, s, i
    brake = 0.0 if brk < 0.0 else (1.0 if brk > 1.0 else brk)
    st = -1.0 if steer < -1.0 else (1.0 if steer > 1.0 else steer)
    x, y, yaw, vx, vy, r, s, i = integrate_tracked(
        kc, x, y, yaw, vx, vy, r, throttle, brake, st * k[13], mu, lateral_accel, dt,
        substeps, route, hint,
    )  # fmt: skip
    return phase, thr, brk, steer, 2, x, y, yaw, vx, vy, r, s, i


_TIMED_MOVE: Any = None


def _timed_move_kernel() -> Any:
    """:func:`_timed_car_move` compiled by numba when it is installed (the same bits),
    else itself. Loaded once per process."""
    global _TIMED_MOVE
    if _TIMED_MOVE is None:
        from sitcov._jit import compiled, typed_entry

        pts = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        k = np.array([3.0, 20.0, 4.2, 0.5, 0.5, 0.1, 1.0, 30.0, 25.0, 0.8, 4.0, 1.4, 2.7, 0.6])
        kc = _constants(Vehicle(default_params(), 0.0, 0.0, 0.0)._k, True)
        route = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        kk, pts = np.concatenate((k, kc)), np.concatenate((pts, route))
        example = (pts, kk, 1, 5.0, 3.0, 2.0, 0.0, 0.1, 0.2, 3.0, 0.01, 0.0, 0)
        example += (1.0, 0.0, DT, SUBSTEPS, 0)
        helpers = (("bisect_right", _bisect_right), _point_at, pure_pursuit, _car_steer)
        helpers += (timing_law, _timed_car, integrate, ("track", track), integrate_tracked)
        fast = compiled(_timed_car_move, *example, helpers=helpers)
        _TIMED_MOVE = typed_entry(fast) or _timed_car_move
    return _TIMED_MOVE


def _car_move_points(route: Any, points: Any) -> Any:
    """:func:`_timed_car_move`'s ``pts``: the route's (xs, ys, hs, ss) then ``points``, the
    body's route points (xs, ys, ss: ``Actor._points``), as one float array when
    ``points`` is one (compiled), else one tuple. Once per route and points array, not
    per run (a map's routes are cached, so runs share them; the kernel only reads it)."""
    if not isinstance(points, np.ndarray):
        return (route.xs, route.ys, route.hs, route.ss, *points)
    if points is getattr(route, "_track_array", None):  # the route's own (Path.tracker)
        return _car_move_array(route)
    return np.concatenate((_car_points(route, True), points))


@functools.lru_cache(maxsize=256)
def _car_move_array(route: Any) -> Any:
    """:func:`_car_move_points` of the route's own points array (cached per route)."""
    return np.concatenate((_car_points(route, True), route._track_array))


@functools.lru_cache(maxsize=256)
def _car_points(route: Any, compiled: bool) -> Any:
    """The route's (xs, ys, hs, ss) as :func:`_car_steer` takes them fastest: one float
    array for the ``compiled`` one (one type check), else the tuples. Once per route, not
    per run (a map's routes are cached, so runs share them; the kernel only reads it)."""
    pts = (route.xs, route.ys, route.hs, route.ss)
    return np.array(pts, dtype=np.float64) if compiled else pts


def _speed_command(actor: Actor, target: float, dt: float) -> tuple[float, float]:
    """(throttle, brake) towards ``target`` [m/s]: a P controller for a car; a cyclist or
    a pedestrian reaches the target within its acceleration limits in one step if it can."""
    speed = actor.body.speed
    if target <= 0.0 and speed < STANDING:
        return 0.0, 1.0
    if actor.kind == "car":
        u = SPEED_GAIN * (target - speed)
    else:
        spec = actor.spec
        u = (target - speed) / ((spec.a_max if target > speed else spec.b_max) * dt)
    return (min(u, 1.0), 0.0) if u >= 0.0 else (0.0, min(-u, 1.0))


def react(
    actor: Actor, world: Any, thr: float, brk: float, v0: float, ego: int = EGO_ALL
) -> tuple[float, float]:
    """(throttle, brake) no stronger than the IDM allows for the nearest obstacle on the
    actor's path (``_yielding``); unchanged when nothing is ahead. ``v0``: its desired
    speed [m/s]; ``ego``: how it sees the ego (``_yielding.EGO_ALL`` ...)."""
    w = actor.watcher
    if w is None or not w.entries:
        return thr, brk
    accel = w.accel(v0, ego, world.ego_decel)
    if accel == math.inf:
        return thr, brk
    spec = actor.spec
    u0 = thr - brk
    u = limit(u0, accel, spec.a_max, spec.b_max)
    if u == u0:
        return thr, brk
    return (u, 0.0) if u >= 0.0 else (0.0, min(-u, 1.0))


def _lookahead(actor: Actor, speed: float) -> float:
    return max(4.0, 0.8 * speed) if actor.kind != "pedestrian" else max(1.0, 0.5 * speed)


class TimingController:
    """The paper's timing law for an actor sharing a conflict with the ego.

    Args:
        params: the adversary's tuning with the situation's switch distance.
        s_ego, s_self: arc lengths of the conflict's start on the ego's and the actor's
            route [m] (inf: no conflict, the actor cruises once the ego moves).
        cruise_speed: the actor's speed after the switch [m/s] (None: ``params``').
    """

    name = "timed"

    def __init__(
        self,
        params: AdversaryParams,
        s_ego: float,
        s_self: float,
        cruise_speed: float | None = None,
    ) -> None:
        if cruise_speed is not None:
            params = replace(params, cruise_speed=cruise_speed)
        self.params = params
        self.law = AdversaryController(params, has_conflict=math.isfinite(s_ego))
        self.s_ego, self.s_self = s_ego, s_self
        self.switch_time: float | None = None
        self.switch_gap: float | None = None
        self.brake = 0.0
        self._steer: Callable[[float], float] | None = None
        self._car: tuple[Any, Any, Any] | None = None  # _bind_car's, at the first step
        self._move: Any = None  # drive's (points, constants, kernel), at its first step
        self._looks = False  # any road user meets its route (set with _car)
        self._still: Any = None  # (s, ego s, law's command) of a standoff step, and
        self._still_cmd = (0.0, 0.0)  # what react answered then
        self._others = False  # road users besides the ego do
        # AdversaryController.lookahead's constants, read every step
        self._la_min, self._la_time = params.lookahead_min, params.lookahead_time

    def command(self, actor: Actor, world: Any) -> tuple[float, float, float]:
        """(throttle, brake, steer) for this step (a car's in one call: :func:`_timed_car`)."""
        if actor.kind == "car":
            return self._car_command(actor, world)
        speed = actor.body.speed
        law = self.law
        s_ego = world.ego.s
        thr, brk = law.command(self.s_ego - s_ego, world.ego_speed, self.s_self - actor.s, speed)
        if law.phase_index == 2:  # cruise
            if self.switch_time is None:
                self.switch_time, self.switch_gap = world.t, self.s_ego - s_ego
            thr, brk = react(actor, world, thr, brk, self.params.cruise_speed, EGO_STANDING)
        elif law.phase_index == 1:
            thr, brk = react(actor, world, thr, brk, self.params.cruise_speed, EGO_NEVER)
        self.brake = brk
        steer = self._steer
        if steer is None:
            steer = self._steer = lateral_controller(actor, world.dt)
        ahead = self._la_time * speed  # law.lookahead(speed), inlined
        return thr, brk, steer(ahead if ahead > self._la_min else self._la_min)

    def _car_command(self, actor: Actor, world: Any) -> tuple[float, float, float]:
        """:meth:`command` of a car: the law and the steering in one :func:`_timed_car`."""
        if self._car is None:
            self._start_car(actor)
        kernel, pts, k = self._car
        law, b, s_ego = self.law, actor.body, world.ego.s
        phase, thr, brk, steer = kernel(
            pts, k, law.phase_index, s_ego, world.ego_speed, actor.s, b.x, b.y, b.yaw, b.vx, b.vy
        )
        law.phase_index = phase
        if phase == 2:  # cruise
            if self.switch_time is None:
                self.switch_time, self.switch_gap = world.t, self.s_ego - s_ego
            if self._reacts(actor, world) & 2:
                thr, brk = self._react_cruise(actor, world, thr, brk)
        elif phase == 1 and self._others:
            thr, brk = react(actor, world, thr, brk, self.params.cruise_speed, EGO_NEVER)
        self.brake = brk
        return thr, brk, steer

    def _start_car(self, actor: Actor) -> None:
        """Bind the car's kernel and constants at its first step; who meets its route."""
        self._car = self._bind_car(actor)
        w = actor.watcher
        self._looks = w is not None and bool(w.entries)
        self._others = self._looks and w.others

    def _reacts(self, actor: Actor, world: Any) -> int:
        """In which phases the watcher has a say this step: bit 1 in phase 1 (road users
        besides the ego meet its route), bit 2 in cruise (they do, or the ego is slow or
        braking hard and near)."""
        cruise = self._looks and (
            self._others
            or (world.ego_speed < SLOW or world.ego_decel > EGO_BRAKING)
            and actor.gap < NEAR
        )
        return (1 if self._others else 0) | (2 if cruise else 0)

    def _react_cruise(
        self, actor: Actor, world: Any, thr: float, brk: float
    ) -> tuple[float, float]:
        """The watcher's answer in cruise (it sees the ego only while it stands)."""
        b, s_ego = actor.body, world.ego.s
        # both standing where they stood last step: the same answer (a standoff with the
        # ego lasts long; nothing else can have moved without others)
        still = not self._others and b.vx == b.vy == 0.0 and world.ego_speed == 0.0
        if still and self._still == (actor.s, s_ego, thr, brk):
            return self._still_cmd
        key = (actor.s, s_ego, thr, brk)
        thr, brk = react(actor, world, thr, brk, self.params.cruise_speed, EGO_STANDING)
        if still:
            self._still, self._still_cmd = key, (thr, brk)
        return thr, brk

    def drive(self, actor: Actor, world: Any, mu: float, lateral: float, dt: float) -> None:
        """:meth:`command` and the actor's move under it (``Actor.move``) in one: a car's
        in one compiled call (:func:`_timed_car_move`) unless its watcher has a say this
        step (the same values as the two calls)."""
        move = self._move
        if move is None:
            points = actor._points
            if actor.kind != "car" or points is None:
                thr, brk, steer = self.command(actor, world)
                actor.move(thr, brk, steer, mu, lateral, dt)
                return
            if self._car is None:
                self._start_car(actor)
            b = actor.body
            move = self._move = (
                _car_move_points(actor.route, points),
                self._move_constants(b),
                _TIMED_MOVE or _timed_move_kernel(),
            )
        pts, kk, kernel = move
        law, b = self.law, actor.body
        reacts = 0  # _reacts, written out (this runs every step)
        if self._looks:
            others = self._others
            if others or (
                (world.ego_speed < SLOW or world.ego_decel > EGO_BRAKING) and actor.gap < NEAR
            ):
                reacts = 3 if others else 2
        phase, thr, brk, steer, moved, x, y, yaw, vx, vy, r, s, i = kernel(
            pts, kk, law.phase_index, world.ego.s, world.ego_speed, actor.s, b.x, b.y, b.yaw,
            b.vx, b.vy, b.r, actor.hint, mu, lateral, dt, SUBSTEPS, reacts,
        )  # fmt: skip
        law.phase_index = phase
        if phase == 2 and self.switch_time is None:
            self.switch_time, self.switch_gap = world.t, self.s_ego - world.ego.s
        if not moved:  # the watcher's say, then the move (as command and Actor.move)
            if phase == 2:
                thr, brk = self._react_cruise(actor, world, thr, brk)
            else:
                thr, brk = react(actor, world, thr, brk, self.params.cruise_speed, EGO_NEVER)
            self.brake = brk
            actor.move(thr, brk, steer, mu, lateral, dt)
            return
        self.brake = brk
        if moved == 2:  # Vehicle.step's state and steering angle
            b.x, b.y, b.yaw, b.vx, b.vy, b.r = x, y, yaw, vx, vy, r
            b.steer = (-1.0 if steer < -1.0 else (1.0 if steer > 1.0 else steer)) * b.p.steer_max
        actor.s, actor.hint = s, i

    def _move_constants(self, b: Any) -> Any:
        """:func:`_timed_car_move`'s ``kk``: the law's constants (``_bind_car``'s) then
        the body's (``Vehicle.step``'s ``kc``), one array when they are arrays (compiled),
        else one tuple; made at the car's first step (the body's constants stay)."""
        k = self._car[2]
        kc = b._kc
        if kc is None:
            kc = b._kc = _constants(b._k)
        if len(k) != TIMED_K:
            raise ValueError(f"timed car: {len(k)} law constants, expected {TIMED_K}")
        if isinstance(k, np.ndarray) or isinstance(kc, np.ndarray):
            return np.concatenate((np.asarray(k, dtype=np.float64), kc))
        return (*k, *kc)

    def _bind_car(self, actor: Actor) -> tuple[Any, Any, Any]:
        """The kernel, the route's points and the constants of :func:`_timed_car`."""
        kernel = _timed_kernel()
        fast = kernel is not _timed_car
        p = actor.body.p
        k = (
            *self.law.constants,
            self.s_ego,
            self.s_self,
            self._la_time,
            self._la_min,
            p.lr,
            p.wheelbase,
            p.steer_max,
        )
        return kernel, _car_points(actor.route, fast), np.array(k) if fast else k

    def reach_speed(self, actor: Actor) -> float:
        """The speed the actor may still reach [m/s] (for the early end)."""
        return max(actor.body.speed, self.params.cruise_speed)

    def stuck(self, actor: Actor) -> bool:
        """Braked still before its switch: waits for an ego that will never come; or, after
        it, stands before a road user that stands too."""
        if self.law.phase_index == 0:
            return self.brake > 0.0 and actor.body.speed < STANDING
        w = actor.watcher
        ego = EGO_STANDING if self.law.phase_index == 2 else EGO_NEVER
        stands = self.law.phase_index == 1 and self.brake > 0.0 and actor.body.speed < STANDING
        return stands or (w is not None and w.blocked(ego))


#: The speed an accelerating ego is assumed to reach [m/s] (the reference stack's 25 km/h)
#: in :func:`ego_arrival`.
EGO_CRUISE = 25.0 / 3.6


def ego_arrival(d: float, v: float, a: float, floor: float) -> float:
    """The ego's arrival time [s] over ``d`` [m] at speed ``v`` [m/s] (floored at ``floor``)
    when it goes on accelerating at ``a`` [m/s^2] (if > 0) up to :data:`EGO_CRUISE` (or
    its speed, if faster), then holds it. Without the acceleration an ego that speeds up
    looks slower than it will be, and a road user timed on it starts late and must rush."""
    v = v if v > floor else floor
    cap = v if v > EGO_CRUISE else EGO_CRUISE
    if a <= 0.0 or v >= cap:
        return d / v
    t1 = (cap - v) / a
    d1 = (v + 0.5 * a * t1) * t1
    if d1 >= d:
        return (math.sqrt(v * v + 2.0 * a * d) - v) / a
    return t1 + (d - d1) / cap


def catch_speed(d: float, t: float, u: float, a: float) -> float:
    """The speed [m/s] to change to (from ``u``, at ``a`` [m/s^2]) and hold so as to cover
    ``d`` [m] in ``t`` [s]: ``d = v t - (v - u)^2 / (2 a)``, the smaller root; the fastest
    change (``u + a t``) if none does."""
    at = a * t
    disc = at * at - 2.0 * a * (d - t * u)
    return u + at - math.sqrt(disc) if disc > 0.0 else u + at


class PacedController:
    """A timed pedestrian or cyclist: meets the ego by when it starts, at a speed people go.

    The adversary's role without the timing law's creeping (the law floors nothing but the
    arrival-time estimate, so a walker synchronised from 2 m out crawls at 0.5 m/s):

    1. ``wait``: stands until the ego moves and the ego's arrival time at the conflict (its
       distance over its speed floored at ``min_speed``, as in the law, taking into account
       that it still speeds up: :func:`ego_arrival`) has dropped to the actor's own: its
       distance to the conflict at ``speed`` plus the time to reach that speed from
       standing (``speed / (2 a_max)``);
    2. ``regulate``: goes at the speed that would arrive with the ego (:func:`catch_speed`:
       from its speed now, getting there at ``a_max``), kept within [``low``, ``high``]
       (what people do), until the ego or the actor reaches the conflict;
    3. ``cruise``: on at ``speed``.

    From its start it stops short of a road user standing in its path (the ego only while
    it stands: ``_yielding.EGO_STANDING``), so it never walks into a standing car.

    Args:
        s_ego, s_self: arc lengths of the conflict's start on the ego's and the actor's
            route [m] (inf: no conflict: it goes once the ego moves).
        speed: its own cruising speed [m/s] (drawn per run: ``_bodies.SPEEDS``).
        low, high: the range it regulates in [m/s].
        params: the adversary's ``min_speed`` and ``start_speed``.
    """

    name = "timed"

    def __init__(
        self,
        s_ego: float,
        s_self: float,
        speed: float,
        low: float,
        high: float,
        params: AdversaryParams | None = None,
    ) -> None:
        p = params or AdversaryParams()
        self.params = replace(p, switch_distance=0.0, cruise_speed=float(speed))
        self.s_ego, self.s_self = s_ego, s_self
        self.speed, self.low, self.high = float(speed), float(low), float(high)
        self.phase_index = 0  # wait, regulate, cruise (PHASES)
        self.start_time: float | None = None  # when it went [s]
        self.switch_time: float | None = None  # when it stopped regulating [s]
        self.switch_gap: float | None = None  # the ego's distance to the conflict then [m]
        self.brake = 0.0
        self._steer: Callable[[float], float] | None = None

    def _target(self, actor: Actor, world: Any) -> float:
        p = self.params
        v_ego = world.ego_speed
        d_ego = self.s_ego - world.ego.s
        d_self = self.s_self - actor.s
        if self.phase_index == 0:
            if v_ego <= p.start_speed:
                return 0.0
            t_ego = ego_arrival(max(d_ego, 0.0), v_ego, -world.ego_decel, p.min_speed)
            t_self = max(d_self, 0.0) / self.speed + self.speed / (2.0 * actor.spec.a_max)
            if math.isfinite(d_ego) and t_self < t_ego:
                return 0.0
            self.phase_index = 1 if math.isfinite(d_ego) else 2
            self.start_time = world.t
        if self.phase_index == 1:
            if d_ego <= 0.0 or d_self <= 0.0:
                self.phase_index = 2
                self.switch_time, self.switch_gap = world.t, d_ego
            else:
                t_ego = ego_arrival(d_ego, v_ego, -world.ego_decel, p.min_speed)
                v = catch_speed(d_self, t_ego, actor.body.speed, actor.spec.a_max)
                return min(max(v, self.low), self.high)
        return self.speed

    def command(self, actor: Actor, world: Any) -> tuple[float, float, float]:
        """(throttle, brake, steer) for this step."""
        target = self._target(actor, world)
        thr, brk = _speed_command(actor, target, world.dt)
        if self.phase_index > 0:
            thr, brk = react(actor, world, thr, brk, target, EGO_STANDING)
        self.brake = brk
        if thr == 0.0 and actor.body.speed == 0.0:
            return thr, brk, 0.0  # waits standing
        if self._steer is None:
            self._steer = lateral_controller(actor, world.dt)
        return thr, brk, self._steer(_lookahead(actor, actor.body.speed))

    def reach_speed(self, actor: Actor) -> float:
        """The speed the actor may still reach [m/s]."""
        return max(actor.body.speed, self.high)

    def stuck(self, actor: Actor) -> bool:
        """Waits for an ego that stands (asked only once it stands for good), or stands
        before a road user that stands."""
        if self.phase_index == 0:
            return True
        return actor.watcher is not None and actor.watcher.blocked(EGO_STANDING)


class ScriptedController:
    """Background traffic: cruise at ``speed``; stop at arc length ``stop_at`` for ``wait``
    seconds (None: for good), then go on. Yields to and follows the road users on its path
    (:func:`react`: the IDM, ``_yielding``).

    Args:
        speed: cruising speed [m/s].
        stop_at: arc length on the actor's route where it stops [m], or None.
        wait: how long it stands there [s]; None stands for good.
    """

    name = "cruise"

    def __init__(self, speed: float, stop_at: float | None = None, wait: float | None = None):
        self.speed, self.stop_at, self.wait = float(speed), stop_at, wait
        self.stopped_since: float | None = None
        self.done_stop = stop_at is None
        self.brake = 0.0
        self._steer: Callable[[float], float] | None = None

    def _target(self, actor: Actor, world: Any) -> float:
        target = self.speed
        if not self.done_stop:
            left = self.stop_at - actor.s
            if self.stopped_since is None and left <= 0.3 and actor.body.speed < STANDING + 0.2:
                self.stopped_since = world.t
            if self.stopped_since is not None:
                if self.wait is not None and world.t - self.stopped_since >= self.wait:
                    self.done_stop = True
                else:
                    return 0.0
            else:
                brake = max(actor.spec.b_max, 1.0)
                target = min(target, math.sqrt(max(0.0, 2.0 * 0.5 * brake * max(left, 0.0))))
        return target

    def command(self, actor: Actor, world: Any) -> tuple[float, float, float]:
        """(throttle, brake, steer) for this step."""
        target = self._target(actor, world)
        thr, brk = _speed_command(actor, target, world.dt)
        thr, brk = react(actor, world, thr, brk, self.speed)
        self.brake = brk
        if self._steer is None:
            self._steer = lateral_controller(actor, world.dt)
        return thr, brk, self._steer(_lookahead(actor, actor.body.speed))

    def reach_speed(self, actor: Actor) -> float:
        """The speed the actor may still reach [m/s]."""
        return max(actor.body.speed, self.speed)

    def stuck(self, actor: Actor) -> bool:
        """Stopped for good at its stop point, or stands before a road user that stands."""
        if self.stopped_since is not None and self.wait is None:
            return True
        return actor.watcher is not None and actor.watcher.blocked()


#: Pedestrian behaviours and their defaults: start time before the ego arrives [s],
#: pause at the kerb [s] (None: for good; 0: no stop at the kerb).
CROSSING_BEHAVIOURS: dict[str, dict[str, float | None]] = {
    "cross": {"time": 3.0, "pause": 0.0},
    "kerb": {"time": 4.0, "pause": None},
    "hesitate": {"time": 4.0, "pause": 1.5},
}


class CrossingController:
    """A pedestrian on a crosswalk.

    Waits on the sidewalk until the ego's arrival time at the crosswalk (its distance to
    the conflict over its speed, speed floored at 0.5 m/s) drops to ``time`` seconds;
    then walks at its walking speed. With a ``pause`` it stops with its front
    :data:`KERB_MARGIN` short of the kerb (``s_kerb``, where its route meets the road)
    for ``pause`` seconds (None: for good), then crosses.

    Args:
        behaviour: ``cross``, ``kerb`` or ``hesitate`` (:data:`CROSSING_BEHAVIOURS`).
        s_ego: arc length of the conflict's start on the ego's route [m].
        s_kerb: arc length of the kerb on the pedestrian's route [m].
        time, pause: override the behaviour's defaults.
        speed: walking speed [m/s].
    """

    #: A pedestrian waiting at the kerb stands this far short of it [m].
    KERB_MARGIN = 0.3

    def __init__(
        self,
        behaviour: str,
        s_ego: float,
        s_kerb: float,
        speed: float,
        time: float | None = None,
        pause: float | None | str = "default",
    ) -> None:
        defaults = CROSSING_BEHAVIOURS[behaviour]
        self.name = behaviour
        self.time = float(defaults["time"] if time is None else time)
        self.pause = defaults["pause"] if pause == "default" else pause
        self.s_ego, self.s_kerb, self.speed = s_ego, s_kerb, float(speed)
        self.started = False
        self.paused_since: float | None = None
        # a pause of 0 means no stop at the kerb; None means a stop for good
        self.past_kerb = self.pause is not None and self.pause <= 0.0
        self.brake = 0.0
        self._steer: Callable[[float], float] | None = None

    def _target(self, actor: Actor, world: Any) -> float:
        if not self.started:
            d_ego = self.s_ego - world.ego.s
            if d_ego / max(world.ego_speed, 0.5) > self.time or world.ego_speed <= 0.1:
                return 0.0
            self.started = True
        if self.past_kerb:
            return self.speed
        left = self.s_kerb - self.KERB_MARGIN - actor.half_l - actor.s
        if self.paused_since is None:
            if left > 0.05:
                b = actor.spec.b_max
                return min(self.speed, math.sqrt(2.0 * 0.8 * b * left))
            self.paused_since = world.t
        if self.pause is not None and world.t - self.paused_since >= self.pause:
            self.past_kerb = True
            return self.speed
        return 0.0

    def command(self, actor: Actor, world: Any) -> tuple[float, float, float]:
        """(throttle, brake, steer) for this step."""
        target = self._target(actor, world)
        thr, brk = _speed_command(actor, target, world.dt)
        if self.started:  # steps out when its behaviour says (the test): ego only if standing
            thr, brk = react(actor, world, thr, brk, self.speed, EGO_STANDING)
        self.brake = brk
        if thr == 0.0 and actor.body.speed == 0.0:
            return thr, brk, 0.0  # waits standing: faces where it stands
        if self._steer is None:
            self._steer = lateral_controller(actor, world.dt)
        return thr, brk, self._steer(_lookahead(actor, actor.body.speed))

    def reach_speed(self, actor: Actor) -> float:
        """The speed the actor may still reach [m/s]."""
        return max(actor.body.speed, self.speed)

    def stuck(self, actor: Actor) -> bool:
        """Will never move again: waits for an ego that stands still (the early end asks
        only once the ego stands for good), stands at the kerb for good, or stands before
        a road user that stands."""
        if not self.started or (self.paused_since is not None and self.pause is None):
            return True
        return actor.watcher is not None and actor.watcher.blocked(EGO_STANDING)
