"""An in-memory stand-in for the ``carla`` client: exactly the surface the adapter uses.

``FakeCarla(server)`` behaves like the ``carla`` module for :class:`CarlaBackend`
(``carla_module=``): a client connects to the :class:`FakeServer`, which keeps the world
settings, weather, actors, a lane graph built from a map file (straight lanes from every
spawn point to the junction and from the junction to every goal), simple kinematic
vehicles, walkers that walk as commanded, camera frames and collision events (with vehicles
and walkers), and logs every call that changes state.
Public members of the fake classes are exactly those of ``_surface.SURFACE`` (a test
checks it); test hooks live on :class:`FakeServer`.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

#: Default tyre friction of a CARLA wheel (vehicle blueprints use ~3.5).
BASE_TIRE_FRICTION = 3.5
_WHEELBASE = 2.8  # [m]


class Vector3D:
    def __init__(self, x: float = 0.0, y: float = 0.0, z: float = 0.0) -> None:
        self.x, self.y, self._z = float(x), float(y), float(z)


class Location(Vector3D):
    @property
    def z(self) -> float:
        return self._z


class Rotation:
    def __init__(self, pitch: float = 0.0, yaw: float = 0.0, roll: float = 0.0) -> None:
        self._pitch, self.yaw, self._roll = float(pitch), float(yaw), float(roll)


class Transform:
    def __init__(self, location: Location | None = None, rotation: Rotation | None = None):
        self.location = location or Location()
        self.rotation = rotation or Rotation()


class BoundingBox:
    def __init__(self, extent: Vector3D) -> None:
        self.extent = extent


class WorldSettings:
    def __init__(self, synchronous_mode: bool = False, fixed_delta_seconds: Any = None) -> None:
        self.synchronous_mode = synchronous_mode
        self.fixed_delta_seconds = fixed_delta_seconds


class WeatherParameters:
    def __init__(self, **kwargs: float) -> None:
        self._values = {k: float(v) for k, v in kwargs.items()}


class VehicleControl:
    def __init__(self, throttle: float = 0.0, steer: float = 0.0, brake: float = 0.0) -> None:
        self._values = (float(throttle), float(steer), float(brake))


class WalkerControl:
    def __init__(self, direction: Vector3D | None = None, speed: float = 0.0) -> None:
        d = direction or Vector3D(1.0, 0.0, 0.0)
        self._direction, self._speed = (d.x, d.y), float(speed)


class WheelPhysicsControl:
    def __init__(self, tire_friction: float = 2.0, max_steer_angle: float = 70.0) -> None:
        self.tire_friction = tire_friction
        self.max_steer_angle = max_steer_angle


class VehiclePhysicsControl:
    def __init__(self, wheels: list[WheelPhysicsControl] | None = None) -> None:
        self.wheels = wheels or []


class Image:
    def __init__(self, frame: int, width: int, height: int, raw_data: bytes) -> None:
        self.frame, self.width, self.height, self.raw_data = frame, width, height, raw_data


class CollisionEvent:
    def __init__(self, frame: int, other_actor: Actor) -> None:
        self.frame, self.other_actor = frame, other_actor


class ActorAttribute:
    def __init__(self, value: str) -> None:
        self._value = value

    def as_int(self) -> int:
        return int(self._value)


class ActorBlueprint:
    def __init__(self, blueprint_id: str, attributes: dict[str, str]) -> None:
        self._id, self._attributes = blueprint_id, dict(attributes)

    def has_attribute(self, name: str) -> bool:
        return name in self._attributes

    def get_attribute(self, id: str) -> ActorAttribute:  # noqa: A002 - carla's keyword
        if id not in self._attributes:
            raise IndexError(f"blueprint {self._id!r} has no attribute {id!r}")
        return ActorAttribute(self._attributes[id])

    def set_attribute(self, name: str, value: str) -> None:
        if name not in self._attributes or not isinstance(value, str):
            raise IndexError(f"blueprint {self._id!r} has no attribute {name!r} (or not a str)")
        self._attributes[name] = value


_BLUEPRINTS = {
    "sensor.camera.rgb": {
        "image_size_x": "800",
        "image_size_y": "600",
        "fov": "90",
        "sensor_tick": "0.0",
    },
    "sensor.other.collision": {},
    "static.trigger.friction": {
        "friction": "3.5",
        "extent_x": "100",
        "extent_y": "100",
        "extent_z": "100",
    },
}


#: Two-wheeled vehicle blueprints of CARLA 0.9.x (bicycles); other ``vehicle.*`` have 4 wheels.
TWO_WHEELERS = ("vehicle.diamondback.century", "vehicle.gazelle.omafiets", "vehicle.bh.crossbike")
#: Half extents [m] of the fake's actors by blueprint family (CARLA reports its own).
EXTENTS = {"walker": (0.25, 0.25, 0.9), "bicycle": (0.9, 0.3, 0.85), "car": (2.4, 1.0, 0.75)}


class BlueprintLibrary:
    def find(self, id: str) -> ActorBlueprint:  # noqa: A002 - carla's keyword
        if id.startswith("vehicle."):
            wheels = "2" if id in TWO_WHEELERS else "4"
            return ActorBlueprint(id, {"role_name": "autopilot", "number_of_wheels": wheels})
        if id.startswith("walker.pedestrian."):
            return ActorBlueprint(id, {"role_name": "pedestrian", "is_invincible": "true"})
        if id not in _BLUEPRINTS:
            raise IndexError(f"blueprint {id!r} not found")
        return ActorBlueprint(id, _BLUEPRINTS[id])


class Actor:
    def __init__(
        self,
        server: FakeServer,
        blueprint: ActorBlueprint,
        transform: Transform,
        parent: Actor | None,
    ):
        server._next_id += 1
        self.id = server._next_id
        self.type_id = blueprint._id
        family = (
            "walker"
            if self.type_id.startswith("walker.")
            else ("bicycle" if self.type_id in TWO_WHEELERS else "car")
        )
        self.bounding_box = BoundingBox(Vector3D(*EXTENTS[family]))
        self._server, self._parent = server, parent
        self._attributes = blueprint._attributes
        self._x, self._y, self._yaw = (
            transform.location.x,
            transform.location.y,
            transform.rotation.yaw,
        )
        self._speed = 0.0

    def get_transform(self) -> Transform:
        return Transform(Location(self._x, self._y, 0.0), Rotation(yaw=self._yaw))

    def get_velocity(self) -> Vector3D:
        rad = math.radians(self._yaw)
        return Vector3D(self._speed * math.cos(rad), self._speed * math.sin(rad), 0.0)

    def destroy(self) -> bool:
        server = self._server
        server.log.append(("destroy", self.id))
        if isinstance(self, Sensor) and self._callback is not None:
            server.log.append(("destroy_while_listening", self.id))
        return server._actors.pop(self.id, None) is not None


class Vehicle(Actor):
    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self._control = (0.0, 0.0, 0.0)
        self._wheels = [
            WheelPhysicsControl(BASE_TIRE_FRICTION, 70.0 if i < 2 else 0.0) for i in range(4)
        ]

    def apply_control(self, control: VehicleControl) -> None:
        self._control = control._values

    def get_physics_control(self) -> VehiclePhysicsControl:
        return VehiclePhysicsControl(
            [WheelPhysicsControl(w.tire_friction, w.max_steer_angle) for w in self._wheels]
        )

    def apply_physics_control(self, physics_control: VehiclePhysicsControl) -> None:
        self._server.log.append(
            ("physics", self.id, [w.tire_friction for w in physics_control.wheels])
        )
        if not self._server.ignore_physics:
            self._wheels = [
                WheelPhysicsControl(w.tire_friction, w.max_steer_angle)
                for w in physics_control.wheels
            ]

    def _step(self, dt: float) -> None:
        throttle, steer, brake = self._control
        grip = min(1.0, self._wheels[0].tire_friction / BASE_TIRE_FRICTION)
        accel = 4.0 * throttle - 8.0 * grip * brake
        self._speed = max(0.0, self._speed + accel * dt)
        yaw_rate = self._speed / _WHEELBASE * math.tan(math.radians(steer * 70.0))
        self._yaw += math.degrees(yaw_rate * dt)
        rad = math.radians(self._yaw)
        self._x += self._speed * math.cos(rad) * dt
        self._y += self._speed * math.sin(rad) * dt


class Walker(Actor):
    """A pedestrian: walks at the commanded speed along the commanded direction."""

    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self._walk = (0.0, 0.0, 0.0)  # direction x, y and speed

    def apply_control(self, control: WalkerControl) -> None:
        (dx, dy), speed = control._direction, control._speed
        norm = math.hypot(dx, dy)
        if norm > 0.0:
            self._walk = (dx / norm, dy / norm, speed)
        self._server.log.append(("walker_control", self.id, dx, dy, speed))

    def _step(self, dt: float) -> None:
        dx, dy, speed = self._walk
        self._speed = speed
        if speed > 0.0:
            self._yaw = math.degrees(math.atan2(dy, dx))
            self._x += speed * dx * dt
            self._y += speed * dy * dt


class Sensor(Actor):
    def __init__(self, *args: Any) -> None:
        super().__init__(*args)
        self._callback: Any = None

    def listen(self, callback: Any) -> None:
        self._server.log.append(("listen", self.id))
        self._callback = callback

    def stop(self) -> None:
        self._server.log.append(("stop", self.id))
        self._callback = None


class Waypoint:
    def __init__(self, server: FakeServer, lane: int, s: float) -> None:
        self._server, self._lane = server, lane
        start, end, _ = server._lanes[lane]
        length = math.dist(start, end)
        self.road_id, self.section_id, self.lane_id, self.s = lane, 0, -1, min(s, length)
        f = self.s / length if length else 0.0
        self.transform = Transform(
            Location(start[0] + f * (end[0] - start[0]), start[1] + f * (end[1] - start[1]), 0.0),
            Rotation(yaw=math.degrees(math.atan2(end[1] - start[1], end[0] - start[0]))),
        )

    def next(self, distance: float) -> list[Waypoint]:
        start, end, successors = self._server._lanes[self._lane]
        length = math.dist(start, end)
        if self.s + distance <= length + 1e-9:
            return [Waypoint(self._server, self._lane, self.s + distance)]
        rest = self.s + distance - length
        return [Waypoint(self._server, lane, rest) for lane in successors]


class Map:
    def __init__(self, server: FakeServer, name: str) -> None:
        self._server, self.name = server, name

    def get_waypoint(self, location: Location, project_to_road: bool = True) -> Waypoint | None:
        if not project_to_road and not self._on_road(location.x, location.y):
            return None  # as CARLA: no driving lane at this location
        best, best_d = 0, math.inf
        for i, (start, _end, _) in enumerate(self._server._lanes):
            d = math.hypot(start[0] - location.x, start[1] - location.y)
            if d < best_d:
                best, best_d = i, d
        return Waypoint(self._server, best, 0.0)

    def _on_road(self, x: float, y: float) -> bool:
        """Within ``FakeServer.road_half_width`` of a lane of the fake lane graph."""
        for (ax, ay), (bx, by), _ in self._server._lanes:
            dx, dy = bx - ax, by - ay
            f = ((x - ax) * dx + (y - ay) * dy) / max(dx * dx + dy * dy, 1e-12)
            f = min(1.0, max(0.0, f))
            if math.hypot(ax + f * dx - x, ay + f * dy - y) <= self._server.road_half_width:
                return True
        return False


class World:
    def __init__(self, server: FakeServer) -> None:
        self._server = server

    def get_settings(self) -> WorldSettings:
        s = self._server._settings
        return WorldSettings(s.synchronous_mode, s.fixed_delta_seconds)

    def apply_settings(self, settings: WorldSettings) -> int:
        server = self._server
        server._check()
        server.log.append(
            ("apply_settings", settings.synchronous_mode, settings.fixed_delta_seconds)
        )
        server._settings = WorldSettings(settings.synchronous_mode, settings.fixed_delta_seconds)
        return server.frame

    def set_weather(self, weather: WeatherParameters) -> None:
        self._server.log.append(("set_weather", dict(weather._values)))
        self._server.weather = dict(weather._values)

    def get_map(self) -> Map:
        self._server.log.append(("get_map",))
        return Map(self._server, self._server.map_name)

    def get_blueprint_library(self) -> BlueprintLibrary:
        return BlueprintLibrary()

    def spawn_actor(
        self, blueprint: ActorBlueprint, transform: Transform, attach_to: Actor | None = None
    ) -> Actor:
        server = self._server
        server._check()
        family = blueprint._id.split(".", 1)[0]
        cls = {"vehicle": Vehicle, "sensor": Sensor, "walker": Walker}.get(family, Actor)
        actor = cls(server, blueprint, transform, attach_to)
        if cls is Vehicle:
            server._episode_ticks = 0
        server._actors[actor.id] = actor
        server.log.append(("spawn", blueprint._id, actor.id, dict(blueprint._attributes)))
        return actor

    def tick(self, seconds: float = 10.0) -> int:
        return self._server._tick()


class FakeServer:
    """The simulated server and the tests' handle on it.

    Args:
        carla_map: a :class:`~sitcov.sim.carla.CarlaMap`; its spawn points and goals make
            the lane graph.
        map_name: the map the server has loaded at start.
    """

    def __init__(self, carla_map: Any, map_name: str = "Carla/Maps/Town10HD_Opt") -> None:
        self.map_name = self.start_map = map_name
        self.reachable = True
        #: a dead server (see :meth:`kill`) comes back once this file exists (tests point a
        #: ``--carla-launch`` command at it, e.g. ``touch FILE``); the file is then removed
        self.revive_file: Path | None = None
        self.kills = 0
        self.ignore_physics = False
        self.fail_ticks = 0  # the next N ticks raise a time-out
        self.collide_at_tick: int | None = None  # counted from the last vehicle spawn
        # car centres closer than this collide [m]; walkers and bicycles collide when their
        # boxes touch the ego's
        self.collision_radius = 3.0
        self.road_half_width = 3.5  # driving lanes reach this far from a lane's line [m]
        self.log: list[tuple] = []
        self.weather: dict[str, float] = {}
        self.frame = 0
        self.ticks = 0
        self._episode_ticks = 0
        self.connections = 0
        self._settings = WorldSettings(False, None)
        self._actors: dict[int, Actor] = {}
        self._next_id = 100
        self._frame_bytes: dict[tuple[int, int], bytes] = {}
        self._lanes = _lane_graph(carla_map)

    @property
    def actors(self) -> dict[int, Actor]:
        """Live actors by id."""
        return self._actors

    @property
    def settings(self) -> WorldSettings:
        """Current world settings."""
        return self._settings

    def kill(self) -> None:
        """The server process dies: unreachable, its world (actors, settings, town) gone."""
        self.reachable = False
        self._actors.clear()
        self._settings = WorldSettings(False, None)
        self.map_name = self.start_map
        self.kills += 1

    def _check(self) -> None:
        if not self.reachable and self.revive_file is not None and self.revive_file.exists():
            self.revive_file.unlink()  # what a launch command did: a fresh server is up
            self.reachable = True
        if not self.reachable:
            raise RuntimeError("time-out of 10000ms while waiting for the simulator")

    def _tick(self) -> int:
        self._check()
        if self.fail_ticks > 0:
            self.fail_ticks -= 1
            raise RuntimeError("time-out of 10000ms while waiting for the simulator")
        if not self._settings.synchronous_mode:
            raise RuntimeError("tick() outside synchronous mode (fake)")
        dt = self._settings.fixed_delta_seconds or 0.05
        movers = [a for a in self._actors.values() if isinstance(a, Vehicle | Walker)]
        for v in movers:
            v._step(dt)
        self.frame += 1
        self.ticks += 1
        self._episode_ticks += 1
        sensors = [a for a in self._actors.values() if isinstance(a, Sensor) and a._callback]
        for sensor in sensors:
            if sensor.type_id == "sensor.camera.rgb":
                w = int(sensor._attributes["image_size_x"])
                h = int(sensor._attributes["image_size_y"])
                raw = self._frame_bytes.setdefault((w, h), bytes(w * h * 4))
                sensor._callback(Image(self.frame, w, h, raw))
            elif sensor.type_id == "sensor.other.collision":
                for other in self._collisions(sensor._parent, movers):
                    sensor._callback(CollisionEvent(self.frame, other))
        return self.frame

    def _collisions(self, ego: Actor, movers: list[Actor]) -> list[Actor]:
        if self.collide_at_tick is not None and self._episode_ticks == self.collide_at_tick:
            return [v for v in movers if v is not ego][:1]
        out = []
        for v in movers:
            if v is ego:
                continue
            if v.bounding_box.extent.x < EXTENTS["car"][0]:  # walkers, bicycles: their boxes
                if _box_gap(ego, v) <= 0.0:
                    out.append(v)
            elif math.hypot(v._x - ego._x, v._y - ego._y) < self.collision_radius:
                out.append(v)
        return out


def _box_gap(a: Actor, b: Actor) -> float:
    """Distance [m] between two actors' footprint boxes (0 when they overlap)."""
    from sitcov.sim.carla._geometry import box_corners, box_distance

    boxes = [
        box_corners(
            o._x, o._y, math.radians(o._yaw), o.bounding_box.extent.x, o.bounding_box.extent.y
        )
        for o in (a, b)
    ]
    return box_distance(*boxes)


def _lane_graph(carla_map: Any) -> list[tuple[tuple[float, float], tuple[float, float], list[int]]]:
    j = (carla_map.junction.x, carla_map.junction.y)
    lanes: list[tuple[tuple[float, float], tuple[float, float], list[int]]] = []
    out = {leg: len(lanes) + i for i, leg in enumerate(carla_map.goals)}
    for goal in carla_map.goals.values():
        lanes.append((j, tuple(goal), []))
    for table in (carla_map.ego_spawns, carla_map.ov_spawns):
        for key, sp in table.items():
            leg = key.split("-")[0]
            succ = [i for other, i in out.items() if other != leg]
            lanes.append(((sp.x, sp.y), j, succ))
    return lanes


class FakeCarla:
    """Module-like object with the fake classes; ``Client`` connects to ``server``."""

    Location = Location
    Rotation = Rotation
    Transform = Transform
    Vector3D = Vector3D
    BoundingBox = BoundingBox
    WorldSettings = WorldSettings
    WeatherParameters = WeatherParameters
    VehicleControl = VehicleControl
    WalkerControl = WalkerControl
    ActorAttribute = ActorAttribute
    Walker = Walker
    VehiclePhysicsControl = VehiclePhysicsControl
    WheelPhysicsControl = WheelPhysicsControl
    Image = Image
    CollisionEvent = CollisionEvent
    ActorBlueprint = ActorBlueprint
    BlueprintLibrary = BlueprintLibrary
    Actor = Actor
    Vehicle = Vehicle
    Sensor = Sensor
    Waypoint = Waypoint
    Map = Map
    World = World

    def __init__(self, server: FakeServer) -> None:
        fake_server = server

        class Client:
            def __init__(self, host: str = "127.0.0.1", port: int = 2000) -> None:
                self._server, self._timeout = fake_server, 5.0
                fake_server.log.append(("client", host, port))

            def set_timeout(self, seconds: float) -> None:
                self._timeout = seconds

            def get_server_version(self) -> str:
                self._server._check()
                self._server.connections += 1
                return "0.9.16"

            def get_client_version(self) -> str:
                return "0.9.16"

            def get_world(self) -> World:
                self._server._check()
                return World(self._server)

            def load_world(self, map_name: str) -> World:
                self._server._check()
                self._server.log.append(("load_world", map_name))
                self._server.map_name = f"Carla/Maps/{map_name}"
                self._server._settings = WorldSettings(False, None)
                return World(self._server)

        self.Client = Client
        self.server = server
