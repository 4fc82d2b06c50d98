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
"""

from __future__ import annotations

import math
import queue
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from sitcov.sim._base import Outcome, Trace
from sitcov.sim.carla._geometry import carla_transform, steer_to_carla
from sitcov.sim.carla._metrics import relative_speed
from sitcov.sim.carla._state import image_to_rgb, make_observation, vehicle_state

#: The ego counts as halted below this speed [m/s]; after AEB, a halt of HALT_TIME [s] with
#: the OV at its goal ends the run early (``stopped``): nothing can change any more.
HALT_SPEED = 0.1
HALT_TIME = 2.0

if TYPE_CHECKING:
    from sitcov.av import AVStack
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


class Episode:
    """The step loop of one run; the backend owns spawning and cleanup."""

    def __init__(
        self,
        settings: EpisodeSettings,
        world: Any,
        stack: AVStack,
        ego: Any,
        ov: Any,
        *,
        record: bool = False,
    ) -> None:
        self.settings, self.world, self.stack = settings, world, stack
        self.ego, self.ov = ego, ov
        self.record = record
        self.images: queue.Queue = queue.Queue()
        self.collisions: list[tuple[int, int, str]] = []  # (frame, other actor id, type)
        self.ov_id = ov.id

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

    def drive(self, driver: OVDriver, metrics: MetricTracker, goal: tuple[float, float]) -> Outcome:
        """Step until collision, goal, early stop or the simulated time limit."""
        settings, world, carla = self.settings, self.world, self.settings.carla
        dt, timeout = settings.dt, settings.timeout
        gx, gy = goal[0], -goal[1]
        tolerance = settings.goal_tolerance
        ego_rows: list[tuple[float, float, float, float, float]] = []
        ov_rows: list[tuple[float, float, float, float, float]] = []
        other_hits: list[str] = []
        frame = world.tick(seconds=timeout)
        step, t, halted = 0, 0.0, 0.0
        status, reason = "pass", "sim_timeout"
        collision_time = collision_speed = None
        aeb_fired = False
        road = RoadMonitor(carla, settings.carla_map)
        while True:
            ego, ov = vehicle_state(self.ego), vehicle_state(self.ov)
            road.update(t, self.ego)
            image = self._image(frame)
            if self.record:
                ego_rows.append((t, ego.x, ego.y, ego.yaw, ego.speed))
                ov_rows.append((t, ov.x, ov.y, ov.yaw, ov.speed))
            hit_ov = False
            for _, other_id, type_id in self.collisions:
                if other_id == self.ov_id:
                    hit_ov = True
                else:
                    other_hits.append(type_id)
            self.collisions.clear()
            metrics.update(t, ego, ov)
            if hit_ov:
                status, reason = "fail", "collision"
                collision_time, collision_speed = t, relative_speed(ego, ov)
                break
            if math.hypot(ego.x - gx, ego.y - gy) <= tolerance:
                reason = "goal"
                break
            halted = halted + dt if (aeb_fired and ego.speed < HALT_SPEED) else 0.0
            if halted >= HALT_TIME and driver.at_goal(ov.x, ov.y):
                reason = "stopped"
                break
            if t >= settings.sim_timeout - 1e-9:
                break
            rgb = image_to_rgb(image) if step % settings.camera_every == 0 else None
            try:
                control = self.stack.step(make_observation(t, ego, rgb))
            except Exception as exc:
                raise StackFailure() from exc
            if control.info.get("aeb") and metrics.aeb_time is None:
                aeb_fired = True
                metrics.aeb_time = float(control.info.get("aeb_time", t))
            self.ego.apply_control(
                carla.VehicleControl(
                    throttle=_clip01(control.throttle),
                    steer=steer_to_carla(control.steer),
                    brake=_clip01(control.brake),
                )
            )
            throttle, brake, steer = driver.command(
                t, (ego.x, ego.y), ego.speed, (ov.x, ov.y, ov.yaw), ov.speed
            )
            self.ov.apply_control(
                carla.VehicleControl(throttle=throttle, steer=steer_to_carla(steer), brake=brake)
            )
            frame = world.tick(seconds=timeout)
            step += 1
            t = step * dt
        trace = None
        if self.record:
            trace = Trace(ego=ego_rows, ov=ov_rows, meta={"map": settings.map_name, "dt": dt})
        return Outcome(
            status=status,
            end_reason=reason,
            sim_time=t,
            collision=status == "fail",
            collision_time=collision_time,
            collision_speed=collision_speed,
            min_distance=None if math.isinf(metrics.min_distance) else metrics.min_distance,
            min_ttc=metrics.min_ttc,
            pet=metrics.pet(collided=collision_time is not None),
            aeb_fired=metrics.aeb_time is not None,
            aeb_time=metrics.aeb_time,
            metrics={
                "ticks": step,
                "other_collisions": sorted(set(other_hits)),
                "road_departure_time": road.time,
                "lane_departure_time": None,
            },
            trace=trace,
        )


def _clip01(value: float) -> float:
    return max(0.0, min(1.0, float(value)))
