"""The CARLA backend: one situation per run on a real CARLA server (synchronous, 0.05 s).

Per run: connect (the client is cached), load the town if needed, switch the world to
synchronous mode with a fixed step (the original settings are restored afterwards), set the
weather from the situation, spawn ego and OV at the map file's points and every further
road user of the situation (pedestrians, cyclists, extra cars: ``_actors``), scale every wheel's
tyre friction and read it back, attach the ego's RGB camera (the stack's CameraSpec) and a
collision sensor, then step: the stack gets camera frames in ``Observation.image`` and runs
its own detector, the OV follows the adversary's timing law. Every actor and sensor is
destroyed in ``finally``. Server time-outs or disconnects: reconnect and retry once, then an
``error`` outcome. With a launch command (``--carla-launch``), a server that does not
answer is started again with it, and the backend waits (at most ``launch_timeout`` s) until
it accepts connections before going on. Only the members listed in ``_surface.SURFACE``
are used.
"""

from __future__ import annotations

import contextlib
import math
import shlex
import subprocess
import time
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from sitcov.av._base import RunInfo
from sitcov.errors import BackendUnavailableError, ConfigError, MissingExtraError, SetupError
from sitcov.perception._colors import ov_color
from sitcov.sim._base import Backend, Outcome
from sitcov.sim.carla._actors import (
    Scene,
    ScenePlanned,
    Twin,
    check_blueprints,
    conflict_point,
    plan_scene,
    spawn_twins,
)
from sitcov.sim.carla._episode import Episode, EpisodeSettings, StackFailure
from sitcov.sim.carla._geometry import carla_transform, plan_route
from sitcov.sim.carla._mapfile import CarlaMap, SpawnPoint, load_carla_map
from sitcov.sim.carla._metrics import MetricTracker
from sitcov.sim.carla._ovdriver import OVDriver
from sitcov.sim.embedded._backend import MAX_ACTOR_SLOT
from sitcov.weather._conditions import WEATHER_ELEMENTS, check_profile, conditions_from_values

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.hyperspace import Situation

#: Fixed simulation step [s] (the paper's controllers assume 0.05 s).
DT = 0.05
#: Simulated time limit of a run [s].
SIM_TIMEOUT = 60.0
#: Rate at which camera frames are handed to the stack [Hz] (the embedded camera mode's).
CAMERA_RATE_HZ = 10.0
#: Relative tolerance of the tyre-friction read-back.
FRICTION_RTOL = 1e-3
FRICTION_MODES = ("wheels", "trigger", "both")
#: Default wait for a server started by ``--carla-launch`` [s] (CARLA takes 10-60 s).
LAUNCH_TIMEOUT = 120.0
#: Pause between connection attempts while a launched server starts [s].
LAUNCH_POLL = 1.0


def _check_wants(stack: AVStack) -> None:
    """The carla backend gives camera images only: a stack that wants detections or objects
    (``AVStack.wants``) stops the campaign with one line instead of getting none."""
    wants = getattr(stack, "wants", None)
    if wants not in (None, "image"):
        who = getattr(stack, "who", None) or f"stack {getattr(stack, 'name', '?')!r}"
        raise SetupError(
            f"{who} wants {wants}, which the carla backend does not give (it gives camera "
            "images): run it with --backend embedded (pem or camera perception)"
        )


@dataclass(frozen=True)
class _RunPlan:
    """What one run needs before spawning: movements, spawns, lane routes (CARLA frame),
    the scene's further road users and the car OV's conflict point."""

    ego_move: str
    ov_move: str
    scene: ScenePlanned | None
    ego_spawn: SpawnPoint
    ego_goal: tuple[float, float]
    ego_route: list[tuple[float, float]]
    ov_spawn: SpawnPoint | None
    ov_route: list[tuple[float, float]]
    conflict: tuple[float, float] | None

    @property
    def car_ov(self) -> bool:
        """The OV is a car (the paper's OV driver drives it)."""
        return self.ov_spawn is not None


@dataclass(frozen=True)
class _Spawned:
    """The world, its blueprint library and the actors spawned for one run."""

    world: Any
    library: Any
    ego: Any
    ov: Any
    twins: list[Twin]


class CarlaBackend(Backend):
    """Runs situations on a CARLA server (0.9.15/0.9.16).

    Args:
        host, port: the server (ignored when ``servers`` is given).
        timeout: client time-out [s] for connecting and for every server call.
        map: a shipped map file name (``Town03``) or a map YAML path.
        servers: ``[(host, port), ...]`` or ``["host:port", ...]``; this backend uses
            ``servers[worker_index % len(servers)]`` (scale-out: one server per worker).
        worker_index: index of the worker process that owns this backend.
        friction_mode: ``wheels`` (scale every wheel's tire_friction of both vehicles),
            ``trigger`` (a static.trigger.friction box over the junction) or ``both``.
        camera_rate_hz: frames per second handed to the stack.
        sun_altitude: sun altitude [deg] (the paper never varied the sun).
        physics: ``carla`` (default: the wheels' tyre friction is scaled by the friction
            element alone; weather is rendering only) or ``physical`` (the wet-road mu of
            ``sitcov.sim.conditions_from_values`` reaches the wheels; the crosswind force
            is NOT applied: CARLA's weather wind moves no vehicle). See docs/carla.md.
        connect: connect now (fail fast without a server) rather than at the first run.
        launch: a shell command that starts the server (``--carla-launch``); ``{host}`` and
            ``{port}`` are replaced by this backend's server. When no server answers (at the
            first connection, or after one died mid-campaign) it is run and the backend
            waits for the server; the command must free the port of a hung server itself.
        launch_timeout: seconds to wait for a launched server to accept connections.
        carla_module: the module providing the client API (tests pass a fake).
    """

    name: ClassVar[str] = "carla"

    def __init__(
        self,
        host: str = "localhost",
        port: int = 2000,
        timeout: float = 10.0,
        map: str = "Town03",  # noqa: A002 - the CLI's name
        servers: list[Any] | str | None = None,
        worker_index: int = 0,
        *,
        dt: float = DT,
        sim_timeout: float = SIM_TIMEOUT,
        friction_mode: str = "wheels",
        camera_rate_hz: float = CAMERA_RATE_HZ,
        sun_altitude: float = 45.0,
        physics: str = "carla",
        connect: bool = True,
        launch: str | None = None,
        launch_timeout: float = LAUNCH_TIMEOUT,
        carla_module: Any = None,
    ) -> None:
        from sitcov.sim.carla._options import parse_servers

        if servers:
            chosen = parse_servers(servers)
            host, port = chosen[int(worker_index) % len(chosen)]
        if friction_mode not in FRICTION_MODES:
            raise ConfigError(
                field="friction_mode", value=friction_mode, expected=" | ".join(FRICTION_MODES)
            )
        if not (timeout > 0):
            raise ConfigError(field="carla_timeout", value=timeout, expected="seconds > 0")
        self.host, self.port, self.timeout = str(host), int(port), float(timeout)
        self.map: CarlaMap = load_carla_map(map)
        self.dt, self.sim_timeout = float(dt), float(sim_timeout)
        self.friction_mode = friction_mode
        self.physics = check_profile(physics)
        self.camera_every = max(1, round(1.0 / (camera_rate_hz * self.dt)))
        self.sun_altitude = float(sun_altitude)
        self.launch = _launch_command(launch, self.host, self.port)
        if not (launch_timeout > 0):
            raise ConfigError(field="carla_launch_timeout", value=launch_timeout, expected="> 0")
        self.launch_timeout = float(launch_timeout)
        self.launches = 0  # servers started by this backend
        self._server_process: subprocess.Popen | None = None
        self._carla = carla_module if carla_module is not None else _import_carla()
        self._client: Any = None
        self._world: Any = None
        self._cmap: Any = None
        self._routes: dict[tuple, list[tuple[float, float]]] = {}
        self._versions: dict[str, str] = {}
        if connect:
            self._connect()

    # -- connection ------------------------------------------------------------------------

    def _connect(self) -> None:
        try:
            self._connect_once()
        except BackendUnavailableError:
            if self.launch is None:
                raise
            self._relaunch()

    def _connect_once(self) -> None:
        carla = self._carla
        client = carla.Client(host=self.host, port=self.port)
        client.set_timeout(self.timeout)
        try:
            server = client.get_server_version()
        except RuntimeError:
            raise BackendUnavailableError(
                f"no CARLA server at {self.host}:{self.port} after {self.timeout:g}s: "
                "start CarlaUE4.sh or pass --carla-host/--carla-port"
            ) from None
        self._versions = {"server": str(server), "client": str(client.get_client_version())}
        self._client, self._world, self._cmap = client, None, None

    def _relaunch(self) -> None:
        """Start the server with the launch command and wait until it accepts connections.

        Raises:
            BackendUnavailableError: the command exited with an error, or no server answered
                within ``launch_timeout`` seconds.
        """
        assert self.launch is not None
        self.launches += 1
        self._server_process = subprocess.Popen(  # noqa: S603 - the user's own command
            self.launch,
            shell=True,  # noqa: S602 - a command line such as "CarlaUE4.sh -RenderOffScreen"
            start_new_session=True,  # the server outlives this worker's signals
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        deadline = time.monotonic() + self.launch_timeout
        while True:
            try:
                self._connect_once()
                return
            except BackendUnavailableError:
                code = self._server_process.poll()
                if code not in (None, 0):
                    raise BackendUnavailableError(
                        f"--carla-launch {shlex.quote(self.launch)} exited with status {code}"
                    ) from None
                if time.monotonic() >= deadline:
                    raise BackendUnavailableError(
                        f"no CARLA server at {self.host}:{self.port} within "
                        f"{self.launch_timeout:g}s of running --carla-launch "
                        f"{shlex.quote(self.launch)}"
                    ) from None
                time.sleep(min(LAUNCH_POLL, max(0.0, deadline - time.monotonic())))

    def _ensure_world(self) -> tuple[Any, Any]:
        if self._client is None:
            self._connect()
        if self._world is None:
            world = self._client.get_world()
            cmap = world.get_map()
            if cmap.name.rsplit("/", 1)[-1] != self.map.town:
                world = self._client.load_world(self.map.town)
                cmap = world.get_map()
            self._world, self._cmap = world, cmap
            self._routes.clear()
        return self._world, self._cmap

    def check(self) -> dict[str, str]:
        """Smoke test without running a situation: versions, town, and every route.

        Plans the route of every spawn entry to every other leg's goal on the server's lane
        graph (a ConfigError names the first one that cannot be planned), and looks up the
        map file's walker and bicycle blueprints in the server's library.
        """
        world, cmap = self._ensure_world()
        lengths = []
        for table in (self.map.ego_spawns, self.map.ov_spawns):
            for key, spawn in table.items():
                start = key.split("-")[0]
                ends = [key.split("-")[1]] if "-" in key else self.map.legs
                for leg in ends:
                    if leg != start:
                        route = self._route(cmap, spawn, self.map.goals[leg])
                        lengths.append(len(route))
        report = {
            "server": f"{self.host}:{self.port}",
            "carla_server": self._versions.get("server", "?"),
            "carla_client": self._versions.get("client", "?"),
            "town": cmap.name,
            "map_file": self.map.name,
            "routes": f"{len(lengths)} planned, {min(lengths)}-{max(lengths)} points",
            "road_users": check_blueprints(world.get_blueprint_library(), self.map),
        }
        if report["carla_server"] != report["carla_client"]:
            report["warning"] = "client and server versions differ: install the matching wheel"
        return report

    def close(self) -> None:
        """Drop the connection (the server keeps running)."""
        self._client = self._world = self._cmap = None

    def check_hyperspace(self, hyperspace: Any) -> None:
        """The extra road users' values (``actorN``) against the embedded map whose routes
        they follow (as :func:`plan_scene` reads them in every run); ``intsit`` routes are
        CARLA's own spawns and goals, checked when the server is reached."""
        from sitcov.sim.embedded._map import load_map
        from sitcov.sim.embedded._scene import check_scene_values

        check_scene_values(load_map(self.map.embedded_map), hyperspace, intsit=False)

    def effects(self) -> dict[str, str]:
        """What each element does in CARLA."""
        out = {
            name: f"carla.WeatherParameters.{name} (rendering: reaches the stack via the camera)"
            for name in WEATHER_ELEMENTS
        }
        if getattr(self, "physics", "carla") == "physical":
            out["friction"] = (
                "scales every wheel's tire_friction of ego and OV by the physical profile's "
                "wet-road mu (sitcov.sim.conditions_from_values), read back after applying"
            )
            for name in ("wetness", "precipitation", "precipitation_deposits"):
                out[name] += "; lowers the wheels' tire_friction (wet-road mu)"
            out["wind_intensity"] += "; no side force (CARLA's wind moves no vehicle)"
        else:
            out["friction"] = (
                "scales every wheel's tire_friction of ego and OV by the friction element, "
                "read back after applying"
            )
        out["intsit"] = (
            "ego/OV spawn points, routes and conflict point from the map file; a pedestrian "
            "or cyclist OV (kind) as the actorN slots"
        )
        slot = (
            "walker.pedestrian.* (carla.WalkerControl) or two-wheeled vehicle.* "
            "(carla.VehicleControl) on the map file's embedded_map routes, driven by the "
            "embedded controllers"
        )
        out.update({f"actor{n}": slot for n in range(2, MAX_ACTOR_SLOT + 1)})
        return out

    # -- runs ------------------------------------------------------------------------------

    def run(
        self, situation: Situation, av_stack: AVStack, seed: int, *, record: bool = False
    ) -> Outcome:
        """Run one situation; retry once after a server failure, then an ``error`` outcome.

        Raises:
            BackendUnavailableError: no server could be reached for the first connection.
            Exception: whatever the AV stack raised (after cleaning up the world).
        """
        last: Exception | None = None
        for attempt in (1, 2):
            try:
                outcome = self._run_once(situation, av_stack, seed, record)
            except StackFailure as exc:
                raise exc.__cause__ from None  # type: ignore[misc]
            except RuntimeError as exc:  # carla's time-outs and disconnects
                last = exc
                if attempt == 2:
                    break
                self.close()
                try:
                    self._ensure_world()
                except (BackendUnavailableError, RuntimeError) as again:
                    last = again
                    break
            else:
                outcome.metrics["attempts"] = attempt
                return outcome
        return Outcome.errored(f"CARLA server failed twice (reconnected once): {last}")

    def _intsit(self, situation: Situation) -> tuple[str, str, str]:
        value = situation.value("intsit")
        if not isinstance(value, Mapping) or not {"ego", "ov"} <= set(value):
            raise ConfigError(
                field="intsit", value=value, expected="a mapping with ego, ov and conflict"
            )
        kind = str(value.get("kind", "car"))
        if kind == "car" and "conflict" not in value:
            raise ConfigError(
                field="intsit.conflict", value=value, expected="a conflict point of the map file"
            )
        return str(value["ego"]), str(value["ov"]), str(value.get("conflict", ""))

    def _route(self, cmap: Any, spawn: SpawnPoint, goal: tuple[float, float]) -> list:
        key = (spawn.x, spawn.y, goal)
        if key not in self._routes:
            start = self._carla.Location(x=spawn.x, y=spawn.y, z=spawn.z)
            self._routes[key] = plan_route(cmap, start, goal, tolerance=self.map.goal_tolerance)
        return self._routes[key]

    def _transform(self, x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> Any:
        return carla_transform(self._carla, x, y, z, yaw)

    def _episode_settings(self) -> EpisodeSettings:
        """What the step loop needs of this backend (it holds no reference to it)."""
        return EpisodeSettings(
            carla=self._carla,
            carla_map=self._cmap,
            map_name=self.map.name,
            goal_tolerance=self.map.goal_tolerance,
            dt=self.dt,
            timeout=self.timeout,
            sim_timeout=self.sim_timeout,
            camera_every=self.camera_every,
        )

    def _weather(self, values: Mapping[str, Any]) -> tuple[Any, dict[str, float]]:
        params = {name: float(values.get(name, 0.0)) for name in WEATHER_ELEMENTS}
        params["sun_altitude_angle"] = self.sun_altitude
        return self._carla.WeatherParameters(**params), params

    def _run_once(self, situation: Situation, stack: AVStack, seed: int, record: bool) -> Outcome:
        world, cmap = self._ensure_world()
        plan = self._plan(cmap, situation, seed)
        weather, weather_values = self._weather(situation.values)
        scale = friction_scale(situation.values, self.physics)
        original = world.get_settings()
        actors: list[Any] = []
        sensors: list[Any] = []
        try:
            settings = world.get_settings()
            settings.synchronous_mode = True
            settings.fixed_delta_seconds = self.dt
            world.apply_settings(settings)
            world.set_weather(weather)
            library = world.get_blueprint_library()
            ego, ov, twins = self._spawn(world, library, plan, situation, seed, actors)
            wheeled = [tw.carla_actor for tw in twins if tw.actor.kind != "pedestrian"]
            vehicles = (ego, *wheeled, *([ov] if ov is not None else []))
            friction = self._apply_friction(world, library, vehicles, scale, actors)
            if friction.get("error"):
                return Outcome.errored(friction["error"])
            run = _Spawned(world, library, ego, ov, twins)
            outcome, driver = self._drive(
                run, plan, stack, situation, seed, friction, record, sensors
            )
            outcome.metrics.update(
                friction_scale=scale,
                physics=self.physics,
                mu=scale * conditions_from_values({}).mu,
                tire_friction=friction["readback"],
                friction_mode=self.friction_mode,
                weather=weather_values,
                map=self.map.name,
                town=self.map.town,
                carla_server=self._versions.get("server"),
                carla_client=self._versions.get("client"),
                ov_released_at=driver.released_at if driver is not None else None,
            )
            if plan.scene is not None and plan.car_ov:
                outcome.metrics["actors"] = {
                    "ov": _ov_metrics(plan.ov_move, outcome),
                    **outcome.metrics["actors"],
                }
            return outcome
        finally:
            self._cleanup(world, original, actors, sensors)

    def _plan(self, cmap: Any, situation: Situation, seed: int) -> _RunPlan:
        """Movements, spawns, lane routes, the scene's further road users and the car OV's
        conflict point (raises ConfigError on bad values before anything is spawned)."""
        spec = self.map
        ego_mv, ov_mv, label = self._intsit(situation)
        ego_sp, ego_goal = spec.ego_spawn(ego_mv), spec.goal(ego_mv)
        ego_route = self._route(cmap, ego_sp, ego_goal)
        # None: the paper's two cars; the twins time their arrival on the ego's lane route
        scene = plan_scene(spec, situation.values, seed, ego_route)
        car_ov = scene is None or scene.car_ov
        ov_sp = spec.ov_spawn(ov_mv) if car_ov else None
        return _RunPlan(
            ego_move=ego_mv,
            ov_move=ov_mv,
            scene=scene,
            ego_spawn=ego_sp,
            ego_goal=ego_goal,
            ego_route=ego_route,
            ov_spawn=ov_sp,
            ov_route=self._route(cmap, ov_sp, spec.goal(ov_mv)) if ov_sp is not None else [],
            conflict=conflict_point(spec, situation.values, label) if car_ov else None,
        )

    def _spawn(
        self,
        world: Any,
        library: Any,
        plan: _RunPlan,
        situation: Situation,
        seed: int,
        actors: list,
    ) -> tuple[Any, Any, list[Twin]]:
        """Ego, the car OV (None for a pedestrian or cyclist OV) and every scene twin; each
        is appended to ``actors`` as soon as it exists."""
        sp = plan.ego_spawn
        ego = world.spawn_actor(
            library.find(self.map.ego_blueprint), self._transform(sp.x, sp.y, sp.z, sp.yaw)
        )
        actors.append(ego)
        ov = self._spawn_ov(world, library, plan.ov_spawn, situation, seed, actors)
        twins = []
        if plan.scene is not None:
            twins = spawn_twins(self._carla, world, library, self.map, plan.scene, actors)
        return ego, ov, twins

    def _drive(
        self,
        run: _Spawned,
        plan: _RunPlan,
        stack: AVStack,
        situation: Situation,
        seed: int,
        friction: dict[str, Any],
        record: bool,
        sensors: list,
    ) -> tuple[Outcome, OVDriver | None]:
        """Sensors, the stack's reset, the OV driver, then the episode's step loop."""
        info = RunInfo(
            dt=self.dt,
            route=tuple((x, -y) for x, y in plan.ego_route),
            goal=(plan.ego_goal[0], -plan.ego_goal[1]),
            map_name=self.map.name,
            camera=stack.camera,
            seed=int(seed),
        )
        twins = run.twins
        mu = conditions_from_values(situation.values, profile=self.physics).mu
        scene = Scene(plan.scene, twins, list(info.route), self.dt, mu) if plan.scene else None
        primary = run.ov if run.ov is not None else twins[0].carla_actor
        episode = Episode(
            self._episode_settings(),
            run.world,
            stack,
            run.ego,
            primary,
            record=record,
            scene=scene,
            ov_kind="car" if plan.car_ov else twins[0].actor.kind,
            route=list(info.route),
        )
        episode.attach_sensors(run.library, sensors)
        try:
            stack.reset(info)
        except Exception as exc:
            raise StackFailure() from exc
        _check_wants(stack)
        ov_sit = [(x, -y) for x, y in plan.ov_route] if plan.car_ov else twins[0].route
        driver = None
        if plan.conflict is not None:
            driver = OVDriver(
                list(info.route),
                ov_sit,
                (plan.conflict[0], -plan.conflict[1]),
                friction["max_steer"],
                switch_distance=self.map.switch_distance(plan.ego_move, plan.ov_move),
            )
        tracker = MetricTracker(list(info.route), ov_sit)
        return episode.drive(driver, tracker, plan.ego_goal), driver

    def _spawn_ov(
        self,
        world: Any,
        library: Any,
        spawn: SpawnPoint | None,
        situation: Situation,
        seed: int,
        actors: list,
    ) -> Any:
        """The paper's car OV at its spawn (None when the OV is a pedestrian or cyclist)."""
        if spawn is None:
            return None
        ov_bp = library.find(self.map.ov_blueprint)
        if ov_bp.has_attribute("color"):  # the same colour the embedded backend draws
            ov_bp.set_attribute("color", ",".join(map(str, ov_color(situation.values, seed))))
        ov = world.spawn_actor(ov_bp, self._transform(spawn.x, spawn.y, spawn.z, spawn.yaw))
        actors.append(ov)
        return ov

    def _apply_friction(
        self, world: Any, library: Any, vehicles: tuple[Any, ...], scale: float, actors: list
    ) -> dict[str, Any]:
        wanted: list[list[float]] = []
        base = 1.0  # the wheels' own friction before scaling (the trigger's reference)
        max_steer = math.radians(70.0)  # of the last vehicle, the OV (for its pure pursuit)
        for vehicle in vehicles:
            control = vehicle.get_physics_control()
            wheels = control.wheels
            if wheels:
                base = wheels[0].tire_friction
                max_steer = math.radians(max(w.max_steer_angle for w in wheels) or 70.0)
            if self.friction_mode in ("wheels", "both"):
                for wheel in wheels:
                    wheel.tire_friction = wheel.tire_friction * scale
                control.wheels = wheels
                vehicle.apply_physics_control(control)
            wanted.append([w.tire_friction for w in wheels])
        if self.friction_mode in ("trigger", "both"):
            bp = library.find("static.trigger.friction")
            bp.set_attribute("friction", str(base * scale))
            extent = str(self.map.junction.radius * 100.0)  # centimetres
            for axis in ("extent_x", "extent_y"):
                bp.set_attribute(axis, extent)
            bp.set_attribute("extent_z", "1000.0")
            junction = self.map.junction
            actors.append(world.spawn_actor(bp, self._transform(junction.x, junction.y)))
        world.tick(seconds=self.timeout)
        readback = [[w.tire_friction for w in v.get_physics_control().wheels] for v in vehicles]
        result: dict[str, Any] = {"readback": readback, "max_steer": max_steer}
        for got, want in zip(readback, wanted, strict=True):
            pairs = zip(got, want, strict=False)
            if len(got) != len(want) or any(
                abs(g - w) > FRICTION_RTOL * max(abs(w), 1e-9) for g, w in pairs
            ):
                result["error"] = (
                    f"tyre friction did not take effect: read back {got}, wanted {want}"
                )
        return result

    def _cleanup(self, world: Any, original: Any, actors: list, sensors: list) -> None:
        for sensor in sensors:
            with contextlib.suppress(RuntimeError):
                sensor.stop()
        for actor in [*reversed(sensors), *reversed(actors)]:
            with contextlib.suppress(RuntimeError):
                actor.destroy()
        sensors.clear()
        actors.clear()
        try:
            world.apply_settings(original)
        except RuntimeError:
            self.close()  # a dead connection: reconnect next time


def friction_scale(values: Mapping[str, Any], physics: str = "carla") -> float:
    """Factor applied to the tyres' friction: the situation's mu relative to clear, dry mu.

    Uses ``sitcov.sim.conditions_from_values`` so both backends share one friction model
    per physics profile: the friction element alone (``carla``), or times the wet-road
    grip ratio (``physical``).
    """
    dry = conditions_from_values({}, profile=physics).mu
    return conditions_from_values(values, profile=physics).mu / dry


def _ov_metrics(move: str, outcome: Outcome) -> dict[str, Any]:
    """The car OV's entry in ``metrics["actors"]``: the run's primary metrics."""
    return {
        "kind": "car",
        "route": move,
        "behaviour": "timed",
        "min_distance": outcome.min_distance,
        "min_ttc": outcome.min_ttc,
        "pet": outcome.pet,
    }


def _launch_command(launch: str | None, host: str, port: int) -> str | None:
    """The launch command with ``{host}`` and ``{port}`` filled in (None: no command)."""
    if launch is None or not str(launch).strip():
        return None
    try:
        return str(launch).format(host=host, port=port)
    except (KeyError, IndexError, ValueError) as exc:
        raise ConfigError(
            field="carla_launch",
            value=launch,
            expected=f"a shell command; only {{host}} and {{port}} are replaced ({exc})",
        ) from None


def _import_carla() -> Any:
    try:
        import carla
    except ImportError:
        raise MissingExtraError("CARLA backend", "carla", "carla") from None
    return carla
