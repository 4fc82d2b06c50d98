"""Route progress of the ego: how far it got, when it reached its goal, when it stood and why.

A verdict must say something about the stack under test; a stack that never moves must
not pass (docs/campaigns.md, "Route completion and blame"). :class:`ProgressMonitor`
records, as facts, what the judge needs for the ``blocked`` and ``route_incomplete``
failure kinds and what the summary shows next to the failure rate:

- ``route_completion``: the largest arc length the ego reached along its route, over the
  arc length at which the goal counts as reached (route length minus
  :data:`~sitcov.sim.embedded._progress.GOAL_TOLERANCE`), capped at 1 [-];
- ``time_to_goal``: when the ego reached its goal [s], or None;
- ``standstill_time``: how long the ego stood (speed below :data:`STILL_SPEED`) [s];
- ``blocked_time``: the first time [s] the ego had stood for :data:`BLOCKED_TIME` without
  interruption while nothing occupied its path or the conflict zone ahead (:func:`path_occupied`);
  the same idea as ScenarioRunner's ``ActorBlockedTest`` (the CARLA Leaderboard fails an
  agent below 0.1 m/s for 180 s on routes of kilometres; ours last 60 s);
- ``route_incomplete_time``: the run's time budget [s] when the run ended by the time
  limit, or as ``stopped`` (nothing can change any more), before the goal; else None;
- ``ego_stopped`` and ``stop_reason``: whether the ego stood at the end of a run that did
  not reach its goal, and why: ``aeb_latched`` (its emergency brake latched),
  ``path_occupied`` or ``path_clear``.

It ends the run at the goal (it is the built-in list's goal monitor: one call per step for
both); only the arc length and speed comparisons run on every step, the path test only
while the ego stands and has not been blocked yet.
"""

from __future__ import annotations

import math
from bisect import bisect_left
from typing import Any

import numpy as np

from sitcov.sim._judge import STATIONARY_SPEED

#: The ego has reached its goal (an actor has left) within this arc length of its
#: route's end [m].
GOAL_TOLERANCE = 1.5

#: Ego speed below which it stands still [m/s] (for ``blocked``, ``standstill_time`` and
#: the ``ego_stationary`` collisions: a car below 0.3 m/s moves less than its own length
#: in 15 s; ScenarioRunner's blocked test uses 0.1 m/s).
STILL_SPEED = STATIONARY_SPEED
_STILL2 = STILL_SPEED * STILL_SPEED  # [m^2/s^2]
#: How long the ego may stand with a clear path before it is ``blocked`` [s]: long enough
#: for a stack to look and go after the road user it yielded to has passed.
BLOCKED_TIME = 10.0
#: How far ahead of the ego's front its path is looked at [m]: beyond the distance at
#: which the reference AEB fires on a car (~10 m) and a queue of two cars.
PATH_AHEAD = 20.0
#: Lateral margin beyond the ego's half width within which a road user occupies its path [m].
PATH_MARGIN = 0.5
#: A moving road user that reaches its conflict zone with the ego within this time at its
#: current speed occupies the zone [s] (a gap too short to go before it).
ARRIVAL_TIME = 5.0


def path_occupied(world: Any, xs: Any, ys: Any, ss: Any, pts: Any = None) -> bool:
    """Whether a road user occupies the ego's path or a conflict zone ahead of it.

    Occupied means, for some active actor: (a) its box comes within the ego's half width
    plus :data:`PATH_MARGIN` of the ego's route over the :data:`PATH_AHEAD` metres ahead
    of the ego's front, or (b) it has a conflict zone with the ego that neither has left
    yet, whose start on the ego's route lies within :data:`PATH_AHEAD` of the ego's front,
    and it is inside that zone or moving and due there within :data:`ARRIVAL_TIME`.
    ``xs``, ``ys``, ``ss``: the ego route's points and arc lengths; ``pts``: the route's
    ``_track_array`` (its points as one float array), for the compiled point test
    (:func:`path_near`), or None (the Python one).
    """
    ego = world.ego
    front = ego.s + ego.half_l
    reach = ego.half_w + PATH_MARGIN
    # the first route points at arc length >= the ego's and >= PATH_AHEAD beyond its front
    lo = bisect_left(ss, ego.s)
    hi = bisect_left(ss, front + PATH_AHEAD)
    if pts is None:
        near, pts = path_near, (xs, ys)
    else:
        near = _PATH_NEAR or path_near_fn()
        if near is path_near:  # no numba: the Python test on the plain sequences
            pts = (xs, ys)
    for a in world.actors:
        if not a.active:
            continue
        c = a.conflict
        if (
            c is not None
            and c.s_ego - front <= PATH_AHEAD
            and ego.s - ego.half_l <= c.s_ego_end
            and a.s - a.half_l <= c.s_ov_end
        ):
            ahead = c.s_ov - (a.s + a.half_l)
            speed = a.body.speed
            if ahead <= 0.0 or (speed >= STILL_SPEED and ahead <= speed * ARRIVAL_TIME):
                return True
        if a.gap > PATH_AHEAD + ego.half_l + a.radius + reach:
            continue
        b = a.body
        c, s = math.cos(b.yaw), math.sin(b.yaw)
        end = min(hi + 1, len(xs))
        if near(pts, lo, end, b.x, b.y, c, s, a.half_l, a.half_w, reach):
            return True
    return False


def path_near(
    pts: Any,
    lo: int,
    hi: int,
    x: float,
    y: float,
    c: float,
    s: float,
    hl: float,
    hw: float,
    reach: float,
) -> bool:
    """Whether a route point ``lo <= i < hi`` lies closer than ``reach`` to the box (centre
    ``x``, ``y``, heading's cos ``c`` and sin ``s``, half sizes ``hl``, ``hw``) [m]:
    ``_point_box_distance(xs[i], ys[i], box) < reach``, written out with the box's
    trigonometry done once and a one-axis early out (the same operations: the same
    values). ``pts``: the route's xs and ys as its first two rows (a float array for the
    compiled kernel, :func:`path_near_fn`; any pair of sequences here)."""
    xs, ys = pts[0], pts[1]
    for i in range(lo, hi):
        dx, dy = xs[i] - x, ys[i] - y
        ex = abs(dx * c + dy * s) - hl
        if ex >= reach:
            continue  # hypot(ex, .) >= ex >= reach
        ey = abs(-dx * s + dy * c) - hw
        if ey >= reach:
            continue
        if hypot(ex if ex > 0.0 else 0.0, ey if ey > 0.0 else 0.0) < reach:
            return True
    return False


#: ``math.hypot`` under the name :func:`path_near` uses (``_jit.py`` binds the name to its
#: correctly rounded version in the compiled code: the same bits).
hypot = math.hypot

_PATH_NEAR: Any = None


def path_near_fn() -> Any:
    """:func:`path_near` compiled by numba when it is installed (the same bits), else
    itself. Loaded once per process, on first use."""
    global _PATH_NEAR
    if _PATH_NEAR is None:
        from sitcov._jit import compiled, typed_entry

        pts = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        example = (pts, 0, 3, 1.0, 0.5, 1.0, 0.0, 2.3, 0.9, 1.4)
        _PATH_NEAR = typed_entry(compiled(path_near, *example)) or path_near
    return _PATH_NEAR


class ProgressMonitor:
    """The ego's route progress, goal time, standstill and blocked time (module docstring).

    Args:
        world: the run's world.
        budget: the run's time budget [s] (the backend's ``sim_timeout``).
    """

    def __init__(self, world: Any, budget: float) -> None:
        route = world.ego.route
        self.goal_s = max(route.length - GOAL_TOLERANCE, 1e-9)
        self.xs, self.ys, self.ss = route.xs, route.ys, route.ss
        self.pts = route._track_array  # the points as one float array (compiled test)
        path_near_fn()  # compiled (or loaded) with the run's setup, not in its loop
        self.budget = float(budget)
        self.best = world.ego.s
        self.goal_time: float | None = None
        self.still_steps = 0
        self.clear_since: float | None = None  # start of the current clear-path standstill
        self.blocked_time: float | None = None

    def update(self, world: Any) -> str | None:
        """Progress every step, ``"goal"`` (ends the run) once the ego is within
        ``GOAL_TOLERANCE`` of its route's end, as ``GoalMonitor`` does; the path test only
        while the ego stands, not yet blocked."""
        ego = world.ego
        s = ego.s
        if s > self.best:
            self.best = s
            if s >= self.goal_s:
                self.goal_time = world.t
                return "goal"
        b = ego.body
        if b.vx * b.vx + b.vy * b.vy >= _STILL2:
            self.clear_since = None
            return None
        self.still_steps += 1
        if self.blocked_time is not None:
            return
        if path_occupied(world, self.xs, self.ys, self.ss, self.pts):
            self.clear_since = None
        elif self.clear_since is None:
            self.clear_since = world.t
        elif world.t - self.clear_since >= BLOCKED_TIME - 1e-9:
            self.blocked_time = world.t
        return None

    def settled(self) -> bool:
        """Whether the standing ego's ``blocked`` fact is known without running on: it is
        blocked already, or its path is clear now (the early end asks, so that the facts
        of a run ended early are those of the whole run; an actor that merely passes
        through the ego's path later is the one case it cannot foresee)."""
        return self.blocked_time is not None or self.clear_since is not None

    def report(self, run: dict, actors: dict, world: Any) -> None:
        """The facts of the module docstring into the run's metrics.

        A run that ended as ``stopped`` (the ego stands for good, nothing can reach it and
        its path is clear: :meth:`settled`) is extrapolated to the time budget: the clear
        standstill becomes ``blocked`` when it would have lasted :data:`BLOCKED_TIME`.
        """
        ego = world.ego
        t = world.t
        reason = world.end_reason
        standing = ego.body.speed < STILL_SPEED
        occupied = standing and path_occupied(world, self.xs, self.ys, self.ss, self.pts)
        blocked = self.blocked_time
        since = self.clear_since
        if blocked is None and reason == "stopped" and since is not None:
            blocked = since + BLOCKED_TIME if since + BLOCKED_TIME <= self.budget + 1e-9 else None
        if reason == "goal" and self.goal_time is None:
            self.goal_time = t
        reached = self.goal_time is not None
        incomplete = not reached and reason in ("sim_timeout", "stopped")
        if reached or not standing:
            why = None
        elif getattr(world.driver, "latched", False):
            why = "aeb_latched"
        else:
            why = "path_occupied" if occupied else "path_clear"
        run["route_length"] = round(self.goal_s, 6)
        run["route_completion"] = 1.0 if reached else round(min(1.0, self.best / self.goal_s), 6)
        run["time_to_goal"] = None if not reached else round(self.goal_time, 10)
        run["time_budget"] = self.budget
        run["standstill_time"] = round(self.still_steps * world.dt, 10)
        run["blocked_time"] = None if blocked is None else round(blocked, 10)
        run["route_incomplete_time"] = self.budget if incomplete else None
        run["ego_stopped"] = bool(standing and not reached)
        run["stop_reason"] = why
