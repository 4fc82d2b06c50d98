"""Contract: every carla member the adapter uses exists in the real wheel, with our arguments.

The list comes from one place (``sitcov.sim.carla._surface.SURFACE``); the fake used by the
behavioural tests implements exactly that list, so the adapter cannot use anything the
contract does not check.
"""

from __future__ import annotations

import inspect
import re
from typing import Any

import pytest
from needs import need_module

from sitcov.sim.carla import _fake
from sitcov.sim.carla._surface import SURFACE, Use, classes, members

carla = need_module("carla", "carla")

_PARAM = re.compile(r"\((\w+)\)(\w+)")


def overloads(func: Any, name: str) -> list[tuple[list[str], int]]:
    """(parameter names without self, number of required ones) per Boost.Python overload."""
    out = []
    for line in (func.__doc__ or "").splitlines():
        line = line.strip()
        if not line.startswith(f"{name}(") or "->" not in line:
            continue
        head = line[: line.index("->")]
        params = [(m.start(), m.group(2)) for m in _PARAM.finditer(head)][1:]
        optional_from = head.find("[")
        required = sum(1 for pos, _ in params if optional_from < 0 or pos < optional_from)
        out.append(([p for _, p in params], required))
    return out


def accepts(func: Any, name: str, use: Use) -> bool:
    for params, required in overloads(func, name):
        n_args = use.positional + len(use.keywords)
        if not use.positional <= len(params) or n_args < required or n_args > len(params):
            continue
        if all(k in params[use.positional :] for k in use.keywords):
            return True
    return False


@pytest.mark.parametrize("key", sorted(SURFACE))
def test_member_exists_in_the_real_wheel_with_our_arguments(key: str) -> None:
    use = SURFACE[key]
    cls_name, _, member = key.partition(".")
    cls = getattr(carla, cls_name, None)
    assert cls is not None, f"carla.{cls_name} does not exist in carla {carla.__name__}"
    if use.kind == "new":
        assert accepts(cls.__init__, "__init__", use), f"carla.{cls_name}({use}) not accepted"
        return
    attr = inspect.getattr_static(cls, member, None)
    if attr is None:  # inherited (e.g. Vehicle.get_transform from Actor)
        attr = getattr(cls, member, None)
    assert attr is not None, f"carla.{key} does not exist"
    if use.kind == "call":
        assert callable(attr), f"carla.{key} is not a method"
        assert accepts(attr, member, use), f"carla.{key} does not take {use}"
    else:
        assert isinstance(attr, property), f"carla.{key} is not a property"
        if use.kind == "set":
            assert attr.fset is not None, f"carla.{key} is read-only"


def test_docstring_parser_reads_known_signatures() -> None:
    """The checker itself: known signatures parse, and wrong arguments are rejected."""
    spawn = overloads(carla.World.spawn_actor, "spawn_actor")
    assert spawn[0][0][:3] == ["blueprint", "transform", "attach_to"] and spawn[0][1] == 2
    assert not accepts(carla.World.spawn_actor, "spawn_actor", Use("call", 2, ("parent",)))
    assert not accepts(carla.Client.set_timeout, "set_timeout", Use("call", 2))
    assert not accepts(carla.WeatherParameters.__init__, "__init__", Use("new", 0, ("fogginess",)))


def test_the_real_objects_the_adapter_builds_take_its_values() -> None:
    """Build (client-side, no server needed) the objects a run creates, with its values."""
    from carla_testkit import situation

    from sitcov.sim.carla import CarlaBackend

    backend = CarlaBackend(connect=False, carla_module=carla)
    weather, applied = backend._weather(situation().values)
    for name, value in applied.items():
        assert getattr(weather, name) == pytest.approx(value), name
    tf = backend._transform(-74.32, -50.0, 0.5, 270.0)
    assert (tf.location.x, tf.location.y, tf.rotation.yaw) == pytest.approx((-74.32, -50.0, 270.0))
    control = carla.VehicleControl(throttle=0.5, steer=-0.25, brake=0.0)
    assert (control.throttle, control.steer) == pytest.approx((0.5, -0.25))
    settings = carla.WorldSettings()
    settings.synchronous_mode = True
    settings.fixed_delta_seconds = 0.05
    assert settings.synchronous_mode and settings.fixed_delta_seconds == pytest.approx(0.05)
    walk = carla.WalkerControl(direction=carla.Vector3D(x=0.6, y=-0.8, z=0.0), speed=1.4)
    assert (walk.direction.x, walk.direction.y, walk.speed) == pytest.approx((0.6, -0.8, 1.4))
    wheel = carla.WheelPhysicsControl()
    wheel.tire_friction = 1.4
    physics = carla.VehiclePhysicsControl()
    physics.wheels = [wheel, wheel]
    assert [w.tire_friction for w in physics.wheels] == pytest.approx([1.4, 1.4])


def _public(obj: Any) -> set[str]:
    names = {n for n in dir(type(obj)) if not n.startswith("_")}
    names |= {n for n in vars(obj) if not n.startswith("_")} if hasattr(obj, "__dict__") else set()
    return names


_BASES = {
    "Vehicle": ["Actor"],
    "Walker": ["Actor"],
    "Sensor": ["Actor"],
    "Location": ["Vector3D"],
}


def _allowed(cls_name: str) -> set[str]:
    allowed = {m for m in members(cls_name) if m != "__init__"}
    for base in _BASES.get(cls_name, []):
        allowed |= _allowed(base)
    return allowed


def test_fake_implements_exactly_the_surface(tmp_path: Any) -> None:
    """Every surface member exists on the fake; the fake has no other public member."""
    from carla_testkit import DrivingStack, fake_backend, situation, small_map

    backend, server = fake_backend(small_map(tmp_path))
    backend.run(situation(), DrivingStack(), seed=1)  # exercise the fake
    fake = backend._carla
    for cls_name in classes():
        assert hasattr(fake, cls_name), f"fake has no {cls_name}"
        cls = getattr(fake, cls_name)
        for member, use in members(cls_name).items():
            if use.kind in ("call", "new") and member != "__init__":
                assert callable(getattr(cls, member, None)), f"fake {cls_name}.{member}"
                sig = inspect.signature(getattr(cls, member))
                for kw in use.keywords:
                    assert kw in sig.parameters, f"fake {cls_name}.{member} lacks {kw}"
    samples = {
        "Location": _fake.Location(1, 2, 3),
        "Rotation": _fake.Rotation(yaw=3),
        "Transform": _fake.Transform(),
        "Vector3D": _fake.Vector3D(),
        "BoundingBox": _fake.BoundingBox(_fake.Vector3D()),
        "WorldSettings": _fake.WorldSettings(),
        "WheelPhysicsControl": _fake.WheelPhysicsControl(),
        "VehiclePhysicsControl": _fake.VehiclePhysicsControl(),
        "Image": _fake.Image(1, 2, 2, bytes(16)),
        "World": fake.World(server),
        "Map": fake.Map(server, "m"),
        "Waypoint": fake.Map(server, "m").get_waypoint(_fake.Location()),
        "BlueprintLibrary": fake.BlueprintLibrary(),
        "ActorBlueprint": fake.BlueprintLibrary().find("sensor.other.collision"),
        "ActorAttribute": fake.BlueprintLibrary()
        .find("vehicle.bh.crossbike")
        .get_attribute("number_of_wheels"),
        "WalkerControl": _fake.WalkerControl(_fake.Vector3D(1, 0, 0), 1.0),
        "Walker": fake.World(server).spawn_actor(
            _fake.ActorBlueprint("walker.pedestrian.0001", {}), _fake.Transform()
        ),
        "Client": fake.Client(host="h", port=1),
        "Vehicle": fake.World(server).spawn_actor(
            _fake.ActorBlueprint("vehicle.x", {}), _fake.Transform()
        ),
    }
    samples["CollisionEvent"] = _fake.CollisionEvent(1, samples["Vehicle"])
    for cls_name, obj in samples.items():
        extra = _public(obj) - _allowed(cls_name)
        assert not extra, f"fake {cls_name} has members outside the surface: {extra}"


def test_the_real_classes_the_scene_actors_use() -> None:
    """Walkers are Actors with their own control; bicycles are Vehicles (client side)."""
    assert issubclass(carla.Walker, carla.Actor)
    assert "apply_control" in vars(carla.Walker)  # its own overload, not the vehicle's
    assert set(members("WalkerControl")["__init__"].keywords) <= {
        n for n in dir(carla.WalkerControl) if not n.startswith("_")
    }
