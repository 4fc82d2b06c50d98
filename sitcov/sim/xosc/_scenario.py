"""One sitcov run as an OpenSCENARIO 1.2 file that plays in a real engine (esmini).

What the file holds, and why:

- ``RoadNetwork``: the run's road file. By default the map's own OpenDRIVE export
  (``sitcov.sim.embedded._odr``), so the scenario plays on exactly the geometry sitcov
  drove on; or another file (CARLA's Town03 for the paper's t-junction), the trajectories
  then placed on it by a rigid transform.
- Entities with sitcov's bodies: ``hero`` (the ego) and every road user of the run under
  its sitcov name (``ov``, ``actor2``, ...): a car or a bicycle ``Vehicle`` or a
  ``Pedestrian``, bounding box = sitcov's footprint box centred on the reference point
  (sitcov's body position), so an engine's box overlap is sitcov's collision test.
- Every road user on its STORED trajectory (the run re-simulated with recording): a timed
  ``FollowTrajectoryAction`` (absolute timing, ``position`` following mode). The adversary
  reaches the conflict point exactly when it did in sitcov, along the real lane path with
  its real speed profile; a pedestrian crosses, a ``kerb`` pedestrian stops at the kerb, a
  ``hesitate`` one waits and goes, a ``stop`` car halts where it halted: whatever the
  controllers did, as it happened. Vertices are kept where straight-line interpolation in
  time would be off by more than :data:`TOLERANCE`.
- The hero also follows its stored trajectory (how sitcov's stack drove); it is assigned its
  lane route (spawn, the movement's connecting road, the exit leg; lane positions, so the
  route is valid on the network and takes the lane that allows the turn) for a user's own
  controller: replace the ``hero`` maneuver group to let your stack drive.
- ``ParameterDeclarations``: situation id, bins, run seed, campaign and index, fault,
  stored verdict (status, failure kind, end reason, which road user was hit and when).
- A road user that left the world at the end of its route in sitcov is deleted then
  (``DeleteEntityAction``), so it does not drive on in the engine.
- A stop trigger: the hero collides with any road user, or the stored run's end (plus
  :data:`END_MARGIN` after a stored collision, which an engine may see a step later).
"""

from __future__ import annotations

import datetime
import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sitcov.errors import MissingExtraError
from sitcov.sim.embedded._bodies import body_spec

#: Largest position error of the written trajectories against the stored rows [m].
TOLERANCE = 0.02
#: Largest heading error of the written trajectories [rad].
HEADING_TOLERANCE = 0.02
#: Simulated time the scenario runs past the stored run's end [s].
END_MARGIN = 1.0
#: Fixed header date: the same run always gives the same file.
CREATION_DATE = datetime.datetime(2024, 1, 1)
#: OpenSCENARIO minor version written (1.2: esmini 2.x/3.x, ScenarioRunner 0.9.15+).
OSC_MINOR = 2

Row = tuple[float, float, float, float, float]
Placement = Callable[[float, float, float], tuple[float, float, float]]


def _xosc() -> Any:
    try:
        from scenariogeneration import xosc
    except ImportError:
        raise MissingExtraError("OpenSCENARIO export", "xosc", "scenariogeneration") from None
    # scenariogeneration checks every element against one process-wide version, which the
    # last Scenario built set (the CARLA exporter writes 1.0): set ours before building
    xosc.VersionBase().setVersion(minor=OSC_MINOR)
    return xosc


@dataclass(frozen=True)
class RunFacts:
    """What sitcov stored about a run, written as parameters.

    Attributes:
        campaign, index, seed: which run.
        fault: the AV stack's fault ("none" without one).
        status, failure_kind, end_reason: the stored verdict.
        collision_actor: the road user the ego hit (``ov``, ``actor2``...) or "".
        collision_time: when [s] (-1 without a collision).
        sim_time: the run's simulated duration [s].
        reproduced: the re-simulation that gave the trajectories ended as stored (status
            and collision time); written as ``sitcov_reproduced``.
    """

    campaign: str
    index: int
    seed: int
    fault: str
    status: str
    failure_kind: str
    end_reason: str
    collision_actor: str
    collision_time: float
    sim_time: float
    reproduced: bool = True


@dataclass(frozen=True)
class HeroRoute:
    """The hero's lane route: (road id, lane id, s [m]) waypoints."""

    waypoints: tuple[tuple[int, int, float], ...]


def identity(x: float, y: float, h: float) -> tuple[float, float, float]:
    """The map's own frame (the exported road file's)."""
    return x, y, h


def simplify(rows: Sequence[Row], tolerance: float = TOLERANCE) -> list[Row]:
    """The rows to keep so that straight-line interpolation in time between kept rows is
    within ``tolerance`` [m] of every dropped row (first and last always kept)."""
    if len(rows) <= 2:
        return list(rows)
    keep = [0]
    i = 0
    n = len(rows)
    while i < n - 1:
        j = i + 1
        while j + 1 < n and _fits(rows, i, j + 1, tolerance):
            j += 1
        keep.append(j)
        i = j
    return [rows[k] for k in keep]


def _fits(rows: Sequence[Row], i: int, j: int, tolerance: float) -> bool:
    """Rows i..j lie on the straight line in time from row i to row j (position within
    ``tolerance`` [m], heading within :data:`HEADING_TOLERANCE`)."""
    t0, x0, y0, h0 = rows[i][:4]
    t1, x1, y1, h1 = rows[j][:4]
    span, turn = t1 - t0, _wrap(h1 - h0)
    if span <= 0:
        return False
    for k in range(i + 1, j):
        t, x, y, h = rows[k][:4]
        f = (t - t0) / span
        if math.hypot(x0 + f * (x1 - x0) - x, y0 + f * (y1 - y0) - y) > tolerance:
            return False
        if abs(_wrap(h0 + f * turn - h)) > HEADING_TOLERANCE:
            return False
    return True


def _wrap(a: float) -> float:
    return math.atan2(math.sin(a), math.cos(a))


def _position(xosc: Any, place: Placement, x: float, y: float, h: float) -> Any:
    px, py, ph = place(x, y, h)
    return xosc.WorldPosition(x=round(px, 4), y=round(py, 4), z=0.0, h=round(_wrap(ph), 5))


def _trajectory_action(xosc: Any, name: str, rows: Sequence[Row], place: Placement) -> Any:
    kept = simplify(rows)
    traj = xosc.Trajectory(f"{name}_trajectory", False)
    traj.add_shape(
        xosc.Polyline(
            [round(r[0], 4) for r in kept],
            [_position(xosc, place, r[1], r[2], r[3]) for r in kept],
        )
    )
    return xosc.FollowTrajectoryAction(
        traj, xosc.FollowingMode.position, xosc.ReferenceContext.absolute, 1, 0
    )


def _entity(xosc: Any, kind: str, length: float, width: float, height: float, name: str) -> Any:
    box = xosc.BoundingBox(width, length, height, 0.0, 0.0, 0.5 * height)
    if kind == "pedestrian":
        entity = xosc.Pedestrian(
            "pedestrian", 80.0, xosc.PedestrianCategory.pedestrian, box, model="pedestrian"
        )
    else:
        spec = body_spec(kind)
        wheel = 0.7 if kind == "cyclist" else 0.68
        # rear axle at the reference point: esmini moves the reference point onto a rear
        # axle placed elsewhere (and the box with it); the box stays centred on sitcov's body
        base = spec.wheelbase or 0.6 * length
        track = 0.1 if kind == "cyclist" else 1.6
        front = xosc.Axle(spec.steer_max or 0.6, wheel, track, base, 0.5 * wheel)
        rear = xosc.Axle(0.0, wheel, track, 0.0, 0.5 * wheel)
        category = xosc.VehicleCategory.bicycle if kind == "cyclist" else xosc.VehicleCategory.car
        entity = xosc.Vehicle(
            kind, category, box, front, rear, max(spec.v_max, 1.0), spec.a_max, spec.b_max,
            mass=80.0 if kind == "cyclist" else 1500.0,
        )  # fmt: skip
    # ScenarioRunner's roles: the hero is the ego vehicle its agent drives
    entity.add_property("type", "ego_vehicle" if name == "ego" else "simulation")
    entity.add_property("sitcov_kind", kind)
    entity.add_property("sitcov_name", name)
    return entity


def _start(xosc: Any) -> Any:
    return xosc.ValueTrigger(
        "start", 0.0, xosc.ConditionEdge.none,
        xosc.SimulationTimeCondition(0.0, xosc.Rule.greaterOrEqual),
    )  # fmt: skip


def _parameters(xosc: Any, situation: Any, facts: RunFacts, map_name: str) -> Any:
    params = xosc.ParameterDeclarations()
    string, double, integer = (
        xosc.ParameterType.string,
        xosc.ParameterType.double,
        xosc.ParameterType.int,
    )
    entries: list[tuple[str, Any, Any]] = [
        ("sitcov_situation", string, situation.id),
        ("sitcov_map", string, map_name),
        ("sitcov_campaign", string, facts.campaign),
        ("sitcov_index", integer, facts.index),
        ("sitcov_seed", integer, facts.seed),
        ("sitcov_fault", string, facts.fault),
        ("sitcov_status", string, facts.status),
        ("sitcov_failure_kind", string, facts.failure_kind),
        ("sitcov_end_reason", string, facts.end_reason),
        ("sitcov_collision_actor", string, facts.collision_actor),
        ("sitcov_collision_time", double, round(facts.collision_time, 4)),
        ("sitcov_sim_time", double, round(facts.sim_time, 4)),
        ("sitcov_reproduced", xosc.ParameterType.boolean, str(facts.reproduced).lower()),
    ]
    entries += [(f"bin_{k}", string, str(v)) for k, v in sorted(situation.bins.items())]
    for name, kind, value in entries:
        params.add_parameter(xosc.Parameter(name, kind, str(value)))
    return params


def _stop_trigger(xosc: Any, others: Sequence[str], end: float) -> Any:
    trigger = xosc.Trigger("stop")
    conditions = [
        xosc.EntityTrigger(
            f"hero_hits_{other}",
            0.0,
            xosc.ConditionEdge.rising,
            xosc.CollisionCondition(other),
            "hero",
        )  # fmt: skip
        for other in others
    ]
    conditions.append(
        xosc.ValueTrigger(
            "stored_run_ended",
            0.0,
            xosc.ConditionEdge.rising,
            xosc.SimulationTimeCondition(round(end, 3), xosc.Rule.greaterThan),
        )  # fmt: skip
    )
    for condition in conditions:  # groups are OR-ed
        trigger.add_conditiongroup(xosc.ConditionGroup().add_condition(condition))
    return trigger


def run_scenario(
    situation: Any,
    trace: Any,
    facts: RunFacts,
    *,
    road_file: str,
    map_name: str,
    place: Placement = identity,
    route: HeroRoute | None = None,
    environment: Any = None,
) -> Any:
    """The ``scenariogeneration`` Scenario of one recorded run (see the module docstring).

    Args:
        situation: the run's situation (``id``, ``bins``, ``values``).
        trace: the run's :class:`sitcov.sim.Trace` (ego rows, every actor's rows, meta).
        facts: the stored verdict and provenance.
        road_file: the ``LogicFile`` path written (relative to the scenario file).
        map_name: the sitcov map the run drove on.
        place: map frame -> the road file's frame (x, y [m], heading [rad]).
        route: the hero's lane route on the road file, if it is sitcov's own export.
        environment: an OpenSCENARIO ``Environment`` for the init (weather), or None.

    Raises:
        MissingExtraError: scenariogeneration is not installed.
    """
    xosc = _xosc()
    meta = trace.meta
    entities = xosc.Entities()
    entities.add_scenario_object(
        "hero", _entity(xosc, "car", meta["length"], meta["width"], 1.5, "ego")
    )
    init = xosc.Init()
    if environment is not None:
        init.add_global_action(xosc.EnvironmentAction(environment))
    groups: list[tuple[str, list[Any]]] = []
    movers = [("hero", trace.ego)]
    for name, info in meta.get("actors", {}).items():
        rows = trace.actors.get(name) or []
        if not rows:
            continue
        entities.add_scenario_object(
            name,
            _entity(xosc, info["kind"], info["length"], info["width"], info["height"], name),
        )
        movers.append((name, rows))
    for name, rows in movers:
        t, x, y, h, v = rows[0]
        init.add_init_action(name, xosc.TeleportAction(_position(xosc, place, x, y, h)))
        init.add_init_action(
            name,
            xosc.AbsoluteSpeedAction(
                round(v, 4),
                xosc.TransitionDynamics(xosc.DynamicsShapes.step, xosc.DynamicsDimension.time, 0),
            ),
        )
        if name == "hero" and route is not None:
            lane_route = xosc.Route("hero_route")
            for road, lane, s in route.waypoints:
                lane_route.add_waypoint(
                    xosc.LanePosition(round(s, 3), 0, lane, road), xosc.RouteStrategy.shortest
                )
            init.add_init_action(name, xosc.AssignRouteAction(lane_route))
        event = xosc.Event(f"{name}_as_stored", xosc.Priority.override)
        event.add_action(f"{name}_trajectory", _trajectory_action(xosc, name, rows, place))
        event.add_trigger(_start(xosc))
        events = [event]
        dt = float(meta.get("dt", 0.05))
        if name != "hero" and rows[-1][0] < facts.sim_time - 0.5 * dt:
            # it left the world at the end of its route (sitcov's LeaveMapRule)
            leave = xosc.Event(f"{name}_leaves", xosc.Priority.parallel)
            leave.add_action(f"{name}_delete", xosc.DeleteEntityAction(name))
            leave.add_trigger(
                xosc.ValueTrigger(
                    f"{name}_route_end",
                    0.0,
                    xosc.ConditionEdge.rising,
                    xosc.SimulationTimeCondition(round(rows[-1][0], 3), xosc.Rule.greaterThan),
                )  # fmt: skip
            )
            events.append(leave)
        groups.append((name, events))
    others = [name for name, _ in movers[1:]]
    # past a collision esmini may find it a step later; any other run ends where it ended
    end = facts.sim_time + (END_MARGIN if facts.end_reason == "collision" else 0.0)
    storyboard = xosc.StoryBoard(init, _stop_trigger(xosc, others, end))
    for name, events in groups:
        maneuver = xosc.Maneuver(f"{name}_maneuver")
        for event in events:
            maneuver.add_event(event)
        group = xosc.ManeuverGroup(f"{name}_group")
        group.add_actor(name)
        group.add_maneuver(maneuver)
        storyboard.add_maneuver_group(group, starttrigger=_start(xosc))
    return xosc.Scenario(
        f"sitcov {facts.campaign}:{facts.index} {situation.id}",
        "sitcov",
        _parameters(xosc, situation, facts, map_name),
        entities,
        storyboard,
        xosc.RoadNetwork(roadfile=road_file),
        xosc.Catalog(),
        osc_minor_version=OSC_MINOR,
        creation_date=CREATION_DATE,
    )


#: Rain in mm/h at the situation's ``precipitation`` 100 (CARLA's heaviest: a downpour).
RAIN_MM_H_AT_100 = 10.0


def environment(values: Mapping[str, Any]) -> Any:
    """The situation's weather and road grip as an OpenSCENARIO 1.2 ``Environment``: cloud
    cover in oktas from ``cloudiness`` [%], fog visual range from sitcov's visibility model,
    rain [mm/h] from ``precipitation`` [%], ``frictionScaleFactor`` = the embedded world's
    friction relative to dry asphalt (the same scale the CARLA backend applies)."""
    from sitcov.sim.carla._backend import friction_scale
    from sitcov.weather._conditions import conditions_from_values

    xosc = _xosc()
    oktas = [
        "zeroOktas", "oneOktas", "twoOktas", "threeOktas", "fourOktas", "fiveOktas",
        "sixOktas", "sevenOktas", "eightOktas",
    ]  # fmt: skip
    cloud = float(values.get("cloudiness", 0.0))
    rain = float(values.get("precipitation", 0.0))
    cover = getattr(xosc.FractionalCloudCover, oktas[round(max(0.0, min(cloud, 100.0)) * 0.08)])
    visibility = conditions_from_values(values).visibility
    weather = xosc.Weather(
        cover,
        fog=xosc.Fog(visual_range=int(min(100000.0, visibility))),
        precipitation=xosc.Precipitation(
            xosc.PrecipitationType.rain if rain > 0 else xosc.PrecipitationType.dry,
            round(rain / 100.0 * RAIN_MM_H_AT_100, 3),
        ),
    )
    road = xosc.RoadCondition(friction_scale_factor=round(friction_scale(values), 6))
    return xosc.Environment(
        "sitcov_environment", xosc.TimeOfDay(False, 2024, 6, 21, 12, 0, 0), weather, road
    )


def facts_of(run: Any, outcome: Any) -> RunFacts:
    """:class:`RunFacts` of a stored run (its record and outcome)."""
    metrics: Mapping[str, Any] = outcome.metrics or {}
    return RunFacts(
        campaign=str(run.campaign),
        index=int(run.index),
        seed=int(run.seed),
        fault=str(run.config.get("fault") or "none"),
        status=str(outcome.status),
        failure_kind=str(outcome.kind),
        end_reason=str(outcome.end_reason),
        collision_actor=str(metrics.get("collision_actor") or ("ov" if outcome.collision else "")),
        collision_time=float(outcome.collision_time if outcome.collision_time is not None else -1),
        sim_time=float(outcome.sim_time),
    )
