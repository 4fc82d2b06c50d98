"""Object lists: the ground truth in the ego frame, and the documented noise and miss model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitcov.errors import ConfigError
from sitcov.perception import (
    ActorView,
    ObjectNoise,
    Pose,
    load_object_noise,
    object_list,
)
from sitcov.sim import conditions_from_values

EGO = Pose(10.0, 5.0, math.pi / 2)  # heading +y: ego-frame x is world +y, y is world -x


def _car(x: float, y: float, yaw: float = 0.0, kind: str = "car") -> ActorView:
    return ActorView(Pose(x, y, yaw), 4.5, 1.9, 1.5, kind=kind)


def test_ground_truth_is_every_road_user_in_the_ego_frame() -> None:
    actors = [
        (1, _car(10.0, 25.0, -math.pi / 2), 0.0, -5.0),  # 20 m ahead, coming towards it
        (2, _car(6.0, 5.0, math.pi / 2, "pedestrian"), 0.0, 1.0),  # 4 m to the left
        (3, _car(10.0, 15.0, math.pi / 2, "cyclist"), 0.0, 3.0),
    ]
    objs = object_list(EGO, actors)
    assert [o.id for o in objs] == [2, 3, 1]  # nearest first (from the ego's centre)
    far = {o.id: o for o in objs}[1]
    assert (far.x, far.y) == pytest.approx((20.0, 0.0))
    assert far.heading == pytest.approx(math.pi)  # facing the ego
    assert (far.vx, far.vy) == pytest.approx((-5.0, 0.0))  # over the ground, ego axes
    assert (far.length, far.width, far.height, far.label) == (4.5, 1.9, 1.5, "car")
    walker = {o.id: o for o in objs}[2]
    assert (walker.x, walker.y, walker.label) == pytest.approx((0.0, 4.0, "person"))
    assert {o.id: o.label for o in objs}[3] == "bicycle"
    assert far.to_dict() == {
        "id": 1, "label": "car", "position": [far.x, far.y], "heading": far.heading,
        "velocity": [far.vx, far.vy], "size": [4.5, 1.9, 1.5],
    }  # fmt: skip


def _reported(noise, dist, conditions=None, n=2000, blocker=False) -> float:
    rng = np.random.default_rng(7)
    actors = [(1, _car(10.0, 5.0 + dist, 0.0), 0.0, 0.0)]
    if blocker:  # a car across the line of sight, half-way
        actors.append((2, _car(10.0, 5.0 + dist / 2, 0.0), 0.0, 0.0))
    hits = sum(
        any(o.id == 1 for o in object_list(EGO, actors, conditions=conditions, noise=noise,
                                           rng=rng))
        for _ in range(n)
    )  # fmt: skip
    return hits / n


def test_misses_grow_with_range_fog_rain_and_occlusion() -> None:
    noise = load_object_noise()
    near, far = _reported(noise, 10.0), _reported(noise, 70.0)
    assert near == pytest.approx(noise.p_max, abs=0.02)
    assert far < 0.5 * near
    fog = conditions_from_values({"fog_density": 100.0})
    assert _reported(noise, 10.0, fog) > 0.8  # T ~ 0.2: the detector still sees it
    assert _reported(noise, 30.0, fog) < 0.1  # T ~ 0.01: it does not
    rain = conditions_from_values({"precipitation": 100.0})
    assert _reported(noise, 10.0, rain) < near - 0.05
    assert _reported(noise, 20.0, blocker=True) == 0.0  # fully hidden behind a nearer car


def test_noise_is_documented_sigma_and_seeded() -> None:
    noise = ObjectNoise(p_max=1.0, range_50=1e6, fog_t50=1e-9)  # never misses
    actors = [(1, _car(10.0, 35.0, 0.0), 2.0, 0.0)]  # 30 m ahead
    draws = [object_list(EGO, actors, noise=noise, rng=np.random.default_rng(s))[0]
             for s in range(3000)]  # fmt: skip
    xs = np.array([o.x for o in draws])
    sigma = noise.pos_sigma0 + noise.pos_sigma_per_m * 30.0
    assert xs.mean() == pytest.approx(30.0, abs=0.02)
    assert xs.std() == pytest.approx(sigma, rel=0.08)
    assert np.std([o.vy for o in draws]) == pytest.approx(noise.vel_sigma, rel=0.08)
    again = object_list(EGO, actors, noise=noise, rng=np.random.default_rng(5))
    assert again == (draws[5],)


def test_the_hook_replaces_range_and_weather_but_not_occlusion() -> None:
    seen = []

    def per_class(label, distance, transmittance, conditions) -> float:
        seen.append((label, round(distance, 6), transmittance))
        return 0.0 if label == "person" else 1.0

    noise = ObjectNoise(detection_probability=per_class)
    actors = [(1, _car(10.0, 75.0), 0.0, 0.0), (2, _car(6.0, 5.0, 0.0, "pedestrian"), 0.0, 0.0)]
    objs = object_list(EGO, actors, noise=noise, rng=np.random.default_rng(0))
    assert [o.id for o in objs] == [1]  # 70 m: the hook, not the range term, decides
    assert ("car", 70.0, 1.0) in seen
    hidden = [(1, _car(10.0, 25.0), 0.0, 0.0), (2, _car(10.0, 15.0), 0.0, 0.0)]
    assert [o.id for o in object_list(EGO, hidden, noise=noise, rng=np.random.default_rng(0))] == [
        2
    ]


def test_bad_parameters_are_one_line_errors(tmp_path) -> None:
    bad = tmp_path / "noise.yaml"
    bad.write_text("p_max: 1.5\n")
    with pytest.raises(ConfigError, match=r"noise.yaml: p_max: expected a number in \[0, 1\]"):
        load_object_noise(bad)
    bad.write_text("range50: 3\n")
    with pytest.raises(ConfigError, match="noise.yaml: range50: expected .*range_50"):
        load_object_noise(bad)
    with pytest.raises(ConfigError, match="missing.yaml: expected a readable YAML file"):
        load_object_noise(tmp_path / "missing.yaml")
