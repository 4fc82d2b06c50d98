"""Pedestrians, cyclists and extra cars in CARLA, driven by the embedded world's controllers.

A situation becomes road users exactly as in the embedded backend
(``sitcov.sim.embedded._scene``: ``parse_scene`` and ``build_actors`` on the map file's
``embedded_map``): the same routes (``actor_route``: crosswalks, bike positions, lanes), the
same conflicts with the ego, the same controllers (the paper's timing law for any actor
sharing a conflict, scripted cruise/stop/go traffic, the pedestrian behaviours). Each such
embedded actor gets a CARLA twin, spawned at its route's start:

- pedestrians as ``walker.pedestrian.*`` (``is_invincible`` set to false, so they can be
  hit), driven with ``carla.WalkerControl(direction, speed)``;
- cyclists as a two-wheeled ``vehicle.*`` blueprint and extra cars as the OV's blueprint,
  driven with ``carla.VehicleControl``.

Every tick a twin's pose and speed are read back from CARLA into its embedded actor and its
controller gives ``(throttle, brake, steer)`` as in the embedded world. A cyclist or car
gets them as they are (``carla.VehicleControl``; steer sign flipped for CARLA's frame). A
pedestrian's body model (``_bodies.Walker``: acceleration limits, turn rate) advances one
step under them and the walker is told to walk at the body's speed along its heading
(``carla.WalkerControl``), since CARLA walkers take a direction and a speed.

:class:`Frame` places the embedded map on the CARLA junction: its centre on the map file's
``junction``, turned by ``embedded_rotation_deg`` (sitcov's right-handed frame).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

from sitcov.errors import ConfigError
from sitcov.sim._adversary import AdversaryParams
from sitcov.sim.carla._geometry import carla_transform, steer_to_carla
from sitcov.sim.carla._mapfile import CarlaMap
from sitcov.sim.carla._metrics import MetricTracker, VehicleState
from sitcov.sim.carla._state import vehicle_state
from sitcov.sim.embedded._actors import Actor
from sitcov.sim.embedded._bodies import body_spec
from sitcov.sim.embedded._controllers import CROSSING_BEHAVIOURS
from sitcov.sim.embedded._map import JunctionMap, find_conflict, load_map
from sitcov.sim.embedded._path import Path
from sitcov.sim.embedded._scene import (
    ActorPlan,
    ScenePlan,
    _controller,
    build_actors,
    parse_scene,
)
from sitcov.sim.embedded._world import World
from sitcov.sim.embedded._yielding import watch

#: Spawn height [m] above the map's ground (walkers are placed by their centre).
SPAWN_Z = {"pedestrian": 1.0, "cyclist": 0.5, "car": 0.5}
#: An actor within this of its route's end [m] is done (for the early end).
END_MARGIN = 1.0
#: Conflict labels of derived hyperspaces (``sitcov hyperspace derive``): k1, k2, ...
DERIVED_CONFLICT = re.compile(r"k\d+")
#: Number of wheels a cyclist's blueprint must have.
BICYCLE_WHEELS = 2
#: Behaviours whose controllers time the actor on the ego's arc length to the conflict.
EGO_TIMED = frozenset({"timed", *CROSSING_BEHAVIOURS})


@dataclass(frozen=True)
class Frame:
    """The embedded map's frame placed on the CARLA junction (sitcov frame: CARLA's (x, -y)).

    Attributes:
        x0, y0: the embedded map's centre in the sitcov frame [m].
        rotation: the embedded map's turn [rad], counter-clockwise.
    """

    x0: float
    y0: float
    rotation: float

    @classmethod
    def of(cls, spec: CarlaMap) -> Frame:
        """The frame of a map file (``junction`` and ``embedded_rotation_deg``)."""
        return cls(spec.junction.x, -spec.junction.y, math.radians(spec.embedded_rotation_deg))

    def to_sitcov(self, x: float, y: float, h: float) -> tuple[float, float, float]:
        """Embedded map (x, y [m], heading [rad]) -> sitcov frame."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        return self.x0 + c * x - s * y, self.y0 + s * x + c * y, h + self.rotation

    def to_map(self, x: float, y: float, h: float) -> tuple[float, float, float]:
        """Sitcov frame -> embedded map (the inverse of :meth:`to_sitcov`)."""
        c, s = math.cos(self.rotation), math.sin(self.rotation)
        dx, dy = x - self.x0, y - self.y0
        return c * dx + s * dy, -s * dx + c * dy, h - self.rotation

    def to_carla(self, x: float, y: float, h: float) -> tuple[float, float, float]:
        """Embedded map -> CARLA (x, y [m], yaw [deg], left-handed)."""
        sx, sy, sh = self.to_sitcov(x, y, h)
        return sx, -sy, -math.degrees(sh)


class SceneView(World):
    """The embedded world as its controllers read it (``ego``, ``ego_speed``, ``t``, ``dt``,
    ``bodies_except``); CARLA moves the bodies, so there is no driver, wind nor ``step``."""

    def __init__(self, ego: Actor, actors: list[Actor], dt: float, mu: float) -> None:
        super().__init__(ego, actors, None, None, mu, dt)  # type: ignore[arg-type]

    def step(self) -> None:
        """Not used: CARLA advances the world."""
        raise NotImplementedError("CARLA advances the world")


class Twin:
    """One embedded actor and the CARLA actor that plays it."""

    def __init__(self, actor: Actor, carla_actor: Any, frame: Frame) -> None:
        self.actor, self.carla_actor, self.frame = actor, carla_actor, frame
        self.route = [frame.to_sitcov(x, y, 0.0)[:2] for x, y in actor.route.points]

    @property
    def name(self) -> str:
        """The actor's name (``ov``, ``actor2``, ...)."""
        return self.actor.name

    def state(self) -> VehicleState:
        """Its CARLA state, sitcov frame."""
        return vehicle_state(self.carla_actor)

    def sync(self, state: VehicleState) -> None:
        """Put the embedded actor where CARLA has it, at CARLA's speed."""
        body = self.actor.body
        body.x, body.y, body.yaw = self.frame.to_map(state.x, state.y, state.yaw)
        body.vx, body.vy = state.speed, 0.0
        self.actor.track()

    def act(self, carla: Any, view: SceneView, mu: float) -> None:
        """The controller's command for one tick, as CARLA control (see the module
        docstring): a vehicle gets it as it is; a walker's body model turns it into the
        heading and speed of a ``WalkerControl``."""
        actor, body = self.actor, self.actor.body
        throttle, brake, steer = actor.controller.command(actor, view)
        if actor.kind != "pedestrian":
            self.carla_actor.apply_control(
                carla.VehicleControl(
                    throttle=_clip01(throttle), steer=steer_to_carla(steer), brake=_clip01(brake)
                )
            )
            return
        body.step(throttle, brake, steer, mu, 0.0, view.dt)
        heading = body.yaw + self.frame.rotation
        direction = carla.Vector3D(x=math.cos(heading), y=-math.sin(heading), z=0.0)
        self.carla_actor.apply_control(
            carla.WalkerControl(direction=direction, speed=float(body.speed))
        )

    def done(self) -> bool:
        """At its route's end, or stopped for good (its controller says so)."""
        actor = self.actor
        return actor.s >= actor.route.length - END_MARGIN or actor.controller.stuck(actor)


def _clip01(value: float) -> float:
    return max(0.0, min(1.0, float(value)))


@dataclass
class ScenePlanned:
    """The embedded side of a run: plan, ego actor (on the embedded map) and the actors that
    need CARLA twins (the primary OV among them unless it is a car)."""

    plan: ScenePlan
    ego: Actor
    actors: list[Actor]
    frame: Frame

    @property
    def car_ov(self) -> bool:
        """The primary OV is a car: the paper's OV driver drives it on CARLA's lanes."""
        return self.plan.actors[0].kind == "car"


def plan_scene(
    spec: CarlaMap,
    values: Mapping[str, Any],
    seed: int,
    ego_route: list[tuple[float, float]] | None = None,
) -> ScenePlanned | None:
    """The actors a situation adds to the paper's two cars; None for the paper's scene.

    Args:
        ego_route: the lane route the CARLA ego drives (CARLA frame), if known: every twin's
            conflict and controller are then taken against it (:func:`follow_carla_route`);
            without it they are the embedded ego path's (enough for routes and spawns).

    Raises:
        ConfigError: bad ``intsit``/``actorN`` values, a route the embedded map lacks, or
            an unknown ``embedded_map``.
    """
    plan = parse_scene(values)
    if plan.classic:
        return None
    jmap = load_map(spec.embedded_map)
    ego, actors = build_actors(jmap, plan, values, seed, AdversaryParams())
    frame = Frame.of(spec)
    pairs = list(zip(plan.actors, actors, strict=True))
    if plan.actors[0].kind == "car":
        pairs = pairs[1:]  # the paper's OV driver drives a car OV on CARLA's lanes
    if ego_route is not None:
        path = Path.from_points([frame.to_map(x, -y, 0.0)[:2] for x, y in ego_route])
        follow_carla_route(jmap, plan.ego, ego, path, pairs)
    # each twin watches the ego and the other twins (CARLA moves them; a car OV that the
    # paper's OV driver drives has no twin, so it is not among them)
    watch([actor for _, actor in pairs], ego)
    return ScenePlanned(plan, ego, [actor for _, actor in pairs], frame)


def follow_carla_route(
    jmap: JunctionMap,
    ego_move: str,
    ego: Actor,
    path: Path,
    pairs: list[tuple[ActorPlan, Actor]],
) -> None:
    """Put the embedded ego on ``path`` (the CARLA ego's lane route, embedded map frame) and
    re-derive the conflict and controller of each actor that times itself on the ego's
    progress (``timed``, the pedestrian crossing behaviours) against it. Scripted traffic
    keeps the embedded scene's conflict: its stop point is a place on its own route.

    Why: the controllers time their arrival with the ego's arc length on its route
    (``world.ego.s``) against the conflict's ``s_ego``. CARLA's lane planner gives a route
    of its own through the junction, so the embedded ego path is the wrong ruler for the
    CARLA ego: measured on it, a timed pedestrian aimed at a crossing point about a metre
    beside the lane the ego really drove and crossed behind it (issue 12's blind-ego
    check). Measuring both the ego's progress and the conflict on the route the ego
    drives makes the timing law hold as in the embedded world.
    """
    ego.route, ego.s, ego.hint = path, 0.0, 0
    car = body_spec("car")
    for plan, actor in pairs:
        if plan.behaviour not in EGO_TIMED:
            continue
        gap = 0.5 * (car.width + actor.spec.width)
        actor.conflict = find_conflict(path, actor.route, gap)
        own = getattr(actor.controller, "speed", None) if actor.kind != "car" else None
        actor.controller = _controller(jmap, plan, actor, ego_move, path, AdversaryParams(), own)


def conflict_point(spec: CarlaMap, values: Mapping[str, Any], label: str) -> tuple[float, float]:
    """The car OV's conflict point (CARLA frame): the map file's ``conflict_points`` entry
    for ``label`` (the paper's c1, c2, c4), else the embedded scene's conflict of the OV's
    route with the ego's (derived situations label theirs k1, k2, ...), placed by
    :class:`Frame`.

    Raises:
        ConfigError: the map file lacks the label and it is no derived ``k<n>`` label, or
            the embedded routes do not meet.
    """
    if label in spec.conflict_points or not DERIVED_CONFLICT.fullmatch(label):
        return spec.conflict_point(label)  # a typo stays an error naming the map's points
    plan = parse_scene(values)
    _, actors = build_actors(load_map(spec.embedded_map), plan, values, 0, AdversaryParams())
    conflict = actors[0].conflict
    if conflict is None:
        return spec.conflict_point(label)  # raises: names the map file's points
    x, y, _ = Frame.of(spec).to_carla(*conflict.point, 0.0)
    return x, y


def blueprint(library: Any, spec: CarlaMap, actor: Actor) -> Any:
    """The blueprint of an actor's kind, set up (walkers can be hit; the actor's colour).

    Raises:
        ConfigError: the map file's ``bicycle_blueprint`` is not a two-wheeler.
    """
    kind = actor.kind
    name = {"pedestrian": spec.walker_blueprint, "cyclist": spec.bicycle_blueprint}.get(
        kind, spec.ov_blueprint
    )
    bp = _find(library, spec, "bicycle_blueprint" if kind == "cyclist" else "", name)
    if kind == "cyclist":
        _two_wheeled(bp, spec)
    if kind == "pedestrian" and bp.has_attribute("is_invincible"):
        bp.set_attribute("is_invincible", "false")
    if actor.color is not None and bp.has_attribute("color"):
        bp.set_attribute("color", ",".join(map(str, actor.color)))
    return bp


def check_blueprints(library: Any, spec: CarlaMap) -> str:
    """Whether the server has the map file's walker and (two-wheeled) bicycle blueprints;
    a one-line summary (``sitcov carla-check``).

    Raises:
        ConfigError: a blueprint is missing, or the bicycle is not a two-wheeler.
    """
    _find(library, spec, "walker_blueprint", spec.walker_blueprint)
    _two_wheeled(_find(library, spec, "bicycle_blueprint", spec.bicycle_blueprint), spec)
    return f"pedestrians {spec.walker_blueprint}, cyclists {spec.bicycle_blueprint}"


def _find(library: Any, spec: CarlaMap, field: str, name: str) -> Any:
    try:
        return library.find(name)
    except IndexError:
        if not field:
            raise
        raise ConfigError(
            field=f"{spec.name}: {field}", value=name, expected="a blueprint this server has"
        ) from None


def _two_wheeled(bp: Any, spec: CarlaMap) -> None:
    wheels = bp.get_attribute("number_of_wheels").as_int()
    if wheels != BICYCLE_WHEELS:
        raise ConfigError(
            field=f"{spec.name}: bicycle_blueprint",
            value=f"{spec.bicycle_blueprint} ({wheels} wheels)",
            expected="a two-wheeled vehicle.* blueprint, e.g. vehicle.diamondback.century",
        )


def spawn_twins(
    carla: Any, world: Any, library: Any, spec: CarlaMap, scene: ScenePlanned, spawned: list
) -> list[Twin]:
    """Spawn a CARLA actor per scene actor at its route's start; each is appended to
    ``spawned`` as soon as it exists (the backend's cleanup list)."""
    twins = []
    for actor in scene.actors:
        bp = blueprint(library, spec, actor)
        body = actor.body
        x, y, yaw = scene.frame.to_carla(body.x, body.y, body.yaw)
        carla_actor = world.spawn_actor(
            bp, carla_transform(carla, x, y, SPAWN_Z.get(actor.kind, 0.5), yaw)
        )
        spawned.append(carla_actor)
        twins.append(Twin(actor, carla_actor, scene.frame))
    return twins


class Scene:
    """The twins of one run: read back, drive, measure and record them every tick.

    Args:
        scene: the embedded side (:func:`plan_scene`).
        twins: their CARLA actors (:func:`spawn_twins`).
        ego_route: the ego's CARLA route, sitcov frame (for the per-actor metrics).
        dt: the step [s]. mu: tyre-road friction the body models use [-].
    """

    def __init__(
        self,
        scene: ScenePlanned,
        twins: list[Twin],
        ego_route: list[tuple[float, float]],
        dt: float,
        mu: float,
    ) -> None:
        self.scene, self.twins, self.mu = scene, twins, mu
        self.view = SceneView(scene.ego, [tw.actor for tw in twins], dt, mu)
        self.trackers = {tw.name: MetricTracker(ego_route, tw.route) for tw in twins}
        self.states: dict[str, VehicleState] = {}
        self.rows: dict[str, list[tuple[float, float, float, float, float]]] = {
            tw.name: [] for tw in twins
        }

    def by_id(self) -> dict[int, Twin]:
        """Twins by CARLA actor id (to name what the ego's collision sensor hit)."""
        return {tw.carla_actor.id: tw for tw in self.twins}

    def observe(self, t: float, ego: VehicleState, record: bool) -> None:
        """Read every twin back from CARLA; move the embedded ego; update the metrics."""
        view = self.view
        view.ego_decel = (view.ego_speed - ego.speed) / view.dt if t > 0.0 else 0.0
        view.t, view.ego_speed = t, ego.speed
        me = view.ego
        body = me.body
        body.x, body.y, body.yaw = self.scene.frame.to_map(ego.x, ego.y, ego.yaw)
        # the closest route point near the last one: a lane route may turn at a sharp
        # corner the ego cuts, where Path.track would stay on the segment before it
        me.s, me.hint = me.route.project(body.x, body.y, me.hint)
        for tw in self.twins:
            state = self.states[tw.name] = tw.state()
            tw.sync(state)
            self.trackers[tw.name].update(t, ego, state)
            if record:
                self.rows[tw.name].append((t, state.x, state.y, state.yaw, state.speed))

    def act(self, carla: Any) -> None:
        """Command every twin for the coming tick."""
        for tw in self.twins:
            tw.act(carla, self.view, self.mu)

    def done(self) -> bool:
        """Every twin at its route's end or stopped for good."""
        return all(tw.done() for tw in self.twins)

    def metrics(self, collided: str | None) -> dict[str, Any]:
        """Per actor: kind, route, behaviour, conflict type and its own criticality metrics
        against the ego (``min_distance``, ``min_ttc``, ``pet``)."""
        out = {}
        for tw in self.twins:
            track = self.trackers[tw.name]
            actor = tw.actor
            out[tw.name] = {
                "kind": actor.kind,
                **actor.info,
                "blueprint": tw.carla_actor.type_id,
                "min_distance": None if math.isinf(track.min_distance) else track.min_distance,
                "min_ttc": track.min_ttc,
                "pet": track.pet(collided=collided == tw.name),
            }
        return out

    def trace_meta(self) -> dict[str, Any]:
        """Each twin's kind, size and route (sitcov frame), as the embedded traces give."""
        return {
            tw.name: {
                "kind": tw.actor.kind,
                "length": tw.actor.spec.length,
                "width": tw.actor.spec.width,
                "height": tw.actor.spec.height,
                "route": [list(p) for p in tw.route],
            }
            for tw in self.twins
        }
