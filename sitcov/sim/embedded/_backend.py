"""The embedded backend: two single-track vehicles at a junction map, stepped at 20 Hz.

One run: conditions from the situation's weather values, routes and conflict point from
its intersection situation, the AV stack drives the ego from simulated perception (a
perception error model, or rendered frames in camera mode), the adversarial OV times its
arrival at the conflict point. The run ends at a collision, the goal, a standstill that
nothing can change, or the time limit; monitors record when the ego first left its lane
or the road. What counts as a failure is the campaign's judge (``sitcov.sim.Judge``),
applied afterwards: the backend's own ``status`` is collision-only. Everything random
comes from ``numpy.random.default_rng(seed)``, so a (situation, seed) pair always gives
the same outcome.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from sitcov.av._base import OBSERVATION_KINDS, RunInfo
from sitcov.errors import ConfigError, SetupError
from sitcov.perception._base import CameraSpec, Sensor
from sitcov.sim._adversary import AdversaryParams
from sitcov.sim._base import Backend, Outcome, Trace
from sitcov.sim.embedded._collision import contact_point
from sitcov.sim.embedded._controllers import PacedController, TimingController
from sitcov.sim.embedded._dynamics import default_params
from sitcov.sim.embedded._ego import EgoDriver
from sitcov.sim.embedded._map import MAPS_DIR, JunctionMap, load_map
from sitcov.sim.embedded._monitors import (  # noqa: F401 - constants re-exported
    CORRIDOR_MARGIN,
    FAR,
    GOAL_TOLERANCE,
    LANE_HOLD_MARGIN,
    LANE_TOLERANCE,
    STOPPED_SPEED,
    LaneDepartureMonitor,
    RoadDepartureMonitor,
    default_monitors,
    fused_update,
)
from sitcov.sim.embedded._progress import BLOCKED_TIME, STILL_SPEED  # noqa: F401
from sitcov.sim.embedded._scene import (  # noqa: F401
    DEFAULT_INTSIT,
    build_actors,
    check_scene_values,
    parse_scene,
)
from sitcov.sim.embedded._world import Wind, World
from sitcov.weather._conditions import (
    AIR_DENSITY,
    SIDE_AREA,
    SIDE_FORCE_COEFF,
    check_profile,
    conditions_from_values,
)

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.hyperspace import Situation

#: Gust model: turbulence intensity (std of speed / mean speed) [-] and time scale [s].
GUST_INTENSITY = 0.3
GUST_TIME = 2.0

#: Camera mode's default ``frame_gate``: a frame is rendered only if a road user's true box
#: is at least this fraction of the smallest box the stack acts on. 0.7 allows a detected
#: box 1.43 times the true one; the SSD's car boxes that passed the reference AEB's score
#: test were at most 1.32 times as wide (99th percentile 1.20; person boxes at most 1.11
#: times as tall): docs/camera.md, frame skipping.
FRAME_GATE = 0.7

#: Highest actor slot (``actor2`` ... ``actor<MAX_ACTOR_SLOT>``) listed among the effects.
MAX_ACTOR_SLOT = 32
_PERCEPTION_EFFECTS = {
    "fog_density": "fog extinction coefficient (Koschmieder), lowers detection contrast",
    "fog_distance": "distance at which the fog starts [m]",
    "cloudiness": "scene illumination (Kasten-Czeplak), lowers image contrast",
    "intsit": "ego and OV routes and their conflict point; the OV's kind (car, cyclist, "
    "pedestrian)",
    "ov_color": "the OV's body colour (camera image; PEM contrast term); default: drawn per run",
    **{
        f"actor{n}": "an extra road user: kind, route, behaviour (docs/embedded.md, "
        "'Actors and the scene'); 'none' for no actor"
        for n in range(2, MAX_ACTOR_SLOT + 1)
    },
}
#: What each element does, per physics profile (``docs/weather.md`` has the table).
ELEMENT_EFFECTS: dict[str, dict[str, str]] = {
    "carla": {
        "friction": "the tyre-road friction mu itself (dynamics: braking, cornering limit)",
        "wetness": "perception only: glare in perception noise (mu unchanged, as in CARLA)",
        "precipitation": "perception only: rain streaks in perception noise; rain angle",
        "precipitation_deposits": "perception only: spray in perception noise",
        "wind_intensity": "perception only: slants the rain (no force, as in CARLA)",
        **_PERCEPTION_EFFECTS,
    },
    "physical": {
        "friction": "dry-road tyre-road friction, times the wet-road grip ratio = mu",
        "wetness": "water film up to 0.25 mm: mu x 0.61 at 100; glare in perception noise",
        "precipitation": "rain film up to 1 mm: mu x 0.55 at 100; rain streaks; rain angle",
        "precipitation_deposits": "share of road under puddles (mu x 0.55 there); spray",
        "wind_intensity": "gusty crosswind side force on ego and OV; rain angle",
        **_PERCEPTION_EFFECTS,
    },
}
#: Default perception and brake actuation delays [s] per physics profile: none in
#: ``carla`` (CARLA applies a control at the next tick, as here); in ``physical`` the
#: brake takes 0.2 s to build up (modern passenger-car brakes, the value German accident
#: reconstruction uses; EEC 71/320 allows up to 0.36 s for M1 vehicles).
DEFAULT_DELAYS: dict[str, tuple[float, float]] = {"carla": (0.0, 0.0), "physical": (0.0, 0.2)}


def _delay(field: str, value: float | None, default: float) -> float:
    """A delay option [s]: ``default`` when None, else a finite number >= 0."""
    if value is None:
        return default
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise ConfigError(field=field, value=value, expected="seconds >= 0") from None
    if not (math.isfinite(number) and number >= 0.0):
        raise ConfigError(field=field, value=value, expected="seconds >= 0")
    return number


class EmbeddedBackend(Backend):
    """Fast, deterministic simulation of an intersection situation (the default backend).

    Args:
        perception: ``"pem"`` (perception error model, detections) or ``"camera"``
            (rendered frames given to the stack as ``Observation.image``).
        map: built-in map name or a map YAML file.
        dt: control period [s].
        sensor: the Sensor used in PEM mode (default: ``sitcov.perception.PEMSensor()``).
        sensor_rate_hz: camera frame rate [Hz].
        sim_timeout: simulated time after which a run ends as a pass [s].
        grey_box: give the stack the full situation in ``RunInfo``.
        adversary: AdversaryParams, or a mapping of its fields.
        wind: False switches the crosswind force off (it exists only in ``physical``).
        physics: ``carla`` (default: weather acts on perception only, friction is the
            friction element, as in CARLA 0.9.x) or ``physical`` (wet-road grip loss and
            crosswind force too); see ``docs/weather.md``.
        perception_delay: seconds between a frame's capture and the stack receiving it
            (default 0: a property of the stack under test, set it to model its latency).
        brake_delay: seconds between the ego's brake command and its effect (default:
            ``DEFAULT_DELAYS`` of the profile: 0 in ``carla``, 0.2 s in ``physical``).
        early_end: end a run as ``stopped`` as soon as nothing can change any more
            (False runs on to the goal or the timeout; verdicts are the same, slower).
        frame_gate: camera mode: render and detect a frame only if some vehicle's true
            box is at least ``frame_gate`` times the narrowest box the stack acts on
            (``AVStack.min_box_width``, per class ``min_box_sizes``) and reaches near
            the region it looks at (``AVStack.centre_window``): the margin for the
            detector's box being up to ``1 / frame_gate`` times the true box (the SSD's
            were at most 1.32 times as wide). 0 renders every frame with a road user in
            view. See docs/camera.md for the measured effect on verdicts.
        object_noise: the object lists' noise and miss model for stacks that want
            ``objects``: None (default) gives the ground truth, ``"default"`` the shipped
            model (``sitcov/perception/data/objects.yaml``), else a YAML file of its
            parameters, or an ``ObjectNoise``.

    What a stack observes is what it wants (``AVStack.wants``): in PEM mode detections
    (the PEM) or objects; in camera mode images, detections (the real detector on the
    rendered frame, at its output floor) or objects. Images from the PEM cannot be
    served: the run raises a one-line ``SetupError``, which stops a campaign.
    """

    name: ClassVar[str] = "embedded"

    def __init__(
        self,
        perception: str = "pem",
        map: str = "t-junction",  # noqa: A002 - the documented option name
        dt: float = 0.05,
        sensor: Sensor | None = None,
        sensor_rate_hz: float = 10.0,
        sim_timeout: float = 60.0,
        grey_box: bool = False,
        adversary: AdversaryParams | Mapping[str, Any] | None = None,
        wind: bool = True,
        early_end: bool = True,
        frame_gate: float = FRAME_GATE,
        physics: str = "carla",
        perception_delay: float | None = None,
        brake_delay: float | None = None,
        object_noise: Any = None,
    ) -> None:
        self.physics = check_profile(physics)
        defaults = DEFAULT_DELAYS[self.physics]
        self.perception_delay = _delay("perception_delay", perception_delay, defaults[0])
        self.brake_delay = _delay("brake_delay", brake_delay, defaults[1])
        if perception not in ("pem", "camera"):
            raise ConfigError(field="perception", value=perception, expected="pem | camera")
        if not 0.0 <= frame_gate <= 1.0:
            raise ConfigError(field="frame_gate", value=frame_gate, expected="a number in [0, 1]")
        if not dt > 0 or not sensor_rate_hz > 0 or not sim_timeout > 0:
            raise ConfigError(
                field="dt/sensor_rate_hz/sim_timeout",
                value=(dt, sensor_rate_hz, sim_timeout),
                expected="positive numbers",
            )
        self.perception = perception
        self.map: JunctionMap = map if isinstance(map, JunctionMap) else load_map(str(map))
        self.dt = float(dt)
        self.sensor = sensor
        self.sensor_every = max(1, round(1.0 / (sensor_rate_hz * self.dt)))
        self.sim_timeout = float(sim_timeout)
        self.grey_box = bool(grey_box)
        if isinstance(adversary, Mapping):
            try:
                adversary = AdversaryParams(**adversary)
            except TypeError as exc:
                raise ConfigError(
                    field="adversary",
                    value=dict(adversary),
                    expected=f"fields of AdversaryParams ({exc})",
                ) from None
        self.adversary = adversary or AdversaryParams()
        self.wind = bool(wind)
        self.early_end = bool(early_end)
        self.frame_gate = float(frame_gate)
        self.vehicle = default_params()
        self._render_frame: Any = None
        self._geometry: dict[str, Any] | None = None
        self._min_sizes: dict[str, tuple[float, float]] = {}  # per class, this run's gate
        self._window: tuple[float, float] | None = None  # this run's centre window [px]
        self.object_noise = _object_noise(object_noise)
        #: Camera mode, stacks that want detections: ``image -> detections`` (default: the
        #: SSD detector at its output floor, made at first use).
        self.detector: Any = None

    def __getstate__(self) -> dict[str, Any]:
        """Cross processes without the detector (a TFLite interpreter; made again there)."""
        state = dict(self.__dict__)
        state["detector"] = None
        return state

    def effects(self) -> dict[str, str]:
        """Every element this backend uses, and how (in this backend's physics profile)."""
        return dict(ELEMENT_EFFECTS[self.physics])

    def check_hyperspace(self, hyperspace: Any) -> None:
        """Every ``intsit`` and ``actorN`` bin parses and names routes of this map (a key
        typo such as ``behavior:`` or an unknown route is refused here, not in each run)."""
        check_scene_values(self.map, hyperspace)

    # --- helpers ----------------------------------------------------------------------------

    def _get_sensor(self) -> Sensor:
        if self.sensor is None:
            from sitcov.perception import PEMSensor  # the ego helper's module; lazy

            self.sensor = PEMSensor()
        return self.sensor

    def _detect(self, image: np.ndarray) -> Any:
        """The camera-mode detector's detections in ``image`` (every class it reports)."""
        if self.detector is None:
            from sitcov.perception import SSDDetector  # lazy: needs the camera extra

            self.detector = SSDDetector()
        return self.detector(image)

    def observation_kind(self, stack: AVStack) -> str:
        """What this backend gives ``stack`` each frame (read after its ``reset``):
        ``detections`` (PEM), ``camera-detections`` (the detector on rendered frames),
        ``image`` or ``objects``.

        Raises:
            ConfigError: the stack wants something that is no observation kind.
            SetupError: the stack wants images in PEM mode (one line, naming the stack).
        """
        wants = getattr(stack, "wants", None)
        if wants is None:
            return "detections" if self.perception == "pem" else "image"
        if wants not in OBSERVATION_KINDS:
            raise ConfigError(field="wants", value=wants, expected=" | ".join(OBSERVATION_KINDS))
        if wants == "image" and self.perception == "pem":
            who = getattr(stack, "who", None) or f"stack {getattr(stack, 'name', '?')!r}"
            raise SetupError(
                f"{who} wants camera images, which perception 'pem' cannot give (it gives "
                "detections or objects): run it with --perception camera"
            )
        if wants == "detections" and self.perception == "camera":
            return "camera-detections"
        return wants

    def _frame(self, camera, pose, actors, conditions, rng) -> np.ndarray:
        if self._render_frame is None:
            try:
                from sitcov.perception import render_frame
            except ImportError as exc:
                raise ConfigError(f"camera perception is not available: {exc}") from None
            self._render_frame = render_frame
            self._geometry = self.map.render_geometry()
        return self._render_frame(camera, pose, actors, conditions, self._geometry, rng)

    # --- camera mode: frame skipping (owner: camera perception) ---------------------------
    #: In camera mode, frames in which no vehicle is at least 2 px wide (nor as wide as
    #: ``frame_gate`` asks) are not rendered nor run through the detector; the stack
    #: receives ``detections=()`` instead. Set False to give a camera-only stack every
    #: frame (about six times as slow with the reference stack).
    skip_empty_frames: bool = True
    #: Called as ``frame_observer(camera, pose, actors, conditions)`` before each camera
    #: frame is rendered (the ground truth of that frame; used by ``sitcov calibrate``).
    frame_observer: Any = None

    def _gate_px(self, stack: AVStack, camera: CameraSpec) -> float:
        """The true box width [px] below which a camera frame is not rendered."""
        from sitcov.perception._renderer import MIN_VISIBLE_PX

        if not self.skip_empty_frames:
            return 0.0
        wanted = self.frame_gate * float(getattr(stack, "min_box_width", 0.0)) * camera.width
        return max(MIN_VISIBLE_PX, wanted)

    def _gate_sizes(self, stack: AVStack, camera: CameraSpec) -> dict[str, tuple[float, float]]:
        """Per class: the true box (width, height) [px] below which an actor of that class
        does not make a camera frame worth rendering (the stack's ``min_box_sizes``)."""
        if not self.skip_empty_frames:
            return {}
        sizes = getattr(stack, "min_box_sizes", None) or {}
        g = self.frame_gate
        return {
            str(label): (g * float(w) * camera.width, g * float(h) * camera.height)
            for label, (w, h) in sizes.items()
        }

    def _gate_window(self, stack: AVStack, camera: CameraSpec) -> tuple[float, float] | None:
        """The stack's ``centre_window`` in pixels (None: it looks at the whole width, or
        frames are not skipped)."""
        if not self.skip_empty_frames:
            return None
        lo, hi = (float(v) for v in getattr(stack, "centre_window", (0.0, 1.0)))
        if lo <= 0.0 and hi >= 1.0:
            return None
        return lo * camera.width, hi * camera.width

    def _gate_spread(self) -> float:
        """How far outside an actor's true box a detection's centre may lie, as a fraction
        of the box width: a detection up to ``1 / frame_gate`` times as wide as the true
        box that covers the true box's centre (``frame_gate`` 0: anywhere)."""
        return math.inf if self.frame_gate <= 0.0 else 0.5 * (1.0 / self.frame_gate - 1.0)

    def _needs_frame(self, camera, pose, actors, min_px: float) -> bool:
        if min_px <= 0.0:
            return True
        from sitcov.perception._renderer import actors_in_view

        window = self._window
        if window is None:
            return actors_in_view(camera, pose, actors, min_px, self._min_sizes)
        return actors_in_view(
            camera, pose, actors, min_px, self._min_sizes, window, self._gate_spread()
        )

    def _frames_repeat(self, conditions: Any) -> bool:
        """Whether a camera frame is fully determined by the poses and views it shows in
        these conditions (the renderer draws nothing at random: no rain), so a frame
        whose inputs equal the previous frame's is that frame again, to the bit."""
        from sitcov.perception._renderer import frame_draws

        return not frame_draws(conditions)

    def _map_ref(self) -> str:
        """The map's name if it is built in (portable across machines), else its file."""
        builtin = MAPS_DIR / f"{self.map.name}.yaml"
        return self.map.name if str(builtin) == self.map.source else self.map.source

    # --- the run ------------------------------------------------------------------------------

    def run(
        self,
        situation: Situation,
        av_stack: AVStack,
        seed: int,
        *,
        record: bool = False,
        perception_seed: int | None = None,
    ) -> Outcome:
        """Simulate ``situation`` with ``av_stack`` driving the ego (deterministic per seed).

        ``perception_seed``: run the world of run seed ``seed`` (wind, the road users'
        colours and drawn speeds, the seed the stack is given) with the perception of run
        seed ``perception_seed`` (the PEM's noise, the camera frames' rain streaks, the
        object lists' noise: :func:`perception_rng`). None or ``seed`` itself: the plain
        run, bit for bit. The agreement experiment's shared-world pairs use it to split
        run-to-run disagreement into a world part and a perception part.
        """
        seed = int(seed)
        rng = np.random.default_rng(seed)
        values = situation.values
        plan = parse_scene(values)
        n_max = int(math.ceil(self.sim_timeout / self.dt - 1e-9))
        wind_direction, gusts = world_draws(rng, n_max)
        cond = conditions_from_values(values, wind_direction=wind_direction, profile=self.physics)
        ego, actors = build_actors(self.map, plan, values, seed, self.adversary)
        wind = Wind(
            cond.wind_speed if self.wind and self.physics == "physical" else 0.0,
            wind_direction,
            gusts,
            GUST_INTENSITY,
            GUST_TIME,
            0.5 * AIR_DENSITY * SIDE_FORCE_COEFF * SIDE_AREA / self.vehicle.mass,
            self.dt,
        )
        sense_rng, sense_seed = rng, seed  # the sensor continues the run's generator
        if perception_seed is not None and int(perception_seed) != seed:
            sense_seed = int(perception_seed)
            sense_rng = perception_rng(sense_seed, n_max)
        driver = self._driver(situation, av_stack, ego, cond, sense_rng, seed, sense_seed)
        world = World(ego, actors, driver, wind, cond.mu, self.dt)
        monitors = self._monitors(world)
        reason = world.end_reason = run_loop(world, monitors, n_max, record)
        outcome = self._outcome(plan, world, monitors, cond, wind_direction, reason, record)
        world.release()  # no reference cycles left: the run's objects go with it
        return outcome

    def _driver(self, situation, av_stack, ego, cond, rng, seed, sense_seed=None) -> EgoDriver:
        """Reset the stack and the sensor for a run; the ego's controller. ``rng`` and
        ``sense_seed`` (default ``seed``) feed the perception; the stack gets ``seed``."""
        sense_seed = seed if sense_seed is None else sense_seed
        route = ego.route
        camera = av_stack.camera
        av_stack.reset(
            RunInfo(
                dt=self.dt,
                route=route.points,
                goal=route.points[-1],
                map_name=self.map.name,
                camera=camera,
                seed=seed,
                situation=situation if self.grey_box else None,
            )
        )
        kind = self.observation_kind(av_stack)
        sensor = self._get_sensor() if kind == "detections" else None
        if sensor is not None and hasattr(sensor, "reset"):
            sensor.reset(frame_dt=self.sensor_every * self.dt)  # per-run noise state (PEM)
        gate_px = self._gate_px(av_stack, camera) if kind in ("image", "camera-detections") else 0.0
        self._min_sizes = self._gate_sizes(av_stack, camera)
        self._window = self._gate_window(av_stack, camera)
        return EgoDriver(
            self,
            av_stack,
            sensor,
            cond,
            rng,
            sense_seed,
            round(self.perception_delay / self.dt),
            round(self.brake_delay / self.dt),
            gate_px,
            kind,
        )

    def _monitors(self, world: World) -> list[Any]:
        """The run's monitors (``_monitors.default_monitors``) for the ego's route."""
        ego = world.ego
        route = ego.route
        lane = LaneDepartureMonitor(0.5 * (self.map.lane_width - ego.spec.width) + LANE_TOLERANCE)
        left, right = self.map.clearance(route)
        road = RoadDepartureMonitor(
            self.map.drivable_area, route.hs, left, right, ego.half_l, ego.half_w
        )
        driver = world.driver
        never_latches = driver.plain_step is not None and not driver.plain_latches
        early_end = self.early_end and not never_latches
        return default_monitors(world, lane, road, early_end, self.sim_timeout)

    def _outcome(self, plan, world, monitors, cond, wind_direction, reason, record) -> Outcome:
        """The run's Outcome: the primary OV's values at the top level, as before actors."""
        run: dict[str, Any] = {}
        per_actor: dict[str, Any] = {a.name: {} for a in world.actors}
        for m in monitors:
            m.report(run, per_actor, world)
        ov = world.actors[0]
        primary = per_actor[ov.name]
        timed = isinstance(ov.controller, TimingController | PacedController)
        timing = ov.controller if timed else None
        collided = reason == "collision"
        t = world.t
        metrics = {
            "steps": world.k,
            "mu": cond.mu,
            "physics": self.physics,
            "perception_delay": self.perception_delay,
            "brake_delay": self.brake_delay,
            "visibility": cond.visibility if math.isfinite(cond.visibility) else None,
            "wind_direction": wind_direction,
            "ego_route": plan.ego,
            "ov_route": ov.info["route"],
            "conflict_label": plan.conflict_label,
            "conflict_point": list(ov.conflict.point) if ov.conflict else None,
            "ov_switch_time": timing.switch_time if timing else None,
            "ov_switch_distance": timing.params.switch_distance if timing else None,
            "ego_gap_at_switch": timing.switch_gap if timing else None,
            **run,
            "ego_final_speed": world.ego.body.speed,
            "ego_collision_speed": world.ego.body.speed if collided else None,
            "ego_stationary": collided and world.ego.body.speed < STILL_SPEED,
        }
        if not plan.classic:
            metrics.update(scene_metrics(world, per_actor))
        return Outcome(
            status="fail" if collided else "pass",
            end_reason=reason,
            sim_time=round(t, 10),
            collision=collided,
            collision_time=round(t, 10) if collided else None,
            collision_speed=per_actor["_collision_speed"],
            min_distance=primary["min_distance"],
            min_ttc=primary["min_ttc"],
            pet=primary["pet"],
            aeb_fired=world.driver.aeb_time is not None,
            aeb_time=world.driver.aeb_time,
            metrics=metrics,
            trace=self._trace(world, reason) if record else None,
        )

    def _trace(self, world: World, reason: str) -> Trace:
        """Every actor's rows (the primary OV also as ``ov``), routes, kinds and sizes."""
        world.record()
        ego, ov = world.ego, world.actors[0]
        hit = world.collision
        return Trace(
            ego=ego.rows,
            ov=ov.rows,
            meta={
                "map": self._map_ref(),
                "ego_route": [list(p) for p in ego.route.points],
                "ov_route": [list(p) for p in ov.route.points],
                "conflict_point": list(ov.conflict.point) if ov.conflict else None,
                # the run ended on the step of contact: the collision monitor's point
                "collision_point": list(contact_point(ego.box(), hit.box()))
                if reason == "collision" and hit is not None
                else None,
                "length": ego.spec.length,
                "width": ego.spec.width,
                "dt": self.dt,
                "actors": {
                    a.name: {
                        "kind": a.kind,
                        "length": a.spec.length,
                        "width": a.spec.width,
                        "height": a.spec.height,
                        # the body colour the camera drew (animations' dash-cam strip)
                        "color": None if a.color is None else [int(c) for c in a.color],
                        "route": [list(p) for p in a.route.points],
                    }
                    for a in world.actors
                },
            },
            actors={a.name: a.rows for a in world.actors},
        )


def world_draws(rng: np.random.Generator, n_max: int) -> tuple[float, np.ndarray]:
    """The world's draws from a run's generator, in this order: the wind's direction
    [rad] and the ``n_max + 1`` unit normals of its OU gusts as a float array (drawn up
    front so the stream's order is fixed; in the ``carla`` profile the wind has no force,
    the normals are drawn all the same, and ``Wind`` reads only the first). The sensor's
    draws follow them."""
    return float(rng.uniform(-math.pi, math.pi)), rng.standard_normal(n_max + 1)


def perception_rng(seed: int, n_max: int) -> np.random.Generator:
    """The generator the sensor of run ``seed`` draws from: ``default_rng(seed)`` after
    :func:`world_draws`, so a run given ``perception_seed=seed`` sees the same
    perception noise as the plain run of ``seed`` would in the same frames."""
    rng = np.random.default_rng(int(seed))
    world_draws(rng, n_max)
    return rng


def _object_noise(value: Any) -> Any:
    """The ``object_noise`` option as an ``ObjectNoise`` (None: ground truth)."""
    if value is None:
        return None
    from sitcov.perception._objects import ObjectNoise, load_object_noise

    if isinstance(value, ObjectNoise):
        return value
    if not isinstance(value, str):
        raise ConfigError(
            field="object_noise", value=value, expected="'default' or a YAML file of parameters"
        )
    return load_object_noise(None if value == "default" else value)


def run_loop(world: World, monitors: list[Any], n_max: int, record: bool) -> str:
    """Step the world until a monitor ends the run or ``n_max`` steps passed; the end reason."""
    fused, rest = fused_update(world, monitors)  # the built-in list's work in one call
    step = world.stepper()  # World.step with the run's fixed parts bound
    if fused is not None and not rest:
        while True:
            if record:
                world.record()
            step()
            reason = fused()
            if reason is not None:
                return reason
            if world.k >= n_max:
                return "sim_timeout"
    updates = [m.update for m in rest]
    if fused is not None:
        updates.insert(0, lambda _world: fused())
    while True:
        if record:
            world.record()
        step()
        for update in updates:
            reason = update(world)
            if reason is not None:
                return reason
        if world.k >= n_max:
            return "sim_timeout"


def scene_metrics(world: World, per_actor: dict[str, Any]) -> dict[str, Any]:
    """Metrics of a scene beyond the paper's two cars: every actor's facts, actor-actor
    collisions, and which actor the ego hit."""
    hit = world.collision
    return {
        "actors": {a.name: {"kind": a.kind, **a.info, **per_actor[a.name]} for a in world.actors},
        "actor_collisions": per_actor.get("_actor_collisions", []),
        "collision_actor": hit.name if hit is not None else None,
        "collision_kind": hit.kind if hit is not None else None,
    }
