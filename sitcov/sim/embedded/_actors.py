"""An actor: one road user in the world, with its kind, body, controller and route.

The ego is an actor too (its controller is the AV stack, driven by ``_ego.EgoDriver``);
the others are the primary OV of the intersection situation (named ``ov``) and the
situation's extra actor slots (``actor2``, ``actor3``, ...).
"""

from __future__ import annotations

import math
from typing import Any

from sitcov.perception._base import ActorView, Pose
from sitcov.sim._metrics import disc_radius
from sitcov.sim.embedded._bodies import Body, BodySpec
from sitcov.sim.embedded._dynamics import SUBSTEPS
from sitcov.sim.embedded._map import Conflict
from sitcov.sim.embedded._path import Path

Row = tuple[float, float, float, float, float]


class Actor:
    """One road user.

    Args:
        name: ``ego``, ``ov``, ``actor2``, ...
        kind: ``car``, ``cyclist`` or ``pedestrian``.
        spec: its size and limits.
        body: its motion model (already at the start of ``route``).
        controller: what drives it (None for the ego).
        route: the path it follows (spawn to end).
        conflict: the swept-path overlap of its route with the ego's (None for the ego or
            when the routes never meet); ``s_ego``: ego's route, ``s_ov``: this route.
        color: body colour (R, G, B) for sensors.
        info: what the scene said about it (route name, behaviour, conflict type).

    Attributes set by the world each step: ``s`` and ``hint`` (arc length and segment on
    its route), ``dx``, ``dy``, ``gap`` (position relative to the ego and centre
    distance; ``gap`` is inf while inactive; ``prev_gap`` one step earlier), ``active``
    (False once it left the map at the end of its route), ``crashed`` (it hit another
    actor: it brakes to a stop). ``watcher``: the road users whose routes meet its own
    (``_yielding.Watcher``, set by the scene; None for the ego).
    """

    __slots__ = (
        "name",
        "kind",
        "spec",
        "body",
        "controller",
        "route",
        "conflict",
        "color",
        "info",
        "half_l",
        "half_w",
        "radius",
        "disc",
        "s",
        "hint",
        "tracker",
        "_points",
        "active",
        "crashed",
        "rows",
        "dx",
        "dy",
        "gap",
        "prev_gap",
        "watcher",
    )

    def __init__(
        self,
        name: str,
        kind: str,
        spec: BodySpec,
        body: Body,
        route: Path,
        controller: Any = None,
        conflict: Conflict | None = None,
        color: tuple[int, int, int] | None = None,
        info: dict[str, Any] | None = None,
    ) -> None:
        self.name, self.kind, self.spec, self.body = name, kind, spec, body
        self.controller, self.route, self.conflict = controller, route, conflict
        self.color = color
        self.info = dict(info or {})
        self.half_l, self.half_w = 0.5 * spec.length, 0.5 * spec.width
        self.radius = math.hypot(self.half_l, self.half_w)  # bounding circle [m]
        self.disc = disc_radius(spec.length, spec.width)  # footprint disc (TTC) [m]
        self.s = 0.0
        self.hint = 0
        self.tracker = route.tracker()  # route.track, compiled when numba is there
        # a car's body tracks itself in its integrator's call (Vehicle.step's route)
        self._points = self.tracker.args[0] if kind == "car" else None
        self.active = True
        self.crashed = False
        self.rows: list[Row] = []
        self.dx = self.dy = 0.0  # position relative to the ego [m]
        self.gap = math.inf  # centre distance to the ego [m] (inf while inactive)
        self.prev_gap = math.inf  # the same one step earlier [m]
        self.watcher: Any = None  # what it sees on its path (_yielding.Watcher), set by the scene

    def box(self) -> tuple[float, float, float, float, float]:
        """The footprint box (x, y, yaw, half length, half width)."""
        b = self.body
        return (b.x, b.y, b.yaw, self.half_l, self.half_w)

    def view(self) -> ActorView:
        """What a sensor sees of it."""
        b = self.body
        spec = self.spec
        return ActorView(
            Pose(b.x, b.y, b.yaw),
            spec.length,
            spec.width,
            spec.height,
            b.speed,
            self.color,
            self.kind,
        )

    def velocity(self) -> tuple[float, float]:
        """World-frame velocity [m/s]."""
        b = self.body
        c, s = math.cos(b.yaw), math.sin(b.yaw)
        return b.vx * c - b.vy * s, b.vx * s + b.vy * c

    def move(self, thr: float, brk: float, steer: float, mu: float, lat: float, dt: float) -> None:
        """Step the body under the commands, then update ``s`` and ``hint`` (a car does
        both in one compiled call: see ``Vehicle.step``)."""
        b = self.body
        if self._points is not None:
            route, hint = self._points, self.hint
            self.s, self.hint = b.step(thr, brk, steer, mu, lat, dt, SUBSTEPS, route, hint)
        else:
            b.step(thr, brk, steer, mu, lat, dt)
            self.s, self.hint = self.tracker(b.x, b.y, self.hint)

    def track(self) -> None:
        """Update ``s`` and ``hint`` from the body's position."""
        b = self.body
        self.s, self.hint = self.tracker(b.x, b.y, self.hint)

    def record(self, t: float) -> None:
        """Append a trace row (t, x, y, yaw, speed)."""
        b = self.body
        self.rows.append((t, b.x, b.y, b.yaw, b.speed))
