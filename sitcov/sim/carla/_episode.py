"""One CARLA run after spawning: sensors, the synchronous step loop, the outcome.

Order of a step (synchronous mode): the previous ``world.tick()`` returned frame ``f``;
read both vehicles' states and, every ``camera_every`` ticks, the camera image of frame
``f``; the stack turns the observation into a control; the OV driver commands the OV;
``world.tick()`` advances 0.05 s. Collision events arrive through the collision sensor's
callback during the tick and are checked after it.

Road departure: after each tick a :class:`RoadMonitor` asks the map whether each corner of
the ego's bounding box lies on a driving lane (``Map.get_waypoint(location,
project_to_road=False)`` is None off the road: sidewalk, shoulder, kerb, grass) and records
the first time one does not, as ``metrics["road_departure_time"]``. Lane departure is not
reported by this backend (``lane_departure_time`` is None); see docs/campaigns.md.

Route progress: :class:`sitcov.sim._progress.RouteProgress` follows the ego along its
route each tick (route completion, time to goal, standstill, route incomplete); a
collision with the ego below ``STATIONARY_SPEED`` is ``ego_stationary``. ``blocked_time``
is not reported by this backend (None).
"""

from __future__ import annotations

import math
import queue
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from sitcov.sim._base import Outcome, Trace
from sitcov.sim._judge import STATIONARY_SPEED
from sitcov.sim._progress import RouteProgress
from sitcov.sim.carla._geometry import carla_transform, steer_to_carla
from sitcov.sim.carla._metrics import relative_speed
from sitcov.sim.carla._state import image_to_rgb, make_observation, vehicle_state
from sitcov.sim.embedded._collision import contact_point

#: The ego counts as halted below this speed [m/s]; after its AEB latched, a halt of
#: HALT_TIME [s] with the OV at its goal ends the run early (``stopped``): nothing can change
#: any more (an AEB that releases never ends a run early).
HALT_SPEED = 0.1
HALT_TIME = 2.0

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.sim.carla._actors import Scene
    from sitcov.sim.carla._metrics import MetricTracker
    from sitcov.sim.carla._ovdriver import OVDriver


class StackFailure(Exception):
    """Wraps an exception raised by the AV stack, so it is not mistaken for a server error."""


@dataclass(frozen=True)
class EpisodeSettings:
    """What the step loop needs of the backend: the client module and the loaded map, the
    step, the time limits, the camera rate and the map file's goal tolerance."""

    carla: Any
    carla_map: Any
    map_name: str
    goal_tolerance: float
    dt: float
    timeout: float
    sim_timeout: float
    camera_every: int


class RoadMonitor:
    """Records the first time a corner of the ego's box is off every driving lane."""

    def __init__(self, carla: Any, carla_map: Any) -> None:
        self.carla, self.map = carla, carla_map
        self.time: float | None = None

    def update(self, t: float, actor: Any) -> None:
        """Check the four corners of ``actor``'s bounding box (CARLA frame)."""
        if self.time is not None:
            return
        tf = actor.get_transform()
        ext = actor.bounding_box.extent
        yaw = math.radians(tf.rotation.yaw)
        c, s = math.cos(yaw), math.sin(yaw)
        x, y, z = tf.location.x, tf.location.y, tf.location.z
        for a, b in ((ext.x, ext.y), (ext.x, -ext.y), (-ext.x, -ext.y), (-ext.x, ext.y)):
            corner = self.carla.Location(x=x + a * c - b * s, y=y + a * s + b * c, z=z)
            if self.map.get_waypoint(corner, project_to_road=False) is None:
                self.time = t
                return


@dataclass
class _Tick:
    """What the loop knows after one tick: states, the road user hit, the stop reason."""

    t: float
    ego: Any
    ov: Any
    hit: tuple[str, str, Any] | None = None


class Episode:
    """The step loop of one run; the backend owns spawning and cleanup.

    Args:
        settings: what the loop needs of the backend.
        world, stack, ego: the CARLA world, the AV stack and the ego vehicle.
        ov: the primary other road user's CARLA actor (the OV driver's car, or the twin of
            a pedestrian or cyclist OV).
        record: keep the trajectories.
        scene: the situation's further road users (None in the paper's two-car scene).
        ov_kind: the primary road user's kind.
        route: the ego's route in the sitcov frame (route progress facts, RouteProgress).
    """

    def __init__(
        self,
        settings: EpisodeSettings,
        world: Any,
        stack: AVStack,
        ego: Any,
        ov: Any,
        *,
        record: bool = False,
        scene: Scene | None = None,
        ov_kind: str = "car",
        route: list[tuple[float, float]] | None = None,
    ) -> None:
        self.settings, self.world, self.stack = settings, world, stack
        self.ego, self.ov = ego, ov
        self.record, self.scene = record, scene
        self.images: queue.Queue = queue.Queue()
        self.collisions: list[tuple[int, int, str]] = []  # (frame, other actor id, type)
        #: CARLA id -> (name, kind, actor) of every road user the ego may hit
        self.road_users: dict[int, tuple[str, str, Any]] = {ov.id: ("ov", ov_kind, ov)}
        if scene is not None:
            for actor_id, twin in scene.by_id().items():
                self.road_users[actor_id] = (twin.name, twin.actor.kind, twin.carla_actor)
        self.other_hits: list[str] = []
        self.rows: tuple[list, list] = ([], [])
        self.route: list[tuple[float, float]] = list(route or ())
        self.latched = False  # the stack's AEB latched (Control.info["aeb"])
        self.progress: RouteProgress | None = None

    def attach_sensors(self, library: Any, sensors: list[Any]) -> None:
        """Spawn the ego's RGB camera (the stack's CameraSpec) and collision sensor.

        Sensors are appended to ``sensors`` as soon as they exist, so cleanup sees them
        even if a later call fails.
        """
        carla, cam = self.settings.carla, self.stack.camera
        bp = library.find("sensor.camera.rgb")
        bp.set_attribute("image_size_x", str(int(cam.width)))
        bp.set_attribute("image_size_y", str(int(cam.height)))
        bp.set_attribute("fov", str(float(cam.fov_deg)))
        bp.set_attribute("sensor_tick", "0.0")  # a frame every tick; the stack gets every k-th
        camera = self.world.spawn_actor(
            bp, carla_transform(carla, cam.mount_x, 0.0, cam.mount_z), attach_to=self.ego
        )
        sensors.append(camera)
        camera.listen(self.images.put)
        collision = self.world.spawn_actor(
            library.find("sensor.other.collision"),
            carla_transform(carla, 0.0, 0.0),
            attach_to=self.ego,
        )
        sensors.append(collision)
        collision.listen(self._on_collision)

    def _on_collision(self, event: Any) -> None:
        other = event.other_actor
        self.collisions.append((event.frame, other.id, other.type_id))

    def _image(self, frame: int) -> Any:
        """The camera image of ``frame`` (older frames are dropped)."""
        while True:
            try:
                image = self.images.get(timeout=self.settings.timeout)
            except queue.Empty:
                raise RuntimeError(
                    f"camera frame {frame} not received within {self.settings.timeout:g}s"
                ) from None
            if image.frame >= frame:
                return image

    def drive(
        self, driver: OVDriver | None, metrics: MetricTracker, goal: tuple[float, float]
    ) -> Outcome:
        """Step until collision, goal, early stop or the simulated time limit.

        ``driver`` drives a car OV (None: the OV is a twin of the scene); ``metrics``
        measures the ego against the primary road user; ``goal`` is the ego's (CARLA frame).
        """
        settings = self.settings
        road = RoadMonitor(settings.carla, settings.carla_map)
        self.progress = RouteProgress(self.route, settings.goal_tolerance, settings.sim_timeout)
        frame = self.world.tick(seconds=settings.timeout)
        step, halted = 0, 0.0
        while True:
            now = self._observe(step * settings.dt, metrics, road)
            self.progress.update(now.t, now.ego.x, now.ego.y, now.ego.speed, settings.dt)
            image = self._image(frame)
            standing = self.latched and now.ego.speed < HALT_SPEED
            halted = halted + settings.dt if standing else 0.0
            reason = self._end_reason(now, goal, driver, halted)
            if reason is not None:
                break
            self._command(now, image, step, metrics, driver)
            frame = self.world.tick(seconds=settings.timeout)
            step += 1
        return self._outcome(now, reason, metrics, road, step)

    def _observe(self, t: float, metrics: MetricTracker, road: RoadMonitor) -> _Tick:
        """Read every state of this tick, the collisions and the metrics."""
        ego, ov = vehicle_state(self.ego), vehicle_state(self.ov)
        road.update(t, self.ego)
        if self.record:
            self.rows[0].append((t, ego.x, ego.y, ego.yaw, ego.speed))
            self.rows[1].append((t, ov.x, ov.y, ov.yaw, ov.speed))
        now = _Tick(t, ego, ov, self._hit())
        metrics.update(t, ego, ov)
        if self.scene is not None:
            self.scene.observe(t, ego, self.record)
        return now

    def _hit(self) -> tuple[str, str, Any] | None:
        """The first road user the ego hit since the last tick; other hits are kept."""
        hit = None
        for _, other_id, type_id in self.collisions:
            user = self.road_users.get(other_id)
            if user is None:
                self.other_hits.append(type_id)
            elif hit is None:
                hit = user
        self.collisions.clear()
        return hit

    def _end_reason(
        self, now: _Tick, goal: tuple[float, float], driver: OVDriver | None, halted: float
    ) -> str | None:
        settings = self.settings
        if now.hit is not None:
            return "collision"
        if math.hypot(now.ego.x - goal[0], now.ego.y + goal[1]) <= settings.goal_tolerance:
            return "goal"
        if halted >= HALT_TIME and self._others_done(now, driver):
            return "stopped"
        if now.t >= settings.sim_timeout - 1e-9:
            return "sim_timeout"
        return None

    def _others_done(self, now: _Tick, driver: OVDriver | None) -> bool:
        """Nothing else will move towards the ego: the OV at its goal, every twin done."""
        ov_done = driver is None or driver.at_goal(now.ov.x, now.ov.y)
        return ov_done and (self.scene is None or self.scene.done())

    def _command(
        self,
        now: _Tick,
        image: Any,
        step: int,
        metrics: MetricTracker,
        driver: OVDriver | None,
    ) -> None:
        """The stack's control for the ego, the OV driver's, and every twin's."""
        settings, carla = self.settings, self.settings.carla
        rgb = image_to_rgb(image) if step % settings.camera_every == 0 else None
        try:
            control = self.stack.step(make_observation(now.t, now.ego, rgb))
        except Exception as exc:
            raise StackFailure() from exc
        info = control.info
        if (info.get("aeb") or info.get("aeb_active")) and metrics.aeb_time is None:
            metrics.aeb_time = float(info.get("aeb_time", now.t))
        self.latched = self.latched or bool(info.get("aeb"))
        self.ego.apply_control(
            carla.VehicleControl(
                throttle=_clip01(control.throttle),
                steer=steer_to_carla(control.steer),
                brake=_clip01(control.brake),
            )
        )
        if driver is not None:
            ego, ov = now.ego, now.ov
            throttle, brake, steer = driver.command(
                now.t, (ego.x, ego.y), ego.speed, (ov.x, ov.y, ov.yaw), ov.speed
            )
            self.ov.apply_control(
                carla.VehicleControl(throttle=throttle, steer=steer_to_carla(steer), brake=brake)
            )
        if self.scene is not None:
            self.scene.act(carla)

    def _outcome(
        self, now: _Tick, reason: str, metrics: MetricTracker, road: RoadMonitor, step: int
    ) -> Outcome:
        hit = now.hit
        name = hit[0] if hit is not None else None
        collision_speed = point = None
        if hit is not None:
            other = now.ov if name == "ov" else self.scene.states[name]  # type: ignore[union-attr]
            collision_speed = relative_speed(now.ego, other)
            point = list(contact_point(_box(now.ego), _box(other)))
        extra: dict[str, Any] = {
            "ticks": step,
            "other_collisions": sorted(set(self.other_hits)),
            "road_departure_time": road.time,
            "lane_departure_time": None,
            **self.progress.facts(reason, self.latched),
            "ego_collision_speed": now.ego.speed if hit is not None else None,
            "ego_stationary": hit is not None and now.ego.speed < STATIONARY_SPEED,
            # where the ego hit (sitcov frame, the boxes' overlap), its heading, the kind
            "collision_point": point,
            "collision_heading": now.ego.yaw if hit is not None else None,
            "collision_kind": (hit[1] if hit is not None else None)
            if self.scene is not None
            else ("car" if hit is not None else None),
            "max_drac": metrics.max_drac,  # the OV's (docs/metrics.md)
        }
        if self.scene is not None:
            extra["actors"] = self.scene.metrics(name)
            extra["collision_actor"] = name
            extra["collision_kind"] = hit[1] if hit is not None else None
        return Outcome(
            status="fail" if hit is not None else "pass",
            end_reason=reason,
            sim_time=now.t,
            collision=hit is not None,
            collision_time=now.t if hit is not None else None,
            collision_speed=collision_speed,
            min_distance=None if math.isinf(metrics.min_distance) else metrics.min_distance,
            min_ttc=metrics.min_ttc,
            pet=metrics.pet(collided=name == "ov"),
            aeb_fired=metrics.aeb_time is not None,
            aeb_time=metrics.aeb_time,
            metrics=extra,
            trace=self._trace(metrics.ov_route) if self.record else None,
        )

    def _trace(self, ov_route: list[tuple[float, float]]) -> Trace:
        """The rows; with a scene also every actor's rows, kind, size and route (a car OV
        with its CARLA box and lane route)."""
        meta: dict[str, Any] = {"map": self.settings.map_name, "dt": self.settings.dt}
        if self.scene is None:
            return Trace(ego=self.rows[0], ov=self.rows[1], meta=meta)
        ext = self.ov.bounding_box.extent
        car = {"kind": "car", "length": 2.0 * ext.x, "width": 2.0 * ext.y}
        meta["actors"] = {"ov": {**car, "route": [list(p) for p in ov_route]}}
        meta["actors"].update(self.scene.trace_meta())  # a pedestrian or cyclist OV wins
        actors = {"ov": self.rows[1], **self.scene.rows}
        return Trace(ego=self.rows[0], ov=self.rows[1], meta=meta, actors=actors)


def _clip01(value: float) -> float:
    return max(0.0, min(1.0, float(value)))


def _box(state: Any) -> tuple[float, float, float, float, float]:
    """A vehicle state's box (x, y, yaw, half length, half width) [m, rad]."""
    return (state.x, state.y, state.yaw, state.half_length, state.half_width)
