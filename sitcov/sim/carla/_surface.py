"""The part of the ``carla`` client API that the adapter uses, listed in one place.

The contract test checks every entry against the real ``carla`` wheel (the member exists,
positional arguments fit, keyword names are the wheel's), and the in-memory fake used by
the behavioural tests implements exactly these members. The adapter must not touch any
other part of the API: a new call means a new line here, so the contract cannot drift.
"""

from __future__ import annotations

from dataclasses import dataclass

from sitcov.weather._conditions import WEATHER_ELEMENTS


@dataclass(frozen=True)
class Use:
    """How the adapter uses one member of a ``carla`` class.

    Attributes:
        kind: ``new`` (constructor), ``call`` (method), ``get`` (read a property) or
            ``set`` (read and assign a property).
        positional: number of positional arguments passed (besides ``self``).
        keywords: keyword argument names passed.
    """

    kind: str
    positional: int = 0
    keywords: tuple[str, ...] = ()


GET = Use("get")
SET = Use("set")


#: ``"Class"`` = constructor, ``"Class.member"`` = method or property.
SURFACE: dict[str, Use] = {
    # connection
    "Client": Use("new", keywords=("host", "port")),
    "Client.set_timeout": Use("call", 1),
    "Client.get_server_version": Use("call"),
    "Client.get_client_version": Use("call"),
    "Client.get_world": Use("call"),
    "Client.load_world": Use("call", 1),
    # world
    "World.get_settings": Use("call"),
    "World.apply_settings": Use("call", 1),
    "World.tick": Use("call", keywords=("seconds",)),
    "World.set_weather": Use("call", 1),
    "World.get_map": Use("call"),
    "World.get_blueprint_library": Use("call"),
    "World.spawn_actor": Use("call", 2, ("attach_to",)),
    "WorldSettings.synchronous_mode": SET,
    "WorldSettings.fixed_delta_seconds": SET,
    "WeatherParameters": Use("new", keywords=(*WEATHER_ELEMENTS, "sun_altitude_angle")),
    # map and routes
    "Map.name": GET,
    "Map.get_waypoint": Use("call", 1, ("project_to_road",)),
    "Waypoint.transform": GET,
    "Waypoint.next": Use("call", 1),
    "Waypoint.road_id": GET,
    "Waypoint.section_id": GET,
    "Waypoint.lane_id": GET,
    "Waypoint.s": GET,
    # blueprints
    "BlueprintLibrary.find": Use("call", 1),
    "ActorBlueprint.has_attribute": Use("call", 1),
    "ActorBlueprint.set_attribute": Use("call", 2),
    "ActorBlueprint.get_attribute": Use("call", 1),
    "ActorAttribute.as_int": Use("call"),
    # geometry
    "Location": Use("new", keywords=("x", "y", "z")),
    "Location.x": GET,
    "Location.y": GET,
    "Location.z": GET,
    "Rotation": Use("new", keywords=("pitch", "yaw", "roll")),
    "Rotation.yaw": GET,
    "Transform": Use("new", 2),
    "Transform.location": GET,
    "Transform.rotation": GET,
    "Vector3D": Use("new", keywords=("x", "y", "z")),
    "Vector3D.x": GET,
    "Vector3D.y": GET,
    "BoundingBox.extent": GET,
    # actors
    "Actor.id": GET,
    "Actor.type_id": GET,
    "Actor.bounding_box": GET,
    "Actor.get_transform": Use("call"),
    "Actor.get_velocity": Use("call"),
    "Actor.destroy": Use("call"),
    "Vehicle.apply_control": Use("call", 1),
    "Vehicle.get_physics_control": Use("call"),
    "Vehicle.apply_physics_control": Use("call", 1),
    "VehicleControl": Use("new", keywords=("throttle", "steer", "brake")),
    "VehiclePhysicsControl.wheels": SET,
    "WheelPhysicsControl.tire_friction": SET,
    "WheelPhysicsControl.max_steer_angle": GET,
    # pedestrians (walker.pedestrian.*); bicycles are Vehicles
    "Walker.apply_control": Use("call", 1),
    "WalkerControl": Use("new", keywords=("direction", "speed")),
    # sensors and their data
    "Sensor.listen": Use("call", 1),
    "Sensor.stop": Use("call"),
    "Image.raw_data": GET,
    "Image.width": GET,
    "Image.height": GET,
    "Image.frame": GET,
    "CollisionEvent.other_actor": GET,
    "CollisionEvent.frame": GET,
}


def classes() -> list[str]:
    """The ``carla`` class names the adapter uses."""
    return sorted({key.split(".", 1)[0] for key in SURFACE})


def members(cls: str) -> dict[str, Use]:
    """Member name -> use for one class (the constructor under ``__init__``)."""
    out: dict[str, Use] = {}
    for key, use in SURFACE.items():
        name, _, member = key.partition(".")
        if name == cls:
            out[member or "__init__"] = use
    return out
