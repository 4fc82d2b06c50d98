"""The esmini backend: OpenSCENARIO files played by esmini, the stack under test driving the ego.

One run: the scenario's XML for the situation (a user's file with its parameters set, or
a situation of sitcov's hyperspace through the OpenSCENARIO exporter), esmini initialised
from it with the ego under an ``ExternalController``; every control period the stack gets
an observation (the PEM on esmini's object states, through the embedded backend's
``EgoDriver``, so delays, AEB latch and noise draws are the same code), its controls drive
sitcov's single-track vehicle (friction acts), the ego's new pose and speed are reported to
esmini, and esmini steps the storyboard and every other object by ``dt``. Facts for the
judge: collision (oriented-box overlap of the ego with any object), road departure (a
corner of the ego's box on no drivable lane, esmini's RoadManager), route completion.
The run ends at a collision, the goal, the storyboard's end, a standstill of
``stop_patience`` seconds, or ``sim_timeout``.
"""

from __future__ import annotations

import bisect
import math
import tempfile
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from sitcov.av._base import RunInfo
from sitcov.errors import ConfigError
from sitcov.sim._base import Backend, Outcome, Trace
from sitcov.sim._metrics import PET_ZONE, disc_radius, post_encroachment_time, time_to_collision
from sitcov.sim.embedded._collision import box_distance, contact_point, corners, overlap
from sitcov.sim.embedded._dynamics import Vehicle, default_params
from sitcov.sim.embedded._ego import EgoDriver
from sitcov.sim.embedded._monitors import GOAL_TOLERANCE, LANE_TOLERANCE, STOPPED_SPEED
from sitcov.sim.embedded._progress import (
    ARRIVAL_TIME,
    BLOCKED_TIME,
    PATH_AHEAD,
    PATH_MARGIN,
    STILL_SPEED,
    path_near,
)
from sitcov.sim.esmini._lib import library
from sitcov.sim.esmini._road import cropped_road
from sitcov.sim.esmini._scenario import (
    SCENARIO_ELEMENT,
    WEATHER_NAMES,
    ScenarioFile,
    scenario_files,
)
from sitcov.sim.esmini._session import RoadProbe, Session, kind_of, route_paths
from sitcov.weather._conditions import check_profile, conditions_from_values

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.hyperspace import Situation

#: Spacing of the ego's route points given to the stack [m].
ROUTE_SPACING = 1.0
#: Route length when the ego has no assigned route: its lane ahead [m].
DEFAULT_ROUTE_LENGTH = 200.0
#: The map of exported situations without ``road``: an embedded map on its own export.
DEFAULT_MAP = "t-junction"
#: ... and with ``road``: the CARLA map file placing them there.
DEFAULT_CARLA_MAP = "Town03"
#: The exported situations' car OV (``sitcov.sim.carla.situation_scenario``).
OV_ENTITY = "adversary"
#: How far along its route the OV's progress is followed [m].
OV_ROUTE_LENGTH = 400.0


class _Body:
    """A pose (what the sensor and the driver read of a body)."""

    __slots__ = ("x", "y", "yaw")

    def __init__(self) -> None:
        self.x = self.y = self.yaw = 0.0


class _Actor:
    """An esmini object as the ``EgoDriver`` sees an actor."""

    __slots__ = (
        "active",
        "body",
        "height",
        "kind",
        "length",
        "name",
        "oid",
        "rows",
        "speed",
        "width",
    )

    def __init__(self, oid: int, name: str, kind: str, length: float, width: float, height: float):
        self.oid, self.name, self.kind = oid, name, kind
        self.length, self.width, self.height = length, width, height
        self.body = _Body()
        self.speed = 0.0
        self.active = True
        self.rows: list[tuple[float, float, float, float, float]] = []

    def velocity(self) -> tuple[float, float]:
        """World-frame velocity [m/s] (esmini's speed along its heading)."""
        return self.speed * math.cos(self.body.yaw), self.speed * math.sin(self.body.yaw)

    def view(self) -> Any:
        from sitcov.perception._base import ActorView, Pose

        b = self.body
        return ActorView(
            Pose(b.x, b.y, b.yaw), self.length, self.width, self.height, self.speed, kind=self.kind
        )


class _Ego:
    __slots__ = ("body", "length", "width")

    def __init__(self, body: Vehicle, length: float, width: float) -> None:
        self.body, self.length, self.width = body, length, width


class _World:
    """What ``EgoDriver.command`` reads: the ego's body and speed, the other actors."""

    def __init__(self, ego: _Ego, actors: list[_Actor]) -> None:
        self.ego, self.actors = ego, actors
        self.ego_speed = 0.0


def _center(st: Any) -> tuple[float, float]:
    """The centre of an object's bounding box [m] from its reference point."""
    c, s = math.cos(st.h), math.sin(st.h)
    return st.x + c * st.centerOffsetX - s * st.centerOffsetY, st.y + s * st.centerOffsetX + (
        c * st.centerOffsetY
    )


class EsminiBackend(Backend):
    """OpenSCENARIO scenarios in esmini with the stack under test driving the ego.

    Args:
        scenario: a ``.xosc`` file whose parameters the hyperspace sets, or a folder of
            them (the ``scenario`` element picks one per run); None: every situation of
            sitcov's hyperspace is turned into a scenario by the OpenSCENARIO exporter
            (``sitcov.sim.carla.situation_scenario``) on ``map``.
        road: an OpenDRIVE file replacing the scenario's road; without ``scenario`` the
            file situations are placed on by the CARLA map file ``map`` (e.g. Town03).
        map: without ``scenario``: with ``road``, the CARLA map file placing situations on
            it (default Town03); without, an embedded map (default ``t-junction``) whose
            situations run on its own OpenDRIVE export (``_maps.py``, ``export-xodr``).
        ego: the entity the stack drives (default: see ``ScenarioFile``).
        dt: control period [s] (esmini is stepped by the same).
        sim_timeout: simulated time after which a run ends as a pass [s].
        stop_patience: a run ends as ``stopped`` after the ego stood this long [s].
        sensor_rate_hz: perception frame rate [Hz].
        sensor: the PEM-mode sensor (default ``PEMSensor()``).
        physics: ``carla`` or ``physical`` (mu; no crosswind force here).
        grey_box: give the stack the situation at reset.
        route_length: the ego's route when the scenario assigns none: its lane ahead [m].
        crop_road: give esmini only the part of ``road`` an exported situation's paths
            come near (``_road.cropped_road``: loads faster, the same lanes).
        perception: ``pem`` only (no camera frames: esmini is built headless here).
        object_noise: the object lists' noise and miss model for stacks that want
            ``objects`` (as the embedded backend's: None = ground truth, ``default``,
            or a YAML file).
    """

    name: ClassVar[str] = "esmini"

    def __init__(
        self,
        scenario: str | None = None,
        road: str | None = None,
        map: str | None = None,  # noqa: A002 - the documented option name
        ego: str | None = None,
        dt: float = 0.05,
        sim_timeout: float = 60.0,
        stop_patience: float = 10.0,
        sensor_rate_hz: float = 10.0,
        sensor: Any = None,
        physics: str = "carla",
        grey_box: bool = False,
        route_length: float = DEFAULT_ROUTE_LENGTH,
        crop_road: bool = True,
        perception: str = "pem",
        object_noise: Any = None,
    ) -> None:
        library()  # a missing esmini is one error before any run
        if perception != "pem":
            raise ConfigError(
                field="perception",
                value=perception,
                expected="pem: the esmini backend renders no camera frames (it gives the "
                "stack PEM detections or object lists); camera mode is the embedded backend's",
            )
        from sitcov.sim.embedded._backend import _object_noise

        self.object_noise = _object_noise(object_noise)
        self.physics = check_profile(physics)
        if not dt > 0 or not sim_timeout > 0 or not sensor_rate_hz > 0 or not stop_patience > 0:
            raise ConfigError(
                field="dt/sim_timeout/sensor_rate_hz/stop_patience",
                value=(dt, sim_timeout, sensor_rate_hz, stop_patience),
                expected="positive numbers",
            )
        self.dt, self.sim_timeout = float(dt), float(sim_timeout)
        self.stop_patience = float(stop_patience)
        self.sensor_every = max(1, round(1.0 / (sensor_rate_hz * self.dt)))
        self.sensor = sensor
        self.grey_box = bool(grey_box)
        self.route_length = float(route_length)
        self.crop_road = bool(crop_road)
        self.ego_name = ego
        self.road = Path(road).resolve() if road else None
        if self.road is not None and not self.road.is_file():
            raise ConfigError(file=str(road), field="road", expected="an OpenDRIVE (.xodr) file")
        self.files: dict[str, ScenarioFile] = {}
        self.jmap: Any = None  # the embedded map whose own export is the road
        #: the entities' driven paths of exported situations, per (ego, OV) movement
        self._paths: dict[tuple[str, str, bool], dict[str, list[tuple[float, float]]]] = {}
        self._run_paths: dict[str, list[tuple[float, float]]] = {}
        self.folder = False
        self.scenario = scenario
        if scenario is not None:
            path = Path(scenario)
            if path.is_dir():
                self.folder = True
                for name, file in scenario_files(path).items():
                    self.files[name] = ScenarioFile(file, ego)
            elif path.is_file():
                self.files[path.stem] = ScenarioFile(path, ego)
            else:
                raise ConfigError(
                    file=str(scenario), field="scenario", expected="a .xosc file or a folder"
                )
        else:
            from sitcov.sim.carla import available_maps, load_carla_map

            carla = {m.lower() for m in available_maps()}
            name = map or (DEFAULT_CARLA_MAP if self.road is not None else DEFAULT_MAP)
            if (
                self.road is not None
                or str(name).lower() in carla
                or str(name).endswith((".yaml", ".yml"))
                and Path(name).is_file()
                and _is_carla_map_file(Path(name))
            ):
                self.map = load_carla_map(name)
                if self.road is None:
                    raise ConfigError(
                        field="road",
                        value=None,
                        expected=f"an OpenDRIVE file of map {self.map.town!r} (--road "
                        "FILE.xodr): the exported scenarios are placed on it",
                    )
            else:  # an embedded map: its own OpenDRIVE export
                from sitcov.sim.embedded import load_map
                from sitcov.sim.esmini._maps import map_spec, own_road

                self.jmap = load_map(name)
                self.map = map_spec(self.jmap)
                self.road = own_road(str(name))

    # --- the hyperspace -----------------------------------------------------------------------

    def effects(self) -> dict[str, str]:
        """Every element this backend reads, and how."""
        weather = {
            name: "the scenario's Environment (where it has one) and the run's perception "
            "and friction, as in the embedded backend's carla profile"
            for name in WEATHER_NAMES
        }
        if not self.files:
            return {
                **weather,
                "intsit": "ego and OV routes on the map (OpenSCENARIO exporter)",
                **{f"actor{n}": "an extra road user (OpenSCENARIO exporter)" for n in range(2, 33)},
            }
        out = dict(weather)
        for file in self.files.values():
            for name in file.declarations:
                out.setdefault(name, f"ParameterDeclaration {name!r} of {file.path.name}")
        if self.folder:
            out[SCENARIO_ELEMENT] = "which scenario file of the folder is played"
        return out

    def check_hyperspace(self, hyperspace: Any) -> None:
        """Refuse elements a user's scenario does not declare (one line naming the file and
        the element); with a folder, the ``scenario`` element must name its files.

        Raises:
            ConfigError: an unknown element or scenario name.
        """
        if not self.files:
            return
        names = tuple(hyperspace.element_names)
        if not self.folder:
            next(iter(self.files.values())).check_names(names)
            return
        if SCENARIO_ELEMENT not in names:
            raise ConfigError(
                f"{self.scenario}: a folder of scenarios needs a hyperspace element "
                f"{SCENARIO_ELEMENT!r} whose bins name its files ({', '.join(self.files)})"
            )
        for label in hyperspace.labels(SCENARIO_ELEMENT):
            value = _bin_value(hyperspace, label)
            if str(value) not in self.files:
                raise ConfigError(
                    f"{self.scenario}: element {SCENARIO_ELEMENT!r} bin {label!r}: expected one "
                    f"of the folder's scenarios ({', '.join(self.files)}), got {value!r}"
                )
        declared = set(WEATHER_NAMES) | {SCENARIO_ELEMENT}
        for file in self.files.values():
            declared |= set(file.declarations)
        for name in names:
            if name not in declared:
                first = next(iter(self.files.values()))
                first.check_names([name], folder=True)  # raises, naming the file

    # --- one run ------------------------------------------------------------------------------

    def _scenario_xml(self, situation: Situation) -> tuple[str, str, dict[str, Any]]:
        """(XML, scenario name, parameters set) of a situation."""
        values = dict(situation.values)
        weather = {k: v for k, v in values.items() if k in WEATHER_NAMES}
        if not self.files:
            from sitcov.sim.carla import situation_scenario

            # a car OV gets no speed events: _play times it with the paper's law
            scenario = situation_scenario(situation, self._spec(situation), timed_ov=False)
            with tempfile.TemporaryDirectory(prefix="sitcov-esmini-") as tmp:
                path = Path(tmp) / f"{situation.id}.xosc"
                scenario.write_xml(str(path))
                file = ScenarioFile(path, self.ego_name)
                xml = file.render(values, road=self.road)
                intsit = values.get("intsit")
                ego_mv, ov_mv = str(intsit.get("ego")), str(intsit.get("ov"))  # type: ignore[union-attr]
                # the routes depend on the movements (and on whether the OV is a car)
                key = (ego_mv, ov_mv, self._ov_timing(situation) is not None)
                if key not in self._paths:
                    self._paths[key] = route_paths(
                        file.render(values, road=self.road, external=False),
                        (file.ego, OV_ENTITY),
                        ROUTE_SPACING,
                        max(self.route_length, OV_ROUTE_LENGTH),
                    )
                self._run_paths = self._paths[key]
                if self.crop_road:
                    points = [p for path in self._run_paths.values() for p in path]
                    xml = file.render(values, road=cropped_road(self.road, points))
            return xml, f"export:{situation.id}", {}
        if self.folder:
            name = str(values.get(SCENARIO_ELEMENT))
            if name not in self.files:
                raise ConfigError(
                    field=SCENARIO_ELEMENT, value=name, expected=f"one of {sorted(self.files)}"
                )
        else:
            name = next(iter(self.files))
        file = self.files[name]
        params = file.parameter_values(values)
        xml = file.render(values, road=self.road, weather=weather if file.has_environment else None)
        return xml, name, params

    def _conditions(self, situation: Situation, rng: np.random.Generator) -> tuple[Any, float]:
        values = dict(situation.values)
        if "friction" not in values and self.files:
            name = str(values.get(SCENARIO_ELEMENT)) if self.folder else next(iter(self.files))
            file = self.files.get(name)
            friction = file.environment_friction() if file is not None else None
            if friction is not None:
                values["friction"] = min(1.0, max(0.1, friction))
        wind_direction = float(rng.uniform(-math.pi, math.pi))
        weather = {k: v for k, v in values.items() if k in WEATHER_NAMES}
        cond = conditions_from_values(weather, wind_direction=wind_direction, profile=self.physics)
        return cond, wind_direction

    def observation_kind(self, stack: AVStack) -> str:
        """What this backend gives ``stack`` each frame: ``detections`` (the PEM on
        esmini's objects) or ``objects`` (object lists, ``perception/_objects.py``).

        Raises:
            ConfigError: the stack wants something that is no observation kind.
            SetupError: the stack wants camera images (one line, naming the stack).
        """
        from sitcov.av._base import OBSERVATION_KINDS
        from sitcov.errors import SetupError

        wants = getattr(stack, "wants", None)
        if wants is None:
            return "detections"
        if wants not in OBSERVATION_KINDS:
            raise ConfigError(field="wants", value=wants, expected=" | ".join(OBSERVATION_KINDS))
        if wants == "image":
            who = getattr(stack, "who", None) or f"stack {getattr(stack, 'name', '?')!r}"
            raise SetupError(
                f"{who} wants camera images, which the esmini backend cannot give (no camera "
                "rendering; it gives detections or objects): run it on the embedded backend "
                "with --perception camera"
            )
        return wants

    def _get_sensor(self) -> Any:
        if self.sensor is None:
            from sitcov.perception import PEMSensor

            self.sensor = PEMSensor()
        return self.sensor

    def run(
        self, situation: Situation, av_stack: AVStack, seed: int, *, record: bool = False
    ) -> Outcome:
        """Play ``situation`` in esmini with ``av_stack`` driving the ego (deterministic)."""
        seed = int(seed)
        rng = np.random.default_rng(seed)
        self._run_paths = {}
        xml, scenario_name, params = self._scenario_xml(situation)
        cond, wind_direction = self._conditions(situation, rng)
        paths = tuple(str(f.path.parent) for f in self.files.values())[:1]
        timing = self._ov_timing(situation)
        with Session(xml, seed, paths) as session:
            return self._play(
                session, situation, av_stack, seed, rng, cond, record,
                {"scenario": scenario_name, "parameters": params, "wind_direction": wind_direction},
                timing,
            )  # fmt: skip

    def _spec(self, situation: Situation) -> Any:
        """The map file placing ``situation`` (an embedded map's: with its conflict)."""
        if self.jmap is None:
            return self.map
        from sitcov.sim.esmini._maps import situation_spec

        return situation_spec(self.map, self.jmap, dict(situation.values))

    def _ov_timing(self, situation: Situation) -> tuple[tuple[float, float], float] | None:
        """(conflict point, switch distance) [m] of an exported situation's car OV in
        OpenDRIVE coordinates, or None (a user's scenario, or no car OV)."""
        if self.files:
            return None
        from sitcov.sim.carla import ov_timing

        found = ov_timing(situation, self._spec(situation))
        if found is None:
            return None
        (x, y), switch = found
        return (x, -y), switch  # CARLA's frame is OpenDRIVE's mirrored in y

    def _play(  # noqa: C901, PLR0912, PLR0913, PLR0915
        self, session, situation, stack, seed, rng, cond, record, info, timing=None
    ) -> Outcome:
        objects = session.objects()
        ego_name = self._ego_name(objects)
        ego_id = next(oid for oid, name in objects if name == ego_name)
        st = session.state(ego_id)
        ego_len, ego_wid = st.length, st.width
        cox, coy = st.centerOffsetX, st.centerOffsetY
        cx, cy = _center(st)
        vehicle = Vehicle(default_params(), cx, cy, st.h, max(0.0, st.speed))
        ego = _Ego(vehicle, ego_len, ego_wid)
        actors = []
        for oid, name in objects:
            if oid == ego_id:
                continue
            s = session.state(oid)
            actor = _Actor(oid, name, kind_of(s), s.length, s.width, s.height or 1.5)
            actors.append(actor)
        world = _World(ego, actors)
        self._read(session, actors)
        paths = self._run_paths
        if paths.get(ego_name):
            route = paths[ego_name][: int(self.route_length / ROUTE_SPACING) + 1]
        else:
            route = session.lane_points(ego_id, ROUTE_SPACING, self.route_length)
        if len(route) < 2:
            route = [(cx, cy), (cx + math.cos(st.h), cy + math.sin(st.h))]
        goal = route[-1]
        ov = None
        if timing is not None:
            ov = _TimedOV.start(
                session, actors, route, (ego_len, ego_wid), timing, paths.get(OV_ENTITY)
            )
        road_file = str(self.road) if self.road is not None else session.road_file()
        road = RoadProbe(road_file)
        stack.reset(
            RunInfo(
                dt=self.dt,
                route=tuple(route),
                goal=goal,
                map_name=Path(road_file).stem,
                camera=stack.camera,
                seed=seed,
                situation=situation if self.grey_box else None,
            )
        )
        kind = self.observation_kind(stack)
        sensor = None if kind == "objects" else self._get_sensor()  # objects: no PEM
        if hasattr(sensor, "reset"):
            sensor.reset(frame_dt=self.sensor_every * self.dt)
        driver = EgoDriver(self, stack, sensor, cond, rng, seed, 0, 0, 0.0, kind)
        dt, mu = self.dt, cond.mu
        n_max = int(math.ceil(self.sim_timeout / dt - 1e-9))
        hl, hw = 0.5 * ego_len, 0.5 * ego_wid
        radius_e = disc_radius(ego_len, ego_wid)
        min_distance: float | None = None
        min_ttc: float | None = None
        hit: _Actor | None = None
        collision_speed: float | None = None
        max_drac: float | None = None  # docs/metrics.md
        contact: tuple[tuple[float, float], float] = ((0.0, 0.0), 0.0)  # point, ego heading
        road_departure: float | None = None
        lane_departure: float | None = None
        lanes = _LaneTest(route, road.lane_widths(route), ego_wid)
        idx = start = _advance(route, 0, cx, cy)  # the point the ego starts at
        still = 0.0
        arc = _arc_lengths(route)
        xs, ys = [p[0] for p in route], [p[1] for p in route]
        standing_clear = 0.0  # how long the ego has stood with its path clear [s]
        blocked: float | None = None
        ego_rows: list[tuple[float, float, float, float, float]] = []
        reason = "sim_timeout"
        k, t = 0, 0.0
        while True:
            if record:
                ego_rows.append((t, vehicle.x, vehicle.y, vehicle.yaw, vehicle.speed))
                for a in actors:
                    if a.active:
                        b = a.body
                        a.rows.append((t, b.x, b.y, b.yaw, a.speed))
            world.ego_speed = vehicle.speed
            throttle, brake, steer = driver.command(world, k, t)
            vehicle.step(throttle, brake, steer, mu, 0.0, dt)
            c, s = math.cos(vehicle.yaw), math.sin(vehicle.yaw)
            session.report(
                ego_id, vehicle.x - c * cox + s * coy, vehicle.y - s * cox - c * coy,
                vehicle.yaw, vehicle.speed,
            )  # fmt: skip
            if ov is not None:
                ov.step(session, t, vehicle, mu, dt)
            session.step(dt)
            k += 1
            t = k * dt
            self._read(session, actors)
            if ov is not None:
                ov.observe(t, vehicle)
            ebox = (vehicle.x, vehicle.y, vehicle.yaw, hl, hw)
            evx, evy = vehicle.vx * c - vehicle.vy * s, vehicle.vx * s + vehicle.vy * c
            for a in actors:
                if not a.active:
                    continue
                b = a.body
                abox = (b.x, b.y, b.yaw, 0.5 * a.length, 0.5 * a.width)
                d = box_distance(ebox, abox)
                if min_distance is None or d < min_distance:
                    min_distance = d
                avx, avy = a.speed * math.cos(b.yaw), a.speed * math.sin(b.yaw)
                ttc = time_to_collision(
                    b.x - vehicle.x, b.y - vehicle.y, avx - evx, avy - evy,
                    radius_e + disc_radius(a.length, a.width),
                )  # fmt: skip
                if ttc is not None and (min_ttc is None or ttc < min_ttc):
                    min_ttc = ttc
                if ttc is not None and ttc > 0.0:
                    drac = math.hypot(avx - evx, avy - evy) / (2.0 * ttc)
                    max_drac = drac if max_drac is None or drac > max_drac else max_drac
                if hit is None and overlap(ebox, abox):
                    hit = a
                    collision_speed = math.hypot(avx - evx, avy - evy)
                    contact = (contact_point(ebox, abox), vehicle.yaw)
            if road_departure is None and road.off_road(corners(ebox), vehicle.yaw):
                road_departure = t
            idx = _advance(route, idx, vehicle.x, vehicle.y)
            if lane_departure is None and lanes.left(idx, vehicle.x, vehicle.y):
                lane_departure = t
            still = still + dt if vehicle.speed < STOPPED_SPEED else 0.0
            if (
                vehicle.speed < STILL_SPEED
                and not _path_taken(actors, xs, ys, arc, idx, hl, hw)
                and not (ov is not None and ov.due())
            ):
                standing_clear += dt
                if blocked is None and standing_clear >= BLOCKED_TIME - 1e-9:
                    blocked = t
            else:
                standing_clear = 0.0
            if hit is not None:
                reason = "collision"
                break
            if math.dist((vehicle.x, vehicle.y), goal) <= GOAL_TOLERANCE:
                reason = "goal"
                break
            if session.ended():
                reason = "scenario_end"
                break
            if still >= self.stop_patience and blocked is not None:
                reason = "stopped"  # the verdict is known: blocked (docs/esmini.md)
                break
            if k >= n_max:
                break
        length = _length(route[start:])
        progress = _length(route[start : idx + 1])
        collided = hit is not None
        metrics = {
            "steps": k,
            "mu": mu,
            "physics": self.physics,
            **info,
            "road": Path(road_file).name,
            "road_departure_time": road_departure,
            "lane_departure_time": lane_departure,
            "route_length": round(length, 6),
            "route_completion": (
                1.0
                if reason == "goal"
                else (round(min(1.0, progress / length), 6) if length > 0 else None)
            ),
            "time_to_goal": round(t, 10) if reason == "goal" else None,
            "blocked_time": blocked,
            "route_incomplete_time": round(t, 10) if reason == "sim_timeout" else None,
            "ego_stationary": (vehicle.speed < STILL_SPEED) if hit else None,
            "collision_actor": hit.name if hit else None,
            "collision_kind": hit.kind if hit else None,
            "collision_point": list(contact[0]) if hit else None,
            "collision_heading": contact[1] if hit else None,
            "ego_collision_speed": vehicle.speed if hit else None,
            "max_drac": max_drac,
            "ego_final_speed": vehicle.speed,
        }
        if ov is not None:
            metrics["ov_timing"] = "timing law (closed loop, sitcov)"
            metrics["ov_switch_time"] = ov.driver.released_at
            metrics["ov_conflict"] = [round(v, 6) for v in ov.conflict]
        trace = None
        if record:
            trace = self._trace(ego_rows, actors, route, ego_len, ego_wid, road_file)
        return Outcome(
            status="fail" if collided else "pass",
            end_reason=reason,
            sim_time=round(t, 10),
            collision=collided,
            collision_time=round(t, 10) if collided else None,
            collision_speed=collision_speed,
            min_distance=min_distance,
            min_ttc=min_ttc,
            pet=None if ov is None else ov.pet(hit is ov.actor),
            aeb_fired=driver.aeb_time is not None,
            aeb_time=driver.aeb_time,
            metrics=metrics,
            trace=trace,
        )

    def _ego_name(self, objects: list[tuple[int, str]]) -> str:
        names = [n for _, n in objects]
        if self.files:
            file = next(iter(self.files.values()))
            if file.ego in names:
                return file.ego
        for name in names:
            if name.lower() in ("hero", "ego"):
                return name
        return names[0]

    @staticmethod
    def _read(session: Session, actors: list[_Actor]) -> None:
        for a in actors:
            st = session.state(a.oid)
            b = a.body
            b.x, b.y = _center(st)
            b.yaw = st.h
            a.speed = st.speed
            a.active = bool(st.visibilityMask & 2) or st.visibilityMask == 0

    def _trace(self, ego_rows, actors, route, length, width, road_file) -> Trace:
        ov = actors[0].rows if actors else []
        return Trace(
            ego=ego_rows,
            ov=ov,
            meta={
                "map": road_file,
                "ego_route": [list(p) for p in route],
                "length": length,
                "width": width,
                "dt": self.dt,
                "actors": {
                    a.name: {"kind": a.kind, "length": a.length, "width": a.width} for a in actors
                },
            },
            actors={a.name: a.rows for a in actors},
        )


class _TimedOV:
    """The exported situation's car OV timed by the paper's law in closed loop.

    esmini's default controller keeps moving the OV along its assigned route (lanes and
    junction of the road file); its speed is sitcov's: every step the shared adversary
    (``sitcov.sim.carla.OVDriver``, the CARLA backend's: the timing law on the remaining
    distances along both routes to the conflict point, then the cruise once the ego is
    within the switch distance; past its goal it cruises on, where the embedded world
    removes it) gives throttle and brake, a car body of the embedded
    world (``Vehicle``, the same longitudinal dynamics and friction, steering 0: esmini
    does the lateral part) turns them into a speed, and ``SE_ReportObjectSpeed`` hands it
    to esmini before it steps.
    """

    def __init__(
        self,
        actor: _Actor,
        driver: Any,
        body: Vehicle,
        conflict: tuple[float, float],
        zone: tuple[float, float, float, float] | None = None,
        ego_half_length: float = 0.0,
    ) -> None:
        self.actor, self.driver, self.body = actor, driver, body
        #: the point the arrivals are timed at (on the ego's route) [m]
        self.conflict = conflict
        #: the conflict zone on each route [m]: ego start, end, OV start, end (the
        #: embedded world's PET zone: the overlap, at most ``PET_ZONE`` long)
        self.zone = zone
        self.halves = (ego_half_length, 0.5 * actor.length)
        self.times: list[float | None] = [None, None, None, None]  # entries and exits
        #: the ego's and the OV's arc lengths on their routes at the last observation [m]
        self.s_now: tuple[float, float] | None = None

    def observe(self, t: float, ego: Vehicle) -> None:
        """After a step: when the ego and the OV entered and left the conflict zone (the
        front reaches its start, the rear passes its end, as ``PETMonitor``)."""
        d, z, times = self.driver, self.zone, self.times
        if z is None:
            return
        b = self.actor.body
        now = []
        for k, progress, xy, half in (
            (0, d.ego, (ego.x, ego.y), self.halves[0]),
            (2, d.ov, (b.x, b.y), self.halves[1]),
        ):
            s = progress.s[progress.update(*xy)]
            now.append(s)
            if times[k] is None and s + half >= z[k]:
                times[k] = t
            if times[k + 1] is None and s - half > z[k + 1]:
                times[k + 1] = t

        self.s_now = (now[0], now[1])

    def due(self) -> bool:
        """Whether the OV holds the ego at the conflict zone, as the embedded world's path
        test (b) says (``path_occupied``): neither has left the zone, its start lies within
        ``PATH_AHEAD`` of the ego's front, and the OV is in it or moving and due there
        within ``ARRIVAL_TIME``. False before the first :meth:`observe` or without a zone."""
        z, now = self.zone, self.s_now
        if z is None or now is None:
            return False
        (s_ego, s_ov), (half_e, half_o) = now, self.halves
        if z[0] - (s_ego + half_e) > PATH_AHEAD or s_ego - half_e > z[1] or s_ov - half_o > z[3]:
            return False
        ahead = z[2] - (s_ov + half_o)
        speed = self.actor.speed
        return ahead <= 0.0 or (speed >= STILL_SPEED and ahead <= speed * ARRIVAL_TIME)

    def pet(self, collided: bool) -> float | None:
        """Post-encroachment time at the conflict zone [s] (0 after a collision with the
        OV, None if one of them never entered it or there is no zone)."""
        if self.zone is None:
            return None
        t = self.times
        return post_encroachment_time((t[0], t[1]), (t[2], t[3]), collided)

    @classmethod
    def start(
        cls,
        session: Session,
        actors: list[_Actor],
        ego_route: list[tuple[float, float]],
        ego_size: tuple[float, float],
        timing: tuple[tuple[float, float], float],
        path: list[tuple[float, float]] | None = None,
    ) -> _TimedOV | None:
        from sitcov.sim.carla._ovdriver import OVDriver
        from sitcov.sim.embedded._map import route_conflict
        from sitcov.sim.embedded._path import Path as Polyline

        ego_length, ego_width = ego_size
        actor = next((a for a in actors if a.name == OV_ENTITY), None)
        if actor is None:
            return None
        conflict, switch = timing
        route = path or session.lane_points(actor.oid, ROUTE_SPACING, OV_ROUTE_LENGTH)
        if len(route) < 2 or len(ego_route) < 2:
            return None
        # the embedded world's conflict: where the two swept paths (box widths) first
        # overlap, on the routes esmini drives; the map's point only without an overlap
        found = route_conflict(
            Polyline(*zip(*ego_route, strict=True)),
            Polyline(*zip(*route, strict=True)),
            0.5 * (ego_width + actor.width),
        )
        targets = zone = None
        if found is not None:
            conflict, targets = found.point, (found.s_ego, found.s_ov)
            zone = (
                found.s_ego,
                min(found.s_ego_end, found.s_ego + PET_ZONE),
                found.s_ov,
                min(found.s_ov_end, found.s_ov + PET_ZONE),
            )
        driver = OVDriver(ego_route, route, conflict, switch_distance=switch, targets=targets)
        b = actor.body
        body = Vehicle(default_params(), b.x, b.y, b.yaw, 0.0)
        point = (float(conflict[0]), float(conflict[1]))
        return cls(actor, driver, body, point, zone, 0.5 * ego_length)

    def step(self, session: Session, t: float, ego: Vehicle, mu: float, dt: float) -> None:
        """Set the OV's speed for the coming step from the law."""
        a, body = self.actor, self.body
        b = a.body
        d = self.driver  # its longitudinal part: past its goal the OV drives on, as it
        d.ego.update(ego.x, ego.y)  # leaves the embedded world at its route's end
        d.ov.update(b.x, b.y)
        law = d.controller
        thr, brk = law.command(d.ego.remaining(), ego.speed, d.ov.remaining(), body.speed)
        if d.released_at is None and law.phase == "cruise":
            d.released_at = t
        body.step(thr, brk, 0.0, mu, 0.0, dt)
        session.report_speed(a.oid, body.speed)


def _is_carla_map_file(path: Path) -> bool:
    """A YAML file with CARLA map file fields (``town``), not an embedded map."""
    import yaml

    try:
        data = yaml.safe_load(path.read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError):
        return False
    return isinstance(data, dict) and "town" in data


class _LaneTest:
    """The embedded world's lane-departure test (``LaneDepartureMonitor``) on the ego's
    route: the ego's centre is more than ``(lane width - ego width) / 2 + LANE_TOLERANCE``
    from the route at its tracked point, the lane width from esmini's RoadManager at that
    route point (no test where it finds no lane)."""

    def __init__(self, route: list[tuple[float, float]], widths: list[float], ego_width: float):
        n = len(route)
        self.route = route
        self.trig = []
        for i in range(n):
            (x0, y0), (x1, y1) = route[max(0, min(i, n - 2))], route[max(1, min(i + 1, n - 1))]
            h = math.atan2(y1 - y0, x1 - x0)
            self.trig.append((math.sin(h), math.cos(h)))
        self.limits = [0.5 * (w - ego_width) + LANE_TOLERANCE for w in widths]

    def left(self, i: int, x: float, y: float) -> bool:
        """Whether the ego at (x, y), tracked at route point ``i``, is out of its lane."""
        limit = self.limits[i]
        if limit != limit:  # NaN: no lane found there
            return False
        (px, py), (sn, cs) = self.route[i], self.trig[i]
        lat = -(x - px) * sn + (y - py) * cs
        return lat > limit or -lat > limit


def _bin_value(hyperspace: Any, label: str) -> Any:
    for element in hyperspace.to_dict().get("axes", []):
        for el in element.get("elements", []):
            if el.get("name") != SCENARIO_ELEMENT:
                continue
            for b in el.get("bins", []):
                if str(b.get("label", b.get("value"))) == label:
                    return b.get("value", label)
    return label


def _arc_lengths(points: list[tuple[float, float]]) -> list[float]:
    """Arc length [m] at every point of a route, from its first point."""
    out = [0.0]
    for a, b in zip(points, points[1:], strict=False):
        out.append(out[-1] + math.dist(a, b))
    return out


def _path_taken(
    actors: list[Any], xs: list[float], ys: list[float], arc: list[float], idx: int,
    half_l: float, half_w: float,
) -> bool:  # fmt: skip
    """Whether a road user's box comes within the ego's half width plus ``PATH_MARGIN`` of
    the ego's route over the ``PATH_AHEAD`` metres ahead of its front (the embedded
    world's path test (a); its conflict-zone test (b) needs zones esmini's own
    storyboard actors do not have)."""
    front = arc[idx] + half_l
    end = min(bisect.bisect_left(arc, front + PATH_AHEAD) + 1, len(xs))
    reach = half_w + PATH_MARGIN
    for a in actors:
        if not a.active:
            continue
        b = a.body
        c, s = math.cos(b.yaw), math.sin(b.yaw)
        if path_near((xs, ys), idx, end, b.x, b.y, c, s, 0.5 * a.length, 0.5 * a.width, reach):
            return True
    return False


def _length(points: list[tuple[float, float]]) -> float:
    return sum(math.dist(a, b) for a, b in zip(points, points[1:], strict=False))


def _advance(route: list[tuple[float, float]], idx: int, x: float, y: float) -> int:
    """The route index moved forward while the next point is nearer to (x, y)."""
    n = len(route)
    while idx + 1 < n and math.dist(route[idx + 1], (x, y)) <= math.dist(route[idx], (x, y)):
        idx += 1
    return idx
