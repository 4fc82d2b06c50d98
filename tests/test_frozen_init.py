"""fast_init keeps every behaviour of the frozen dataclasses it speeds up."""

from __future__ import annotations

import dataclasses
import inspect
import pickle

import pytest

from sitcov._frozen import fast_init
from sitcov.av import Control
from sitcov.av._base import EgoState, Observation
from sitcov.perception import ActorView, Detection, Pose


@dataclasses.dataclass(frozen=True)
class _Plain:
    a: float
    b: str = "x"
    c: dict = dataclasses.field(default_factory=dict)


@fast_init
@dataclasses.dataclass(frozen=True)
class _Fast:
    a: float
    b: str = "x"
    c: dict = dataclasses.field(default_factory=dict)


def test_same_signature_defaults_and_fresh_factories() -> None:
    def shape(cls: type) -> list[tuple[str, object]]:
        params = inspect.signature(cls).parameters.values()
        return [(p.name, p.kind, p.default is inspect.Parameter.empty) for p in params]

    assert shape(_Fast) == shape(_Plain)
    one, two = _Fast(1.0), _Fast(1.0)
    assert (one.a, one.b, one.c) == (1.0, "x", {})
    assert one.c is not two.c  # a new dict per instance, as default_factory gives
    assert _Fast(2.0, c={"k": 1}).c == {"k": 1} and _Fast(a=3.0, b="y").b == "y"
    with pytest.raises(TypeError):
        _Fast()  # the required field is still required


def test_equality_hash_repr_immutability_pickle_replace() -> None:
    fast = _Fast(1.5, "q")
    assert fast == _Fast(1.5, "q") and fast != _Fast(1.5, "r")
    assert repr(fast) == repr(_Plain(1.5, "q")).replace("_Plain", "_Fast")
    with pytest.raises(dataclasses.FrozenInstanceError):
        fast.a = 2.0  # type: ignore[misc]
    assert pickle.loads(pickle.dumps(fast)) == fast
    assert dataclasses.replace(fast, a=7.0) == _Fast(7.0, "q")
    assert hash(Pose(1.0, 2.0, 0.5)) == hash(Pose(1.0, 2.0, 0.5))


def test_the_hot_loop_types_keep_their_fields_and_defaults() -> None:
    view = ActorView(Pose(1.0, 2.0, 0.0), 4.5, 1.8, 1.4)
    assert (view.speed, view.color, view.kind) == (0.0, None, "car")
    assert Detection((0.0, 1.0, 2.0, 3.0), 0.5).label == "car"
    assert Control().info == {} and Control(0.1, 0.2, 0.3).steer == 0.3
    obs = Observation(0.5, EgoState(1.0, 2.0, 0.1, 3.0, 0.5))
    assert (obs.detections, obs.image, obs.ego.speed) == (None, None, 3.0)


def test_refuses_what_it_cannot_handle() -> None:
    @dataclasses.dataclass
    class Mutable:
        a: int

    with pytest.raises(TypeError):
        fast_init(Mutable)
