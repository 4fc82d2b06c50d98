"""OpenSCENARIO 1.0 export of situations on a CARLA map file (Town03 by default).

One ``.xosc`` per situation, written with ``scenariogeneration`` so ScenarioRunner and
esmini users can replay what sitcov found. Contents:

- entities ``hero`` (the ego, ScenarioRunner's ``type=ego_vehicle``) and ``adversary`` (a
  car OV), the map file's blueprints as vehicle names, teleported to the map file's spawn
  points;
- the environment: cloud state, fog visual range, rain and sun from the situation's
  weather values, and ``RoadCondition frictionScaleFactor`` = the backend's friction
  scale; the exact CARLA weather values are kept as ``carla_*`` parameters;
- the ego drives its route (spawn, conflict point, goal) at 25 km/h (the reference stack's
  target speed; drop the ``hero`` maneuver group to let your own agent drive);
- the OV's timed approach, simplified to what OpenSCENARIO can express: it starts when the
  ego moves, holds the constant speed that brings it to the conflict point when the ego
  (at 25 km/h) arrives there, and switches to 15 km/h once the ego is within the
  adversary's switch distance of the conflict point (no closed-loop timing law). With
  ``timed_ov=False`` the OV gets no speed events: the esmini backend then sets its speed
  every step from the paper's timing law in closed loop (``sitcov.sim.esmini``), with
  :func:`ov_timing`'s conflict point and switch distance;
- every further road user of the situation (a pedestrian or cyclist OV, the ``actor2``,
  ``actor3``, ... slots): a ``Pedestrian`` or a bicycle ``Vehicle`` (an extra car: a car
  ``Vehicle``), on its route from the embedded map, with events that say what its
  controller does (``sitcov.sim.carla._xosc_actors``); a pedestrian or cyclist OV is the
  entity ``adversary``, the slots keep their names;
- a stop trigger: collision of the hero with any other entity, the ego at its goal, or 60 s.

OpenSCENARIO's world frame is right-handed (y to the left, heading counter-clockwise),
CARLA's is left-handed: positions are written as (x, −y) and headings as −yaw [rad], the
conversion ScenarioRunner undoes when it reads them.
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from sitcov.errors import ConfigError, MissingExtraError
from sitcov.sim.carla._actors import conflict_point, plan_scene
from sitcov.sim.carla._mapfile import CarlaMap, load_carla_map
from sitcov.sim.carla._xosc_actors import (
    Hero,
    actor_entity,
    actor_events,
    actor_init,
    hero_moves,
    reaches,
    speed_action,
    world_position,
)
from sitcov.weather._conditions import WEATHER_ELEMENTS

#: The ego's cruise speed assumed for the OV's timing [m/s] (25 km/h).
EGO_SPEED = 25.0 / 3.6
#: Acceleration assumed for speed changes [m/s^2].
ACCEL = 2.0
#: Speed of the OV after the switch [m/s] (15 km/h).
OV_CRUISE = 15.0 / 3.6
#: Bounds of the OV's approach speed [m/s].
OV_SPEED_RANGE = (1.0, 20.0)
#: Simulated time limit [s].
SIM_TIMEOUT = 60.0
#: Fixed header date: the same situation always gives the same file.
CREATION_DATE = datetime.datetime(2024, 1, 1)


def _xosc() -> Any:
    try:
        from scenariogeneration import xosc
    except ImportError:
        raise MissingExtraError("OpenSCENARIO export", "xosc", "scenariogeneration") from None
    xosc.VersionBase().setVersion(minor=0)  # one process-wide version: this file is 1.0
    return xosc


def _world(xosc: Any, x: float, y: float, yaw_deg: float | None = None) -> Any:
    return world_position(xosc, x, y, yaw_deg)


#: How far along the exit leg's outbound lane the route's middle waypoint lies [m].
EXIT_WAYPOINT = 10.0


def exit_point(spec: CarlaMap, movement: str) -> tuple[float, float]:
    """A point on the exit leg's outbound lane of ``movement`` (CARLA frame) [m]: the
    embedded map's lane, :data:`EXIT_WAYPOINT` past its mouth, placed on the junction.

    A route through it takes the movement's turn: with only spawn and goal, a shortest
    route may leave by another road (on Town03, from B to L's goal it does), and the
    conflict point need not lie on both routes' lanes.
    """
    from sitcov.sim.carla._actors import Frame
    from sitcov.sim.embedded._map import load_map

    lane = load_map(spec.embedded_map).lane(f"{movement.partition('-')[2]}.out")
    x, y, _ = lane.point_at(min(EXIT_WAYPOINT, lane.length))
    cx, cy, _ = Frame.of(spec).to_carla(x, y, 0.0)
    return cx, cy


def ego_start(spec: CarlaMap, movement: str) -> Any:
    """The ego's spawn point for ``movement``: the map file's for its leg, moved into the
    movement's own lane when the file names one (``ov_spawns`` keyed by the movement, e.g.
    Town03's left lane of the stem for ``B-L``) by that lane's offset from the leg's lane.

    An OpenDRIVE route keeps its lane: from Town03's right stem lane, which only turns
    right, the shortest route to L's goal leaves by another road.
    """
    start = spec.ego_spawn(movement)
    leg = movement.partition("-")[0]
    lane, base = spec.ov_spawns.get(movement), spec.ov_spawns.get(leg)
    if lane is None or base is None:
        return start
    return start.model_copy(update={"x": start.x + lane.x - base.x, "y": start.y + lane.y - base.y})


def route_points(spec: CarlaMap, movement: str, start: Any) -> list[tuple[float, float]]:
    """Waypoints (CARLA frame) of a route for ``movement`` from ``start`` (a spawn point
    in the movement's lane): the start, the exit point (:func:`exit_point`), the goal."""
    return [(start.x, start.y), exit_point(spec, movement), spec.goal(movement)]


def _path_length(points: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in zip(points, points[1:], strict=False))


def approach_speed(d_ego: float, d_ov: float) -> float:
    """Constant OV speed [m/s] that reaches the conflict point when the ego does.

    The ego accelerates at ACCEL to EGO_SPEED; the OV starts at the same moment and
    accelerates at ACCEL to the returned speed.
    """
    t_ego = d_ego / EGO_SPEED + EGO_SPEED / (2.0 * ACCEL)
    lo, hi = OV_SPEED_RANGE
    # d_ov = v (t - v / (2 a))  ->  v^2 / (2a) - v t + d_ov = 0, the smaller root
    disc = t_ego * t_ego - 2.0 * d_ov / ACCEL
    v = (t_ego - math.sqrt(disc)) * ACCEL if disc >= 0 else hi
    return max(lo, min(hi, v))


def _weather(xosc: Any, values: Mapping[str, Any]) -> Any:
    from sitcov.sim.carla._backend import friction_scale
    from sitcov.weather._conditions import conditions_from_values

    cloud = float(values.get("cloudiness", 0.0))
    rain = float(values.get("precipitation", 0.0))
    if rain >= 50.0:
        state = xosc.CloudState.rainy
    elif cloud >= 60.0:
        state = xosc.CloudState.overcast
    elif cloud >= 20.0:
        state = xosc.CloudState.cloudy
    else:
        state = xosc.CloudState.free
    visibility = conditions_from_values(values).visibility
    fog = xosc.Fog(visual_range=int(min(100000.0, visibility)))
    precipitation = xosc.Precipitation(
        xosc.PrecipitationType.rain if rain > 0 else xosc.PrecipitationType.dry, rain / 100.0
    )
    sun = xosc.Sun(intensity=100000.0, azimuth=0.0, elevation=math.radians(45.0))
    weather = xosc.Weather(cloudstate=state, sun=sun, fog=fog, precipitation=precipitation)
    road = xosc.RoadCondition(friction_scale_factor=round(friction_scale(values), 6))
    return xosc.Environment(
        "sitcov_environment",
        xosc.TimeOfDay(False, 2024, 6, 21, 12, 0, 0),
        weather,
        road,
    )


def _vehicle(xosc: Any, blueprint: str, ego: bool) -> Any:
    box = xosc.BoundingBox(2.0, 4.8, 1.5, 1.4, 0.0, 0.75)
    front = xosc.Axle(math.radians(70.0), 0.7, 1.6, 2.8, 0.35)
    rear = xosc.Axle(0.0, 0.7, 1.6, 0.0, 0.35)
    car = xosc.Vehicle(blueprint, xosc.VehicleCategory.car, box, front, rear, 50.0, 5.0, 10.0)
    car.add_property("type", "ego_vehicle" if ego else "simulation")
    return car


def _route(xosc: Any, name: str, points: Iterable[tuple[float, float]]) -> Any:
    route = xosc.Route(name)
    for x, y in points:
        route.add_waypoint(_world(xosc, x, y), xosc.RouteStrategy.shortest)
    return xosc.AssignRouteAction(route)


def situation_scenario(
    situation: Any, carla_map: CarlaMap | None = None, *, timed_ov: bool = True
) -> Any:
    """The ``scenariogeneration`` Scenario of one situation (see the module docstring).

    Args:
        situation: a situation of sitcov's hyperspace (``intsit`` and actor slots).
        carla_map: the map file (default Town03's).
        timed_ov: give a car OV its open-loop speed events (False: it stands until
            something else sets its speed, e.g. the esmini backend's timing law).

    Raises:
        ConfigError: the situation has no usable ``intsit`` (or actor slot) for this map.
        MissingExtraError: scenariogeneration is not installed.
    """
    xosc = _xosc()
    spec = carla_map or load_carla_map("Town03")
    values = dict(situation.values)
    intsit = values.get("intsit")
    if not isinstance(intsit, Mapping) or not {"ego", "ov"} <= set(intsit):
        raise ConfigError(field="intsit", value=intsit, expected="a mapping with ego, ov, conflict")
    scene = plan_scene(spec, values, seed=0)  # the seed picks colours and VRU speeds
    car_ov = scene is None or scene.car_ov
    if car_ov and "conflict" not in intsit:
        raise ConfigError(field="intsit", value=intsit, expected="a mapping with ego, ov, conflict")
    ego_mv = str(intsit["ego"])
    ego_sp, ego_goal = ego_start(spec, ego_mv), spec.goal(ego_mv)
    junction = (spec.junction.x, spec.junction.y)
    via = conflict_point(spec, values, str(intsit["conflict"])) if car_ov else junction
    entities = xosc.Entities()
    entities.add_scenario_object("hero", _vehicle(xosc, spec.ego_blueprint, True))
    init = xosc.Init()
    init.add_global_action(xosc.EnvironmentAction(_weather(xosc, values)))
    init.add_init_action("hero", xosc.TeleportAction(_world(xosc, ego_sp.x, ego_sp.y, ego_sp.yaw)))
    init.add_init_action("hero", _route(xosc, "hero_route", route_points(spec, ego_mv, ego_sp)))
    ego_event = xosc.Event("hero_drive", xosc.Priority.overwrite)
    ego_event.add_action("hero_speed", speed_action(xosc, EGO_SPEED))
    ego_event.add_trigger(_start(xosc))
    groups: list[tuple[str, list[Any]]] = [("hero", [ego_event])]
    if car_ov:
        groups.append(("adversary", _car_ov(xosc, spec, intsit, via, entities, init, timed_ov)))
    if scene is not None:
        hero = Hero((ego_sp.x, ego_sp.y), junction)
        for actor in scene.actors:
            name = entity_name(actor.name)
            entity = _vehicle(xosc, spec.ov_blueprint, False)
            if actor.kind != "car":
                entity = actor_entity(xosc, spec, actor)
            entities.add_scenario_object(name, entity)
            actor_init(xosc, init, name, scene.frame, actor)
            groups.append((name, actor_events(xosc, name, scene.frame, actor, hero)))
    others = [name for name, _ in groups[1:]]
    storyboard = xosc.StoryBoard(init, _stop_trigger(xosc, ego_goal, spec.goal_tolerance, others))
    for actor_name, events in groups:
        if not events:  # an untimed OV: nothing in the storyboard moves it
            continue
        maneuver = xosc.Maneuver(f"{actor_name}_maneuver")
        for event in events:
            maneuver.add_event(event)
        group = xosc.ManeuverGroup(f"{actor_name}_group")
        group.add_actor(actor_name)
        group.add_maneuver(maneuver)
        storyboard.add_maneuver_group(group, starttrigger=_start(xosc))
    return xosc.Scenario(
        f"sitcov_{situation.id}",
        "sitcov",
        _parameters(xosc, situation.id, values),
        entities,
        storyboard,
        xosc.RoadNetwork(roadfile=spec.town),
        xosc.Catalog(),
        osc_minor_version=0,
        creation_date=CREATION_DATE,
    )


def entity_name(actor: str) -> str:
    """The entity of a scene actor: the primary road user is ``adversary`` as ever."""
    return "adversary" if actor == "ov" else actor


def _start(xosc: Any) -> Any:
    return xosc.ValueTrigger(
        "start",
        0.0,
        xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition(0.0, xosc.Rule.greaterThan),
    )


def _parameters(xosc: Any, situation_id: str, values: Mapping[str, Any]) -> Any:
    params = xosc.ParameterDeclarations()
    params.add_parameter(
        xosc.Parameter("sitcov_situation", xosc.ParameterType.string, situation_id)
    )
    for name in WEATHER_ELEMENTS + ("friction",):
        if name in values:
            params.add_parameter(
                xosc.Parameter(f"carla_{name}", xosc.ParameterType.double, str(float(values[name])))
            )
    return params


def _car_ov(
    xosc: Any,
    spec: CarlaMap,
    intsit: Mapping[str, Any],
    cp: tuple[float, float],
    entities: Any,
    init: Any,
    timed: bool = True,
) -> list[Any]:
    """The car OV (conflict point ``cp``, CARLA frame): entity, teleport, route, and its
    timed approach and cruise (none unless ``timed``)."""
    ego_mv, ov_mv = str(intsit["ego"]), str(intsit["ov"])
    ego_sp, ov_sp = ego_start(spec, ego_mv), spec.ov_spawn(ov_mv)
    junction = (spec.junction.x, spec.junction.y)
    d_ego = _path_length([(ego_sp.x, ego_sp.y), junction, cp])
    d_ov = _path_length([(ov_sp.x, ov_sp.y), junction, cp])
    entities.add_scenario_object("adversary", _vehicle(xosc, spec.ov_blueprint, False))
    init.add_init_action(
        "adversary", xosc.TeleportAction(_world(xosc, ov_sp.x, ov_sp.y, ov_sp.yaw))
    )
    init.add_init_action(
        "adversary",
        _route(xosc, "ov_route", route_points(spec, ov_mv, ov_sp)),
    )
    if not timed:
        return []
    ov_go = xosc.Event("adversary_approach", xosc.Priority.overwrite)
    ov_go.add_action("adversary_timed_speed", speed_action(xosc, approach_speed(d_ego, d_ov)))
    ov_go.add_trigger(hero_moves(xosc, "hero_moves"))
    switch = switch_distance(spec, intsit)
    ov_cruise = xosc.Event("adversary_cruise", xosc.Priority.overwrite)
    ov_cruise.add_action("adversary_cruise_speed", speed_action(xosc, OV_CRUISE))
    ov_cruise.add_trigger(
        reaches(xosc, "hero_near_conflict", "hero", _world(xosc, *cp), switch, rising=True)
    )
    return [ov_go, ov_cruise]


def switch_distance(spec: CarlaMap, intsit: Mapping[str, Any]) -> float:
    """The ego's distance to the conflict point [m] at which the OV stops synchronising:
    the map file's entry for the situation, else the adversary's fallback."""
    from sitcov.sim._adversary import FALLBACK_SWITCH_DISTANCE

    found = spec.switch_distance(str(intsit["ego"]), str(intsit["ov"]))
    return FALLBACK_SWITCH_DISTANCE if found is None else found


def ov_timing(situation: Any, carla_map: CarlaMap) -> tuple[tuple[float, float], float] | None:
    """(conflict point (CARLA frame) [m], switch distance [m]) of a situation's car OV, or
    None when its OV is no car (a pedestrian or cyclist keeps its storyboard events)."""
    values = dict(situation.values)
    intsit = values.get("intsit")
    if not isinstance(intsit, Mapping) or "conflict" not in intsit:
        return None
    scene = plan_scene(carla_map, values, seed=0)
    if scene is not None and not scene.car_ov:
        return None
    return conflict_point(carla_map, values, str(intsit["conflict"])), switch_distance(
        carla_map, intsit
    )


def _stop_trigger(xosc: Any, goal: tuple[float, float], tolerance: float, others: list[str]) -> Any:
    trigger = xosc.Trigger("stop")
    conditions = [
        xosc.EntityTrigger(
            "collision" if other == "adversary" else f"collision_{other}",
            0.0,
            xosc.ConditionEdge.rising,
            xosc.CollisionCondition(other),
            "hero",
        )
        for other in others
    ]
    conditions += [
        xosc.EntityTrigger(
            "ego_at_goal",
            0.0,
            xosc.ConditionEdge.rising,
            xosc.ReachPositionCondition(_world(xosc, *goal), tolerance),
            "hero",
        ),
        xosc.ValueTrigger(
            "time_limit",
            0.0,
            xosc.ConditionEdge.rising,
            xosc.SimulationTimeCondition(SIM_TIMEOUT, xosc.Rule.greaterThan),
        ),
    ]
    for condition in conditions:  # groups are OR-ed
        trigger.add_conditiongroup(xosc.ConditionGroup().add_condition(condition))
    return trigger


def export_xosc(
    situations: Iterable[Any],
    out_dir: str | Path,
    *,
    map: str | Path = "Town03",  # noqa: A002
) -> list[Path]:
    """Write one ``<situation id>.xosc`` per situation into ``out_dir``; the paths written.

    Situations with the same id are written once.
    """
    spec = load_carla_map(map)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written: list[Path] = []
    seen: set[str] = set()
    for situation in situations:
        if situation.id in seen:
            continue
        seen.add(situation.id)
        path = out / f"{situation.id}.xosc"
        situation_scenario(situation, spec).write_xml(str(path))
        written.append(path)
    return written


def situations_from_json(text: str) -> list[Any]:
    """Situations from JSON text: one object, a list, or JSON lines (``sitcov generate``).

    ``text`` starting with ``@`` names a file to read.

    Raises:
        ConfigError: not JSON, or an object without ``bins`` and ``values``.
    """
    import json

    from sitcov.hyperspace import Situation

    source = "--situation-json"
    if text.startswith("@"):
        source = text[1:]
        try:
            text = Path(source).read_text(encoding="utf-8")
        except OSError as exc:
            raise ConfigError(f"{source}: cannot read situations: {exc}") from None
    try:
        data = json.loads(text)
        items = data if isinstance(data, list) else [data]
    except json.JSONDecodeError:
        try:
            items = [json.loads(line) for line in text.splitlines() if line.strip()]
        except json.JSONDecodeError as exc:
            raise ConfigError(
                file=source, field="(json)", expected=f"JSON situations ({exc.msg})"
            ) from None
    out = []
    for i, item in enumerate(items):
        if not isinstance(item, Mapping) or not {"bins", "values"} <= set(item):
            raise ConfigError(
                file=source, field=f"[{i}]", expected='an object with "bins" and "values"'
            )
        try:
            out.append(Situation.from_dict(item))
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{source}: [{i}]: {exc}") from None
    return out
