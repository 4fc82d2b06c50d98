"""The scene of a run: which actors a situation's values put on the map, and how each acts.

Situation values (docs/embedded.md, "Scene"):

- ``intsit``: ``{ego: "L-B", ov: "R-B", conflict: "c4"}`` as in the paper; optional
  ``kind`` of the OV (``car`` | ``cyclist`` | ``pedestrian``, default ``car``; for a
  pedestrian ``ov`` is a crosswalk route such as ``"XBL"``) and ``type`` (the conflict
  type, recorded only). The OV follows the paper's timing law.
- ``actor2``, ``actor3``, ...: ``"none"`` or ``{kind, route, behaviour?, conflict?,
  start?}``: an extra road user on ``route`` (``sitcov.sim.embedded._routes.actor_route``);
  ``behaviour`` is a controller name (:data:`BEHAVIOURS`) or a mapping ``{name, ...its
  parameters}``; ``conflict`` is a conflict type (recorded only); ``start`` the distance
  [m] from the junction centre where a car or cyclist spawns (default: the map's OV spawn
  on that leg, 8 m further out per earlier actor starting on the same leg).

A situation with no extra actor and a car OV is the paper's two-car scene; its runs are
exactly those of the two-car backend before actors existed (a golden test checks it).
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.perception._colors import OV_COLOR_KEY, PALETTE, draw_color, ov_color
from sitcov.sim._adversary import AdversaryParams, with_switch_distance
from sitcov.sim.embedded._actors import Actor
from sitcov.sim.embedded._bodies import SPEEDS, body_spec, make_body
from sitcov.sim.embedded._controllers import (
    CROSSING_BEHAVIOURS,
    CrossingController,
    PacedController,
    ScriptedController,
    TimingController,
)
from sitcov.sim.embedded._map import Conflict, JunctionMap, Scenario, find_conflict
from sitcov.sim.embedded._path import Path
from sitcov.sim.embedded._routes import actor_route
from sitcov.sim.embedded._yielding import watch

#: The intersection situation used when a situation has no ``intsit`` element (IntSit-1).
DEFAULT_INTSIT = {"ego": "L-B", "ov": "R-B", "conflict": "c4"}
#: Kinds an actor may have.
ACTOR_KINDS = ("car", "cyclist", "pedestrian")
#: Controller names an actor slot's ``behaviour`` may take, and the kinds they fit.
BEHAVIOURS: dict[str, tuple[str, ...]] = {
    "timed": ACTOR_KINDS,  # the paper's timing law on the conflict with the ego
    "cruise": ("car", "cyclist"),  # scripted: cruise, keep a gap to whoever is ahead
    "stop": ("car", "cyclist"),  # scripted: stop before the conflict zone for good
    "stop-go": ("car", "cyclist"),  # scripted: stop there for ``wait`` s, then go on
    **{name: ("pedestrian",) for name in CROSSING_BEHAVIOURS},
}
#: Cruise speed of scripted cars [m/s] (the ego's 25 km/h).
SCRIPTED_CAR_SPEED = 25.0 / 3.6
#: Queueing: each further car or cyclist starting on the same leg spawns this far back [m].
QUEUE_SPACING = 8.0
#: The ego's speed and the time it loses starting from standing [s] that a timed cyclist's
#: spawn assumes (the reference stack's 25 km/h, reached in about 3.5 s): ``_timed_reach``.
EGO_NOMINAL_SPEED, EGO_RAMP = 25.0 / 3.6, 1.7
#: Spawn key of the actors' speed draws (one stream per actor and run: adding it shifts no
#: other stream). "SPD" in ASCII.
SPEED_KEY = 0x535044
#: Scripted stops: the actor's front stops this far before its conflict zone [m].
STOP_SHORT = 2.0
_SLOT = re.compile(r"actor(\d+)$")


@dataclass(frozen=True)
class ActorPlan:
    """One non-ego actor as the situation describes it."""

    name: str
    kind: str
    route: str
    behaviour: str
    params: dict[str, Any] = field(default_factory=dict)
    conflict_type: str | None = None
    start: float | None = None


@dataclass(frozen=True)
class ScenePlan:
    """The ego's movement, the conflict label and every other actor (primary OV first)."""

    ego: str
    conflict_label: str
    actors: tuple[ActorPlan, ...]

    @property
    def classic(self) -> bool:
        """The paper's two-car scene (its runs keep exactly their old metrics)."""
        return len(self.actors) == 1 and self.actors[0].kind == "car"


def parse_intsit(value: Any) -> dict[str, str]:
    """``intsit`` as strings: ego, ov, conflict, kind, type."""
    if value is None:
        value = DEFAULT_INTSIT
    if not isinstance(value, Mapping) or "ego" not in value or "ov" not in value:
        raise ConfigError(
            field="intsit",
            value=value,
            expected="a mapping with 'ego' and 'ov' movements like 'L-B'",
        )
    kind = str(value.get("kind", "car"))
    if kind not in ACTOR_KINDS:
        raise ConfigError(field="intsit.kind", value=kind, expected=" | ".join(ACTOR_KINDS))
    return {
        "ego": str(value["ego"]),
        "ov": str(value["ov"]),
        "conflict": str(value.get("conflict", "")),
        "kind": kind,
        "type": str(value.get("type", "")),
    }


def _behaviour(name: str, kind: str, value: Any) -> tuple[str, dict[str, Any]]:
    params: dict[str, Any] = {}
    if isinstance(value, Mapping):
        params = {str(k): v for k, v in value.items() if k != "name"}
        value = value.get("name")
    if value is None:
        return ("cross" if kind == "pedestrian" else "timed"), params
    if str(value) not in BEHAVIOURS or kind not in BEHAVIOURS[str(value)]:
        fits = sorted(b for b, kinds in BEHAVIOURS.items() if kind in kinds)
        raise ConfigError(field=f"{name}.behaviour", value=value, expected=" | ".join(fits))
    return str(value), params


def parse_slot(name: str, value: Any) -> ActorPlan | None:
    """An ``actorN`` element's value: None for ``"none"``, else its :class:`ActorPlan`."""
    if value is None or value == "none":
        return None
    if not isinstance(value, Mapping) or "kind" not in value or "route" not in value:
        raise ConfigError(
            field=name,
            value=value,
            expected="'none' or a mapping {kind, route, behaviour?, conflict?}",
        )
    unknown = set(value) - {"kind", "route", "behaviour", "conflict", "start"}
    if unknown:
        raise ConfigError(
            field=f"{name}.{sorted(unknown)[0]}",
            value=value,
            expected="kind, route, behaviour, conflict, start",
        )
    kind = str(value["kind"])
    if kind not in ACTOR_KINDS:
        raise ConfigError(field=f"{name}.kind", value=kind, expected=" | ".join(ACTOR_KINDS))
    behaviour, params = _behaviour(name, kind, value.get("behaviour"))
    start = value.get("start")
    if start is not None and (
        isinstance(start, bool) or not isinstance(start, int | float) or start <= 0
    ):
        raise ConfigError(field=f"{name}.start", value=start, expected="a distance > 0 [m]")
    conflict = value.get("conflict")
    return ActorPlan(
        name,
        kind,
        str(value["route"]),
        behaviour,
        params,
        None if conflict is None else str(conflict),
        None if start is None else float(start),
    )


def check_value(map: JunctionMap, name: str, value: Any) -> None:  # noqa: A002
    """One ``intsit`` or ``actorN`` value as a hyperspace bin gives it: it parses, and each
    route it names exists on ``map`` for its kind (before any run, not in every run).

    Raises:
        ConfigError: with the field inside the value (``intsit.ov``, ``actor2.behavior``).
    """
    if name == "intsit":
        intsit = parse_intsit(value)
        routes = (("ego", "car", intsit["ego"]), ("ov", intsit["kind"], intsit["ov"]))
    else:
        plan = parse_slot(name, value)
        routes = () if plan is None else (("route", plan.kind, plan.route),)
    for key, kind, route in routes:
        try:
            actor_route(map, kind, route)
        except ConfigError as exc:
            raise ConfigError(field=f"{name}.{key}", value=route, expected=exc.expected) from None


def check_scene_values(
    map: JunctionMap,  # noqa: A002
    hyperspace: Any,
    *,
    intsit: bool = True,
) -> None:
    """Every ``intsit`` (unless ``intsit`` is False) and ``actorN`` bin of ``hyperspace``
    through :func:`check_value`; the error's field names the element, bin and key
    (``actor2.bins[1] (car:B-L).value.behavior``)."""
    for element in hyperspace.elements:
        if not is_scene_element(element.name) or (element.name == "intsit" and not intsit):
            continue
        for i, bin_ in enumerate(element.bins):
            if bin_.range is not None:
                continue
            try:
                check_value(map, element.name, bin_.value)
            except ConfigError as exc:
                inner = (exc.field or element.name).partition(".")[2]
                field = f"{element.name}.bins[{i}] ({bin_.label}).value"
                raise ConfigError(
                    field=f"{field}.{inner}" if inner else field,
                    value=exc.value,
                    expected=exc.expected,
                ) from None


def is_scene_element(name: str) -> bool:
    """Whether an element's values say who is on the map (``intsit``, ``actorN``)."""
    return name == "intsit" or _SLOT.match(name) is not None


def parse_scene(values: Mapping[str, Any]) -> ScenePlan:
    """The :class:`ScenePlan` of a situation's values (raises ConfigError on bad values)."""
    intsit = parse_intsit(values.get("intsit"))
    ov = ActorPlan(
        "ov", intsit["kind"], intsit["ov"], "timed", conflict_type=intsit["type"] or None
    )
    slots = sorted(
        ((int(m.group(1)), key) for key in values if (m := _SLOT.match(str(key)))),
    )
    extra = [plan for _, key in slots if (plan := parse_slot(key, values[key])) is not None]
    return ScenePlan(intsit["ego"], intsit["conflict"], (ov, *extra))


# --- building the actors ---------------------------------------------------------------------


@functools.lru_cache(maxsize=256)
def ego_route(map: JunctionMap, move: str) -> Path:  # noqa: A002
    """The ego's route for ``move``: from its spawn to its goal (as ``JunctionMap.scenario``)."""
    a, b = map._parse_move(move)
    full = map.route(a, b)
    s0 = map._s_at_distance(full, map.legs[a], map.spawns["ego"][a], True)
    s1 = map._s_at_distance(full, map.legs[b], map.goal_distance, False)
    return full.sub(s0, s1, 1.0)


def _start(map: JunctionMap, plan: ActorPlan, queue: dict[str, int]) -> float | None:  # noqa: A002
    """Where a car or cyclist spawns [m from the centre] (None: a pedestrian's whole route)."""
    if plan.kind == "pedestrian":
        return None
    leg = plan.route.partition("-")[0]
    if leg not in map.legs:
        return None  # actor_route names the bad route
    n = queue.get(leg, 0)
    queue[leg] = n + 1
    return plan.start if plan.start is not None else map.spawns["ov"][leg] + QUEUE_SPACING * n


@functools.lru_cache(maxsize=1024)
def _geometry(
    map: JunctionMap,  # noqa: A002
    ego_move: str,
    name: str,
    kind: str,
    route_name: str,
    start: float | None,
    timed: bool = False,
) -> tuple[Path, Conflict | None, float]:
    """An actor's route (spawn to end), its conflict with the ego and its kerb arc length:
    the same for every run of the situation, so computed once.

    ``timed``: a timed cyclist at its map spawn; if it could not reach the conflict with
    the ego at an ordinary speed (:func:`_timed_reach`), it starts further along its route
    (already riding towards the conflict, e.g. on a roundabout's ring)."""
    route = actor_route(map, kind, route_name)
    if start is not None:
        s0 = map.legs[route_name.partition("-")[0]].length - start
        if not 0.0 <= s0 < route.length - 1.0:
            raise ConfigError(field=f"{name}.start", value=start, expected="a point on the leg")
        route = route.sub(s0, route.length, 1.0)
    er = ego_route(map, ego_move)
    gap = 0.5 * (body_spec("car").width + body_spec(kind).width)
    conflict = find_conflict(er, route, gap)
    if timed and kind == "cyclist" and conflict is not None:
        reach = _timed_reach(kind, conflict.s_ego)
        if conflict.s_ov > reach + 1.0:
            route = route.sub(conflict.s_ov - reach, route.length, 1.0)
            conflict = find_conflict(er, route, gap)
    return route, conflict, _kerb(map, route) if kind == "pedestrian" else 0.0


def _timed_reach(kind: str, s_ego: float) -> float:
    """How far from the conflict [m] a timed road user of ``kind`` may start: what it
    covers at the low end of its speeds, from standing, in the time an ego at
    :data:`EGO_NOMINAL_SPEED` (after :data:`EGO_RAMP`) takes to the conflict ``s_ego``
    metres along its route. So it starts once the ego runs at its speed (while the ego
    speeds up, its arrival time is overestimated) and needs no more than its own speed."""
    v = SPEEDS[kind].low
    a = body_spec(kind).a_max
    t_ego = s_ego / EGO_NOMINAL_SPEED + EGO_RAMP
    return max(0.0, v * (t_ego - v / (2.0 * a)))


def _kerb(map: JunctionMap, route: Path) -> float:  # noqa: A002
    """Arc length where a crosswalk route first enters the road [m] (its start if on it)."""
    area = map.drivable_area
    for x, y, s in zip(route.xs, route.ys, route.ss, strict=True):
        if area.contains(x, y):
            return s
    return 0.0


def _switch_distance(
    map: JunctionMap,  # noqa: A002
    plan: ActorPlan,
    ego_move: str,
    ego: Path,
    actor: Actor,
) -> float | None:
    """Where a timed car stops synchronising: the ego's distance to the conflict [m].

    The paper's switch (the map's table for the paper's car-car situations, else the
    ego's distance at its leg's mouth, capped): after it the car cruises at 15 km/h,
    about the speed it was synchronised at. Timed pedestrians and cyclists do not use the
    law (``PacedController``: with it they crept, and a switch before the conflict made
    them arrive early or late, issue 12's blind-ego check); for them this is 0.
    """
    if plan.kind != "car":
        return 0.0
    scen = Scenario(ego_move, plan.route, ego, actor.route, actor.conflict)
    return map.switch_distance(scen, table=True)


def own_speed(kind: str, seed: int, index: int) -> float | None:
    """The cruising speed [m/s] of a pedestrian or cyclist (the ``index``-th actor of the
    scene) in the run with ``seed``, drawn from ``_bodies.SPEEDS`` on its own random stream
    (adding it shifts no other draw); None for a car."""
    drawn = SPEEDS.get(kind)
    if drawn is None:
        return None
    seq = np.random.SeedSequence(seed, spawn_key=(SPEED_KEY, index))
    return drawn.draw(np.random.default_rng(seq))


def _controller(
    map: JunctionMap,  # noqa: A002
    plan: ActorPlan,
    actor: Actor,
    ego_move: str,
    ego: Path,
    adversary: AdversaryParams,
    own: float | None = None,
) -> Any:
    """The controller of an actor; ``own``: its drawn speed (:func:`own_speed`), which a
    ``speed`` in the situation overrides."""
    c = actor.conflict
    s_ego = c.s_ego if c else math.inf
    s_self = c.s_ov if c else math.inf
    params = dict(plan.params)
    speed = params.pop("speed", None)
    if speed is None:
        speed = own if own is not None else SCRIPTED_CAR_SPEED
    try:
        if plan.behaviour == "timed":
            drawn = SPEEDS.get(plan.kind)
            if drawn is not None:
                return PacedController(
                    s_ego, s_self, float(speed), drawn.low, drawn.high, adversary
                )
            return TimingController(
                with_switch_distance(adversary, _switch_distance(map, plan, ego_move, ego, actor)),
                s_ego,
                s_self,
            )
        if plan.behaviour in CROSSING_BEHAVIOURS:
            return CrossingController(
                plan.behaviour, s_ego, _kerb(map, actor.route), float(speed), **params
            )
        stop_at = None
        if plan.behaviour in ("stop", "stop-go"):
            stop_at = (s_self if c else 0.5 * actor.route.length) - actor.half_l - STOP_SHORT
        wait = params.pop("wait", 2.0) if plan.behaviour == "stop-go" else None
        return ScriptedController(float(speed), stop_at, wait, **params)
    except TypeError as exc:
        raise ConfigError(
            field=f"{plan.name}.behaviour",
            value=plan.params,
            expected=f"parameters of {plan.behaviour} ({exc})",
        ) from None


def _color(
    plan: ActorPlan, index: int, values: Mapping[str, Any], seed: int
) -> tuple[int, int, int]:
    if plan.name == "ov":
        return ov_color(values, seed)  # own random stream: shifts no other draw
    return PALETTE[draw_color(np.random.default_rng([OV_COLOR_KEY, seed, index]))][0]


def build_actors(
    map: JunctionMap,  # noqa: A002
    plan: ScenePlan,
    values: Mapping[str, Any],
    seed: int,
    adversary: AdversaryParams,
) -> tuple[Actor, list[Actor]]:
    """The ego and the other actors (primary OV first), at their spawns, with controllers."""
    car = body_spec("car")
    ov = plan.actors[0]
    if ov.kind == "car":
        scen = map.scenario(plan.ego, ov.route, car.width, car.width)
        er = scen.ego_route
    else:
        er = ego_route(map, plan.ego)
    ex, ey, eh = er.point_at(0.0)
    ego = Actor("ego", "car", car, make_body("car", ex, ey, eh), er)
    actors: list[Actor] = []
    queue: dict[str, int] = {}
    for index, p in enumerate(plan.actors):
        spec = body_spec(p.kind)
        kerb = 0.0
        if index == 0 and p.kind == "car":
            route, conflict = scen.ov_route, scen.conflict
            queue[p.route.partition("-")[0]] = 1
        else:
            start = _start(map, p, queue)
            timed = p.behaviour == "timed" and p.start is None
            route, conflict, kerb = _geometry(map, plan.ego, p.name, p.kind, p.route, start, timed)
        x, y, h = route.point_at(0.0)
        info = {"route": p.route, "behaviour": p.behaviour, "conflict_type": p.conflict_type}
        actor = Actor(
            p.name,
            p.kind,
            spec,
            make_body(p.kind, x, y, h),
            route,
            None,
            conflict,
            _color(p, index, values, seed),
            info,
        )
        own = own_speed(p.kind, seed, index)
        actor.controller = _controller(map, p, actor, plan.ego, er, adversary, own)
        actors.append(actor)
    watch(actors, ego)
    return ego, actors
