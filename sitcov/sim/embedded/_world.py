"""The world: the actors, the wind and one control step of all of them.

:class:`World` advances every actor by one control period: the ego's stack decides first
(from perception of the state at the start of the step), the wind's gust updates, every
other active actor's controller decides from the same state and its body moves, then the
ego's body moves (a controller with a ``drive`` method commands and moves its actor in one
call); each body's position along its route is tracked as it moves (no
controller reads another actor's position along its route but the ego's, which moves
last). Monitors
(``_monitors.py``) look at the world after each step; the run loop (``_backend.py``) only
alternates the two.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator, Sequence
from typing import Any

import numpy as np

from sitcov.sim.embedded import _dynamics
from sitcov.sim.embedded._actors import Actor
from sitcov.sim.embedded._dynamics import SUBSTEPS, _constants, _move_kernel


class Wind:
    """Gusty crosswind on cars: Ornstein-Uhlenbeck gusts on a mean speed.

    Args:
        mean: mean wind speed [m/s] (0: no force at all).
        direction: where it blows towards [rad].
        noise: standard normal draws, one per step (drawn up front so the stream order is
            fixed whether or not the wind acts): a sequence of floats or a float array
            (made a list of Python floats only when the wind acts: turning a run's 1,201
            draws into a list costs about 15 us, as much as drawing them).
        intensity, time_scale: turbulence intensity [-] and gust time scale [s].
        k: side-force coefficient: lateral acceleration per (m/s)^2 of crosswind [1/m].
        dt: control period [s].
    """

    def __init__(
        self,
        mean: float,
        direction: float,
        noise: Sequence[float],
        intensity: float,
        time_scale: float,
        k: float,
        dt: float,
    ) -> None:
        if mean > 0.0 and isinstance(noise, np.ndarray):  # read every step: Python floats
            noise = noise.tolist()
        self.mean, self.direction, self.noise, self.k = mean, direction, noise, k
        self.phi = math.exp(-dt / time_scale)
        self.scale = intensity * math.sqrt(1.0 - self.phi * self.phi)
        self.gust = intensity * float(noise[0])
        self.speed = 0.0

    def update(self, k: int) -> None:
        """Advance the gust to step ``k``'s value."""
        if self.mean > 0.0:
            self.gust = self.phi * self.gust + self.scale * self.noise[k + 1]
            self.speed = self.mean * (1.0 + self.gust)

    def lateral(self, actor: Actor) -> float:
        """Lateral acceleration [m/s^2] on ``actor`` now (cars only; riders and walkers
        lean into the wind)."""
        if self.mean <= 0.0 or actor.kind != "car":
            return 0.0
        v = self.speed * math.sin(self.direction - actor.body.yaw)
        return self.k * v * abs(v)


class World:
    """Every actor of a run and the step that advances them together.

    Args:
        ego: the ego actor.
        actors: the other actors, primary OV first.
        driver: the ego's controller (``_ego.EgoDriver``).
        wind: the run's wind.
        mu: tyre-road friction [-].
        dt: control period [s].
    """

    def __init__(
        self, ego: Actor, actors: Sequence[Actor], driver: Any, wind: Wind, mu: float, dt: float
    ) -> None:
        self.ego, self.actors, self.driver, self.wind = ego, list(actors), driver, wind
        self.mu, self.dt = mu, dt
        self.t = 0.0
        self.k = 0
        self.ego_speed = 0.0
        #: the ego's deceleration over the last step [m/s^2] (negative: it sped up)
        self.ego_decel = 0.0
        self.collision: Actor | None = None  # the actor the ego hit (CollisionMonitor)
        self.end_reason: str | None = None  # why the run ended (set by the backend)
        #: per actor, its controller's ``drive(actor, world, mu, lateral, dt)`` (command
        #: and move in one, e.g. a timed car's one compiled call), None if it has none
        self._drives = [(a, getattr(a.controller, "drive", None)) for a in self.actors]
        #: the ego's move (``_ego_move_setup``), made at the first step
        self._ego_move: Any = None
        #: :meth:`stepper`'s function, made at the first :meth:`step`
        self._stepper: Callable[[], None] | None = None

    def bodies_except(self, actor: Actor) -> Iterator[Actor]:
        """Every active actor (the ego included) but ``actor``."""
        if actor is not self.ego:
            yield self.ego
        for other in self.actors:
            if other is not actor and other.active:
                yield other

    def record(self) -> None:
        """Append a trace row for the ego and every active actor."""
        t = self.t
        self.ego.record(t)
        for a in self.actors:
            if a.active:
                a.record(t)

    def release(self) -> None:
        """Drop the references that tie a finished run's objects into cycles (each actor's
        watcher, which holds the actor; the driver's own bound ``command``), so that
        reference counting frees them when the run's last reference goes. Why: as cycles
        they waited for the garbage collector, whose passes over a campaign's process
        cost about 2 % of its time. The world is not stepped afterwards."""
        for a in self.actors:
            a.watcher = None
        release = getattr(self.driver, "release", None)
        if release is not None:
            release()

    def step(self) -> None:
        """One control period for every actor (see the module docstring)."""
        stepper = self._stepper
        if stepper is None:
            stepper = self._stepper = self.stepper()
        stepper()

    def stepper(self) -> Callable[[], None]:
        """:meth:`step` as a function of no arguments, with what stays fixed for the run
        bound once: the ego, its body and move, the wind, friction, control period, the
        driver's ``command`` and the actors' drives. The run loop calls it every step
        (``_backend.run_loop``): looking these up again on every step cost more than
        some of the work they serve. The same operations in the same order as before
        (the same bits); what changes during a run (``k``, ``t``, the ego's speed, the
        bodies, the actors' ``active`` and ``crashed``) is read every call."""
        ego, wind, dt, mu = self.ego, self.wind, self.dt, self.mu
        eb = ego.body
        command = self.driver.command
        drives, actors = self._drives, self.actors
        windy = wind.mean > 0.0  # Wind.update and Wind.lateral act only then
        lateral = wind.lateral if windy else None
        update_wind = wind.update
        em = self._ego_move
        if em is None:
            em = self._ego_move = self._ego_move_setup()
        # Actor.move then Vehicle.step of a car, written out (() for Actor.move)
        move, kc, steer_max, points = em if em else (None, None, 0.0, None)
        hypot, inf = math.hypot, math.inf

        def step() -> None:
            speed = hypot(eb.vx, eb.vy)  # the ego's body is a Vehicle: its speed
            self.ego_decel = (self.ego_speed - speed) / dt
            self.ego_speed = speed
            k = self.k
            throttle, brake, steer = command(self, k, self.t)
            if windy:
                update_wind(k)
                lat_e = lateral(ego)
            else:
                lat_e = 0.0
            for a, drive in drives:
                if a.active:
                    lat = 0.0 if lateral is None else lateral(a)
                    if a.crashed:
                        a.move(0.0, 1.0, 0.0, mu, lat, dt)
                    elif drive is not None:
                        drive(a, self, mu, lat, dt)
                    else:
                        thr, brk, st = a.controller.command(a, self)
                        a.move(thr, brk, st, mu, lat, dt)
            if move is not None:
                moved, delta, x, y, yaw, vx, vy, r, s, i = move(
                    kc, steer_max, eb.x, eb.y, eb.yaw, eb.vx, eb.vy, eb.r,
                    throttle, brake, steer, mu, lat_e, dt, SUBSTEPS, points, ego.hint,
                )  # fmt: skip
                if moved:
                    eb.x, eb.y, eb.yaw, eb.vx, eb.vy, eb.r = x, y, yaw, vx, vy, r
                    eb.steer = delta
                ego.s, ego.hint = s, i
            else:
                ego.move(throttle, brake, steer, mu, lat_e, dt)
            self.k = k = k + 1
            self.t = k * dt
            ex, ey = eb.x, eb.y
            for a in actors:
                a.prev_gap = a.gap
                if a.active:
                    b = a.body
                    a.dx, a.dy = dx, dy = b.x - ex, b.y - ey
                    a.gap = hypot(dx, dy)
                else:
                    a.gap = inf

        return step

    def _ego_move_setup(self) -> tuple[Any, Any, float, Any] | tuple[()]:
        """What :meth:`step` needs to move a car ego on its route in one compiled call
        (``Vehicle.step``'s kernel, constants and steering limit, the route's points;
        the body's parameters and route stay for the run), or ``()`` for
        ``Actor.move``."""
        ego = self.ego
        points = ego._points
        if points is None:
            return ()
        eb = ego.body
        kc = eb._kc
        if kc is None:
            kc = eb._kc = _constants(eb._k)
        return (_dynamics._MOVE or _move_kernel()), kc, eb.p.steer_max, points
