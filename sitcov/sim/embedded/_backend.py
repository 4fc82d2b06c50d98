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
from collections import deque
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from sitcov.av._base import EgoState, Observation, RunInfo
from sitcov.errors import ConfigError
from sitcov.perception._base import ActorView, CameraSpec, Pose, Sensor
from sitcov.perception._colors import ov_color
from sitcov.sim._adversary import (
    AdversaryController,
    AdversaryParams,
    pure_pursuit,
    with_switch_distance,
)
from sitcov.sim._base import Backend, Outcome, Trace
from sitcov.sim._conditions import (
    AIR_DENSITY,
    SIDE_AREA,
    SIDE_FORCE_COEFF,
    check_profile,
    conditions_from_values,
)
from sitcov.sim._metrics import PET_ZONE, post_encroachment_time
from sitcov.sim.embedded._collision import (
    box_distance,
    corridor_gap,
    overlap,
    time_to_collision,
)
from sitcov.sim.embedded._dynamics import G, Vehicle, default_params
from sitcov.sim.embedded._map import MAPS_DIR, JunctionMap, load_map
from sitcov.sim.embedded._monitors import (
    LANE_TOLERANCE,
    LaneDepartureMonitor,
    RoadDepartureMonitor,
)

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.hyperspace import Situation

#: The intersection situation used when a situation has no ``intsit`` element (IntSit-1).
DEFAULT_INTSIT = {"ego": "L-B", "ov": "R-B", "conflict": "c4"}
#: Gust model: turbulence intensity (std of speed / mean speed) [-] and time scale [s].
GUST_INTENSITY = 0.3
GUST_TIME = 2.0
#: Ego speed below which it counts as stopped [m/s].
STOPPED_SPEED = 0.05
#: The ego has reached its goal within this arc length of the route's end [m].
GOAL_TOLERANCE = 1.5
#: Safety factor on the friction an OV needs to hold its lane (for the early end) [-].
LANE_HOLD_MARGIN = 1.5
#: Tracking margin of the OV around its route for the early end [m].
CORRIDOR_MARGIN = 1.0
#: Centre distance beyond which the box distance is evaluated every other step [m].
FAR = 15.0

_PERCEPTION_EFFECTS = {
    "fog_density": "fog extinction coefficient (Koschmieder), lowers detection contrast",
    "fog_distance": "distance at which the fog starts [m]",
    "cloudiness": "scene illumination (Kasten-Czeplak), lowers image contrast",
    "intsit": "ego and OV routes and their conflict point",
    "ov_color": "the OV's body colour (camera image; PEM contrast term); default: drawn per run",
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
            (``AVStack.min_box_width``); 0 renders every frame with a vehicle in view.
            See docs/camera.md for the measured effect on verdicts.
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
        frame_gate: float = 0.5,
        physics: str = "carla",
        perception_delay: float | None = None,
        brake_delay: float | None = None,
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

    def effects(self) -> dict[str, str]:
        """Every element this backend uses, and how (in this backend's physics profile)."""
        return dict(ELEMENT_EFFECTS[self.physics])

    # --- helpers ----------------------------------------------------------------------------

    def _get_sensor(self) -> Sensor:
        if self.sensor is None:
            from sitcov.perception import PEMSensor  # the ego helper's module; lazy

            self.sensor = PEMSensor()
        return self.sensor

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

    def _needs_frame(self, camera, pose, actors, min_px: float) -> bool:
        if min_px <= 0.0:
            return True
        from sitcov.perception._renderer import vehicles_in_view

        return vehicles_in_view(camera, pose, actors, min_px)

    def _map_ref(self) -> str:
        """The map's name if it is built in (portable across machines), else its file."""
        builtin = MAPS_DIR / f"{self.map.name}.yaml"
        return self.map.name if str(builtin) == self.map.source else self.map.source

    def _intsit(self, situation: Situation) -> dict[str, str]:
        value = situation.value("intsit", None)
        if value is None:
            return dict(DEFAULT_INTSIT)
        if not isinstance(value, Mapping) or "ego" not in value or "ov" not in value:
            raise ConfigError(
                field="intsit",
                value=value,
                expected="a mapping with 'ego' and 'ov' movements like 'L-B'",
            )
        return {
            "ego": str(value["ego"]),
            "ov": str(value["ov"]),
            "conflict": str(value.get("conflict", "")),
        }

    # --- the run ------------------------------------------------------------------------------

    def run(
        self, situation: Situation, av_stack: AVStack, seed: int, *, record: bool = False
    ) -> Outcome:
        """Simulate ``situation`` with ``av_stack`` driving the ego (deterministic per seed)."""
        seed = int(seed)
        rng = np.random.default_rng(seed)
        values = situation.values
        intsit = self._intsit(situation)
        wind_direction = float(rng.uniform(-math.pi, math.pi))
        cond = conditions_from_values(values, wind_direction=wind_direction, profile=self.physics)
        ov_rgb = ov_color(values, seed)  # own random stream: shifts no other draw
        vp = self.vehicle
        ov_dims = (vp.length, vp.width, vp.height)
        scen = self.map.scenario(intsit["ego"], intsit["ov"], vp.width, vp.width)
        er, orr = scen.ego_route, scen.ov_route
        ov_curv = orr.max_curvature
        e_xs, e_ys = er.xs, er.ys
        e_sin = [math.sin(h) for h in er.hs]
        e_cos = [math.cos(h) for h in er.hs]
        conflict = scen.conflict
        dt = self.dt
        n_max = int(math.ceil(self.sim_timeout / dt - 1e-9))
        # wind: OU gusts on the mean speed, drawn up front so the stream order is fixed
        gust_noise = rng.standard_normal(n_max + 1).tolist()
        phi = math.exp(-dt / GUST_TIME)
        gust_scale = GUST_INTENSITY * math.sqrt(1.0 - phi * phi)
        # carla profile: no wind force (the noise is drawn all the same: same streams)
        wind_mean = cond.wind_speed if self.wind and self.physics == "physical" else 0.0
        wind_k = 0.5 * AIR_DENSITY * SIDE_FORCE_COEFF * SIDE_AREA / vp.mass
        gust = GUST_INTENSITY * gust_noise[0]

        ex, ey, eh = er.point_at(0.0)
        ego = Vehicle(vp, ex, ey, eh)
        ox, oy, oh = orr.point_at(0.0)
        ov = Vehicle(vp, ox, oy, oh)
        adv_params = with_switch_distance(self.adversary, self.map.switch_distance(scen))
        adv = AdversaryController(adv_params, has_conflict=conflict is not None)
        s_conf_e = conflict.s_ego if conflict else math.inf
        s_conf_o = conflict.s_ov if conflict else math.inf
        zone_e = min(conflict.s_ego_end, s_conf_e + PET_ZONE) if conflict else math.inf
        zone_o = min(conflict.s_ov_end, s_conf_o + PET_ZONE) if conflict else math.inf

        camera = av_stack.camera
        info = RunInfo(
            dt=dt,
            route=er.points,
            goal=er.points[-1],
            map_name=self.map.name,
            camera=camera,
            seed=seed,
            situation=situation if self.grey_box else None,
        )
        av_stack.reset(info)
        sensor = self._get_sensor() if self.perception == "pem" else None
        if sensor is not None and hasattr(sensor, "reset"):
            sensor.reset(frame_dt=self.sensor_every * dt)  # per-run noise state (PEM)
        latched = False  # the stack's AEB has latched: it ignores perception from now on
        gate_px = self._gate_px(av_stack, camera) if sensor is None else 0.0
        half_l, half_w = 0.5 * vp.length, 0.5 * vp.width
        disc = 2.0 * math.sqrt(vp.length * vp.width / math.pi)
        diag2 = 2.0 * math.hypot(half_l, half_w)
        mu = cond.mu
        steer_max, lr, wb = vp.steer_max, vp.lr, vp.wheelbase
        # delays in whole control periods: frames wait in ``frames`` until their delivery
        # step, brake commands in ``brakes`` (pre-filled with "no brake")
        delay_p = round(self.perception_delay / dt)
        delay_b = round(self.brake_delay / dt)
        frames: deque[tuple[int, Any, Any]] = deque()
        brakes: deque[float] = deque([0.0] * delay_b)

        s_e = s_o = 0.0
        hint_e = hint_o = 0
        ov_active = True
        min_dist = math.inf
        min_ttc: float | None = None
        aeb_time: float | None = None
        enter_e = exit_e = enter_o = exit_o = None
        collision_speed: float | None = None
        max_lat = 0.0
        lane_mon = LaneDepartureMonitor(0.5 * (self.map.lane_width - vp.width) + LANE_TOLERANCE)
        left, right = self.map.clearance(er)
        road_mon = RoadDepartureMonitor(self.map.drivable_area, er.hs, left, right, half_l, half_w)
        monitors = (lane_mon, road_mon)
        switch_time: float | None = None
        switch_gap: float | None = None  # ego's distance to the conflict at the switch [m]
        prev_gap = math.inf
        clear: bool | None = None  # decided once the ego stands latched
        ego_rows: list[tuple[float, float, float, float, float]] = []
        ov_rows: list[tuple[float, float, float, float, float]] = []
        status, reason = "pass", "sim_timeout"
        t = 0.0
        k = 0
        while True:
            ego_speed = ego.speed
            if record:
                ego_rows.append((t, ego.x, ego.y, ego.yaw, ego_speed))
                if ov_active:
                    ov_rows.append((t, ov.x, ov.y, ov.yaw, ov.speed))
            # --- ego stack ------------------------------------------------------------
            detections = image = None
            if k % self.sensor_every == 0 and not latched:
                actors = (
                    (ActorView(Pose(ov.x, ov.y, ov.yaw), *ov_dims, ov.speed, ov_rgb),)
                    if ov_active
                    else ()
                )
                pose = Pose(ego.x, ego.y, ego.yaw)
                if sensor is not None:
                    detections = sensor.detect(pose, actors, cond, rng)
                elif self._needs_frame(camera, pose, actors, gate_px):
                    if self.frame_observer is not None:
                        self.frame_observer(camera, pose, actors, cond)
                    # one generator per frame: which frames are rendered changes no other
                    frame_rng = np.random.default_rng([seed, k])
                    image = self._frame(camera, pose, actors, cond, frame_rng)
                else:
                    detections = ()  # camera mode, no vehicle in view (see _needs_frame)
            if delay_p:
                if detections is not None or image is not None:
                    frames.append((k + delay_p, detections, image))
                detections = image = None
                if frames and frames[0][0] == k:
                    _, detections, image = frames.popleft()
            obs = Observation(t, EgoState(ego.x, ego.y, ego.yaw, ego_speed, t), detections, image)
            ctrl = av_stack.step(obs)
            if ctrl.info and ctrl.info.get("aeb"):
                if aeb_time is None:
                    aeb_time = t
                # camera mode: no more frames are rendered once the brake has latched
                # (Control.info["aeb"] promises the stack ignores perception from now on)
                latched = self.perception == "camera"
            # --- wind -----------------------------------------------------------------
            if wind_mean > 0.0:
                gust = phi * gust + gust_scale * gust_noise[k + 1]
                w = wind_mean * (1.0 + gust)
                ve = w * math.sin(wind_direction - ego.yaw)
                lat_e = wind_k * ve * abs(ve)
                vo = w * math.sin(wind_direction - ov.yaw)
                lat_o = wind_k * vo * abs(vo)
            else:
                lat_e = lat_o = 0.0
            # --- OV -------------------------------------------------------------------
            brk = 0.0
            if ov_active:
                ov_speed = ov.speed
                thr, brk = adv.command(s_conf_e - s_e, ego_speed, s_conf_o - s_o, ov_speed)
                if switch_time is None and adv.phase == "cruise":
                    switch_time, switch_gap = t, s_conf_e - s_e
                look = adv.lookahead(ov_speed)
                tx, ty, _ = orr.point_at(s_o + look)
                c, s = math.cos(ov.yaw), math.sin(ov.yaw)
                delta = pure_pursuit(ov.x - lr * c, ov.y - lr * s, ov.yaw, tx, ty, wb)
                ov.step(thr, brk, delta / steer_max, mu, lat_o, dt)
            brake = ctrl.brake
            if delay_b:
                brakes.append(brake)
                brake = brakes.popleft()
            ego.step(ctrl.throttle, brake, ctrl.steer, mu, lat_e, dt)
            t = (k + 1) * dt
            k += 1
            # --- bookkeeping ------------------------------------------------------------
            s_e, hint_e = er.track(ego.x, ego.y, hint_e)
            lat = -(ego.x - e_xs[hint_e]) * e_sin[hint_e] + (ego.y - e_ys[hint_e]) * e_cos[hint_e]
            for mon in monitors:
                mon.update(t, ego.x, ego.y, ego.yaw, hint_e, lat)
            lat = -lat if lat < 0.0 else lat
            if lat > max_lat:
                max_lat = lat
            if enter_e is None and s_e + half_l >= s_conf_e:
                enter_e = t
            if exit_e is None and s_e - half_l > zone_e:
                exit_e = t
            if ov_active:
                s_o, hint_o = orr.track(ov.x, ov.y, hint_o)
                if enter_o is None and s_o + half_l >= s_conf_o:
                    enter_o = t
                if exit_o is None and s_o - half_l > zone_o:
                    exit_o = t
                dx, dy = ov.x - ego.x, ov.y - ego.y
                gap = math.hypot(dx, dy)
                near = gap < diag2
                ego_box = ov_box = None
                # exact box distance only when it can beat the minimum (every 4th step
                # while far apart: < 3 m of closing in between cannot hide a minimum that
                # matters; the exact value is always computed when near)
                if gap - diag2 < min_dist and (gap < FAR or k & 3 == 0):
                    ego_box = (ego.x, ego.y, ego.yaw, half_l, half_w)
                    ov_box = (ov.x, ov.y, ov.yaw, half_l, half_w)
                    d = box_distance(ego_box, ov_box)
                    if d < min_dist:
                        min_dist = d
                ce, se_ = math.cos(ego.yaw), math.sin(ego.yaw)
                co, so_ = math.cos(ov.yaw), math.sin(ov.yaw)
                rvx = (ov.vx * co - ov.vy * so_) - (ego.vx * ce - ego.vy * se_)
                rvy = (ov.vx * so_ + ov.vy * co) - (ego.vx * se_ + ego.vy * ce)
                ttc = time_to_collision(dx, dy, rvx, rvy, disc)
                if ttc is not None and (min_ttc is None or ttc < min_ttc):
                    min_ttc = ttc
                if near:
                    if ego_box is None:
                        ego_box = (ego.x, ego.y, ego.yaw, half_l, half_w)
                        ov_box = (ov.x, ov.y, ov.yaw, half_l, half_w)
                    if overlap(ego_box, ov_box):
                        status, reason = "fail", "collision"
                        collision_speed = math.hypot(rvx, rvy)
                        break
                if s_o >= orr.length - GOAL_TOLERANCE:
                    ov_active = False  # the OV has left the map at the end of its leg
            else:
                gap = math.inf
            if s_e >= er.length - GOAL_TOLERANCE:
                status, reason = "pass", "goal"
                break
            if self.early_end and aeb_time is not None and ego.speed < STOPPED_SPEED:
                # the ego is latched at a standstill; the run is over when the OV can no
                # longer reach it: gone, driving away past the conflict zone, the ego is
                # short of the conflict zone on its lane, or the OV waits for an ego that
                # will never come (the paper's timing law then brakes it forever)
                # "clear": the stopped ego's box lies outside the corridor the OV will
                # still sweep (its remaining route, widened by half its width and a
                # tracking margin), and the road can hold the OV in its tightest curve
                # at its speed, so it cannot slide into the ego. Checked once: the ego
                # no longer moves.
                if clear is None and ov_active:
                    v_ov = max(ov.speed, self.adversary.cruise_speed)
                    clear = mu * G >= LANE_HOLD_MARGIN * v_ov * v_ov * ov_curv and (
                        corridor_gap(orr, s_o, (ego.x, ego.y, ego.yaw, half_l, half_w))
                        > half_w + CORRIDOR_MARGIN
                    )
                away = s_o - half_l > zone_o and gap > prev_gap
                stuck = (
                    ov_active and adv.phase != "cruise" and brk > 0.0 and (ov.speed < STOPPED_SPEED)
                )
                if not ov_active or clear or away or stuck:
                    status, reason = "pass", "stopped"
                    break
            prev_gap = gap
            if k >= n_max:
                break

        pet = post_encroachment_time((enter_e, exit_e), (enter_o, exit_o), reason == "collision")
        metrics = {
            "steps": k,
            "mu": mu,
            "physics": self.physics,
            "perception_delay": self.perception_delay,
            "brake_delay": self.brake_delay,
            "visibility": cond.visibility if math.isfinite(cond.visibility) else None,
            "wind_direction": wind_direction,
            "ego_route": intsit["ego"],
            "ov_route": intsit["ov"],
            "conflict_label": intsit["conflict"],
            "conflict_point": list(conflict.point) if conflict else None,
            "ov_switch_time": switch_time,
            "ov_switch_distance": adv_params.switch_distance,
            "ego_gap_at_switch": switch_gap,
            "ego_max_lateral_offset": max_lat,
            "ego_left_lane": lane_mon.time is not None,
            "lane_departure_time": None if lane_mon.time is None else round(lane_mon.time, 10),
            "road_departure_time": None if road_mon.time is None else round(road_mon.time, 10),
            "ego_final_speed": ego.speed,
        }
        trace = None
        if record:
            ego_rows.append((t, ego.x, ego.y, ego.yaw, ego.speed))
            if ov_active:
                ov_rows.append((t, ov.x, ov.y, ov.yaw, ov.speed))
            trace = Trace(
                ego=ego_rows,
                ov=ov_rows,
                meta={
                    "map": self._map_ref(),
                    "ego_route": [list(p) for p in er.points],
                    "ov_route": [list(p) for p in orr.points],
                    "conflict_point": list(conflict.point) if conflict else None,
                    "collision_point": [0.5 * (ego.x + ov.x), 0.5 * (ego.y + ov.y)]
                    if reason == "collision"
                    else None,
                    "length": vp.length,
                    "width": vp.width,
                    "dt": dt,
                },
            )
        return Outcome(
            status=status,
            end_reason=reason,
            sim_time=round(t, 10),
            collision=reason == "collision",
            collision_time=round(t, 10) if reason == "collision" else None,
            collision_speed=collision_speed,
            min_distance=min_dist if math.isfinite(min_dist) else None,
            min_ttc=min_ttc,
            pet=pet,
            aeb_fired=aeb_time is not None,
            aeb_time=aeb_time,
            metrics=metrics,
            trace=trace,
        )
