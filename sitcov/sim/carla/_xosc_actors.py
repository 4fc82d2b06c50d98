"""OpenSCENARIO entities and events of a situation's pedestrians, cyclists and extra cars.

The road users come from the same scene as in both backends (``sitcov.sim.carla._actors``
:func:`~sitcov.sim.carla._actors.plan_scene`: the embedded map's routes placed on the CARLA
junction, and the embedded controllers with their parameters). Each becomes:

- an entity: a ``Pedestrian`` (``pedestrianCategory="pedestrian"``, ``model`` = the map
  file's walker blueprint, mass :data:`PEDESTRIAN_MASS`, the body's box) or a ``Vehicle``
  with ``vehicleCategory="bicycle"`` (the bicycle blueprint as its name, the body's box,
  speed and acceleration limits) or, for an extra car, a car ``Vehicle`` as the OV's;
- a teleport to its route's start and an ``AssignRouteAction`` along its route;
- events that say what its controller does, in the OV's simplified open-loop form:

  - ``timed`` (the timing law): a car as the OV (start when the hero moves at the constant
    speed that reaches the conflict when a hero at 25 km/h does; the cruise speed once the
    hero is within the switch distance of the conflict); a pedestrian or cyclist starts at
    its cruise speed when the hero, at 25 km/h, is as many seconds from the conflict as the
    actor needs to reach it (a constant crawl from the hero's start would be unnatural);
  - ``cross`` / ``kerb`` / ``hesitate``: walk when the hero is ``time`` seconds (at 25 km/h)
    from the conflict; ``kerb`` stops at the kerb, ``hesitate`` goes on ``pause`` seconds
    after reaching it;
  - ``cruise`` / ``stop`` / ``stop-go``: go when the hero moves; stop at the stop point;
    ``stop-go`` goes on ``wait`` seconds later.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

from sitcov.sim._adversary import FALLBACK_SWITCH_DISTANCE
from sitcov.sim.carla._actors import Frame
from sitcov.sim.carla._mapfile import CarlaMap
from sitcov.sim.embedded._actors import Actor
from sitcov.sim.embedded._bodies import body_spec
from sitcov.sim.embedded._controllers import (
    CrossingController,
    PacedController,
    ScriptedController,
    TimingController,
)

#: The hero's cruise speed assumed for every timing [m/s] (25 km/h, as for the OV).
EGO_SPEED = 25.0 / 3.6
#: Acceleration of speed changes [m/s^2] (as for the OV).
ACCEL = 2.0
#: Mass of a pedestrian [kg] (an adult; OpenSCENARIO 1.0 requires it).
PEDESTRIAN_MASS = 80.0
#: Route points written per metre of route (one every 5 m, plus the end).
ROUTE_SPACING = 5
#: Wheel diameter [m] of a city bicycle (28-inch wheels).
BICYCLE_WHEEL = 0.7


@dataclass(frozen=True)
class Hero:
    """What the actors' timing needs of the hero: its path length to a point [m]."""

    spawn: tuple[float, float]
    junction: tuple[float, float]

    def distance_to(self, point: tuple[float, float]) -> float:
        """Spawn -> junction centre -> point [m], CARLA frame (as for the OV)."""
        return math.dist(self.spawn, self.junction) + math.dist(self.junction, point)


def world_position(xosc: Any, x: float, y: float, yaw_deg: float | None = None) -> Any:
    """An OpenSCENARIO WorldPosition from CARLA (x, y, yaw [deg]): right-handed (x, -y)."""
    h = None if yaw_deg is None else -math.radians(yaw_deg)
    return xosc.WorldPosition(x=x, y=-y, z=0.0, h=h)


def speed_action(xosc: Any, v: float, rate: float = ACCEL) -> Any:
    """An absolute speed change to ``v`` [m/s] at ``rate`` [m/s^2]."""
    dyn = xosc.TransitionDynamics(xosc.DynamicsShapes.linear, xosc.DynamicsDimension.rate, rate)
    return xosc.AbsoluteSpeedAction(round(v, 3), dyn)


def hero_moves(xosc: Any, name: str) -> Any:
    """Trigger: the hero starts moving."""
    return xosc.EntityTrigger(
        name,
        0.0,
        xosc.ConditionEdge.rising,
        xosc.SpeedCondition(0.1, xosc.Rule.greaterThan),
        "hero",
    )


def reaches(
    xosc: Any,
    name: str,
    entity: str,
    where: Any,
    radius: float,
    delay: float = 0.0,
    *,
    rising: bool = False,
) -> Any:
    """Trigger: ``entity`` is within ``radius`` [m] of ``where`` (after ``delay`` [s]).

    Scene actors' triggers fire on the condition itself (edge ``none``: also when it holds
    from the start, e.g. a hero spawned already close); the OV's keeps its ``rising`` edge.
    """
    return xosc.EntityTrigger(
        name,
        round(delay, 3),
        xosc.ConditionEdge.rising if rising else xosc.ConditionEdge.none,
        xosc.ReachPositionCondition(where, round(radius, 3)),
        entity,
    )


def _event(xosc: Any, name: str, v: float, trigger: Any, rate: float = ACCEL) -> Any:
    event = xosc.Event(name, xosc.Priority.overwrite)
    event.add_action(f"{name}_speed", speed_action(xosc, v, rate))
    event.add_trigger(trigger)
    return event


def actor_entity(xosc: Any, spec: CarlaMap, actor: Actor) -> Any:
    """The entity of a pedestrian or cyclist (cars: the caller's OV vehicle)."""
    body = body_spec(actor.kind)
    box = xosc.BoundingBox(body.width, body.length, body.height, 0.0, 0.0, 0.5 * body.height)
    if actor.kind == "pedestrian":
        entity = xosc.Pedestrian(
            spec.walker_blueprint,
            PEDESTRIAN_MASS,
            xosc.PedestrianCategory.pedestrian,
            box,
            model=spec.walker_blueprint,
        )
    else:
        half = 0.5 * BICYCLE_WHEEL
        front = xosc.Axle(body.steer_max, BICYCLE_WHEEL, 0.1, body.wheelbase, half)
        rear = xosc.Axle(0.0, BICYCLE_WHEEL, 0.1, 0.0, half)
        entity = xosc.Vehicle(
            spec.bicycle_blueprint,
            xosc.VehicleCategory.bicycle,
            box,
            front,
            rear,
            body.v_max,
            body.a_max,
            body.b_max,
        )  # no mass: a Vehicle's mass is OpenSCENARIO 1.1, these files are 1.0
    entity.add_property("type", "simulation")
    entity.add_property("sitcov_kind", actor.kind)
    return entity


def route_points(frame: Frame, actor: Actor) -> list[tuple[float, float, float]]:
    """Points of the actor's route, CARLA frame (x, y, yaw [deg]), one every few metres."""
    route = actor.route
    n = len(route.xs)
    keep = sorted({*range(0, n, ROUTE_SPACING), n - 1})
    return [frame.to_carla(route.xs[i], route.ys[i], route.hs[i]) for i in keep]


def actor_init(xosc: Any, init: Any, name: str, frame: Frame, actor: Actor) -> None:
    """Teleport to the route's start and assign the route."""
    points = route_points(frame, actor)
    init.add_init_action(name, xosc.TeleportAction(world_position(xosc, *points[0])))
    route = xosc.Route(f"{name}_route")
    for x, y, _ in points:
        route.add_waypoint(world_position(xosc, x, y), xosc.RouteStrategy.shortest)
    init.add_init_action(name, xosc.AssignRouteAction(route))


def actor_events(xosc: Any, name: str, frame: Frame, actor: Actor, hero: Hero) -> list[Any]:
    """The events of one actor (see the module docstring)."""
    ctrl = actor.controller
    if isinstance(ctrl, TimingController | PacedController):
        return _timed_events(xosc, name, frame, actor, hero)
    if isinstance(ctrl, CrossingController):
        return _crossing_events(xosc, name, frame, actor, hero)
    if isinstance(ctrl, ScriptedController):
        return _scripted_events(xosc, name, frame, actor)
    raise TypeError(f"no OpenSCENARIO events for controller {type(ctrl).__name__}")


def _conflict_point(frame: Frame, actor: Actor) -> tuple[float, float]:
    """The actor's conflict with the ego, CARLA frame (its route's middle without one)."""
    if actor.conflict is not None:
        x, y = actor.conflict.point
    else:
        x, y, _ = actor.route.point_at(0.5 * actor.route.length)
    return frame.to_carla(x, y, 0.0)[:2]


def _on_route(frame: Frame, actor: Actor, s: float) -> Any:
    x, y, h = actor.route.point_at(s)
    return frame.to_carla(x, y, h)


def approach_speed(d_ego: float, d_actor: float, v_max: float) -> float:
    """Constant speed [m/s] that reaches the conflict after ``d_actor`` [m] when a hero at
    EGO_SPEED (starting at the same moment, both ramping at ACCEL) covers ``d_ego`` [m];
    within (0.1 m/s, ``v_max``]."""
    t_ego = d_ego / EGO_SPEED + EGO_SPEED / (2.0 * ACCEL)
    disc = t_ego * t_ego - 2.0 * d_actor / ACCEL
    v = (t_ego - math.sqrt(disc)) * ACCEL if disc >= 0 else v_max
    return max(0.1, min(v_max, v))


def _timed_events(xosc: Any, name: str, frame: Frame, actor: Actor, hero: Hero) -> list[Any]:
    """A car: the OV's form (constant approach speed from the hero's start, cruise at the
    switch). A pedestrian or cyclist: it starts at its cruise speed when the hero (at
    25 km/h) is as many seconds from the conflict as the actor needs to reach it."""
    ctrl: TimingController | PacedController = actor.controller
    point = _conflict_point(frame, actor)
    where = world_position(xosc, *point)
    s_self = actor.conflict.s_ov if actor.conflict is not None else 0.5 * actor.route.length
    cruise = ctrl.params.cruise_speed
    if actor.kind != "car":
        a_max = body_spec(actor.kind).a_max
        lead = s_self / cruise + cruise / (2.0 * a_max)  # [s] to reach the conflict
        start = reaches(xosc, f"{name}_hero_close", "hero", where, EGO_SPEED * lead)
        return [_event(xosc, f"{name}_approach", cruise, start, a_max)]
    v = approach_speed(hero.distance_to(point), s_self, body_spec(actor.kind).v_max)
    switch = ctrl.params.switch_distance or FALLBACK_SWITCH_DISTANCE
    near = reaches(xosc, f"{name}_hero_near_conflict", "hero", where, switch)
    return [
        _event(xosc, f"{name}_approach", v, hero_moves(xosc, f"{name}_hero_moves")),
        _event(xosc, f"{name}_cruise", cruise, near),
    ]


def _crossing_events(xosc: Any, name: str, frame: Frame, actor: Actor, hero: Hero) -> list[Any]:
    ctrl: CrossingController = actor.controller
    spec = body_spec(actor.kind)
    point = world_position(xosc, *_conflict_point(frame, actor))
    start = reaches(xosc, f"{name}_hero_close", "hero", point, ctrl.time * EGO_SPEED)
    events = [_event(xosc, f"{name}_walk", ctrl.speed, start, spec.a_max)]
    if ctrl.pause is not None and ctrl.pause <= 0.0:
        return events
    stop_s = ctrl.s_kerb - ctrl.KERB_MARGIN - actor.half_l
    kerb = world_position(xosc, *_on_route(frame, actor, stop_s)[:2])
    events.append(
        _event(xosc, f"{name}_kerb", 0.0, reaches(xosc, f"{name}_at_kerb", name, kerb, 0.3), 2.0)
    )
    if ctrl.pause is not None:
        go = reaches(xosc, f"{name}_paused", name, kerb, 0.3, delay=ctrl.pause)
        events.append(_event(xosc, f"{name}_cross", ctrl.speed, go, spec.a_max))
    return events


def _scripted_events(xosc: Any, name: str, frame: Frame, actor: Actor) -> list[Any]:
    ctrl: ScriptedController = actor.controller
    events = [_event(xosc, f"{name}_go", ctrl.speed, hero_moves(xosc, f"{name}_hero_moves"))]
    if ctrl.stop_at is None:
        return events
    where = world_position(xosc, *_on_route(frame, actor, ctrl.stop_at)[:2])
    events.append(
        _event(xosc, f"{name}_stop", 0.0, reaches(xosc, f"{name}_at_stop", name, where, 0.5))
    )
    if ctrl.wait is not None:
        go = reaches(xosc, f"{name}_waited", name, where, 0.5, delay=ctrl.wait)
        events.append(_event(xosc, f"{name}_go_again", ctrl.speed, go))
    return events
