"""The dash-cam renderer: geometry agrees with project_box, weather effects, determinism, speed."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from sitcov.perception import ActorView, CameraSpec, Pose, project_box, render_frame
from sitcov.perception._renderer import vehicles_in_view
from sitcov.sim import conditions_from_values

CAM = CameraSpec()


def _ahead(ego: Pose, forward: float, left: float = 0.0, yaw: float = 0.0) -> ActorView:
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    f = CAM.mount_x + forward
    pose = Pose(ego.x + f * c - left * s, ego.y + f * s + left * c, ego.yaw + yaw)
    return ActorView(pose, 4.5, 1.9, 1.5)


def _render(geometry, ego, actors=(), values=None, seed=0):
    cond = conditions_from_values(values or {})
    return render_frame(CAM, ego, actors, cond, geometry, np.random.default_rng(seed))


def test_frame_shape_dtype_and_determinism(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    car = (_ahead(ego, 12.0),)
    a = _render(geometry, ego, car, {"precipitation": 60}, seed=3)
    b = _render(geometry, ego, car, {"precipitation": 60}, seed=3)
    assert a.shape == (450, 800, 3) and a.dtype == np.uint8
    assert np.array_equal(a, b)
    # Rain streaks come from the rng: another seed moves them; no rain, no difference.
    assert not np.array_equal(a, _render(geometry, ego, car, {"precipitation": 60}, seed=4))
    assert np.array_equal(_render(geometry, ego, car, seed=1), _render(geometry, ego, car, seed=2))


def test_car_pixels_lie_inside_the_projected_box(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    for rel in ((8.0, 0.0, 0.0), (15.0, 3.0, math.pi / 2), (10.0, -2.0, 2.5)):
        car = _ahead(ego, *rel)
        diff = np.abs(_render(geometry, ego, (car,)).astype(int) - _render(geometry, ego)).sum(2)
        ys, xs = np.nonzero(diff > 30)
        x0, y0, x1, y1 = project_box(CAM, ego, car).box
        # The drawn car fills the box tightly; its ground shadow (0.08 m wider, 0.15 m
        # longer than the body) may stick out by a few pixels at the bottom and sides.
        assert xs.min() >= x0 - 8 and xs.max() <= x1 + 8
        assert ys.min() >= y0 - 2 and ys.max() <= y1 + 8
        assert (xs.max() - xs.min()) > 0.85 * (x1 - x0)
        assert (ys.max() - ys.min()) > 0.8 * (y1 - y0)


def test_fog_washes_out_the_car_by_distance(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    fog = {"fog_density": 100}

    def contrast(forward: float, values) -> float:
        car = _ahead(ego, forward)
        diff = np.abs(
            _render(geometry, ego, (car,), values).astype(int) - _render(geometry, ego, (), values)
        )
        x0, y0, x1, y1 = (int(v) for v in project_box(CAM, ego, car).box)
        return float(diff[y0:y1, x0:x1].mean())

    beta = conditions_from_values(fog).fog_extinction
    near_clear, far_clear = contrast(8.0, None), contrast(25.0, None)
    near_fog, far_fog = contrast(8.0, fog), contrast(25.0, fog)
    assert near_fog < near_clear and far_fog < far_clear
    # Beer-Lambert: the far car keeps less of its contrast than the near one, roughly by
    # exp(-beta * 17 m) (tolerance for shading and the box mean).
    ratio = (far_fog / far_clear) / (near_fog / near_clear)
    assert ratio == pytest.approx(math.exp(-beta * 17.0), abs=0.15)


def test_weather_effects_on_light_and_road(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    clear = _render(geometry, ego).astype(float)
    cloudy = _render(geometry, ego, values={"cloudiness": 100}).astype(float)
    # auto-exposure keeps the overall brightness (tests/perception/test_exposure.py)
    assert cloudy.mean() == pytest.approx(clear.mean(), rel=0.1)
    assert cloudy.std() < clear.std()  # flatter
    road = (slice(400, 450), slice(300, 500))  # road just ahead of the ego
    wet = _render(geometry, ego, values={"wetness": 100}).astype(float)
    assert wet[road].mean() < 0.8 * clear[road].mean()
    puddles = _render(geometry, ego, values={"precipitation_deposits": 100}).astype(float)
    changed = np.abs(puddles[250:450] - clear[250:450]).sum(2) > 40
    assert 0.02 < changed.mean() < 0.8  # some of the road, not everything
    rain = _render(geometry, ego, values={"precipitation": 100}).astype(float)
    sky = (slice(0, 150), slice(0, 800))
    assert np.abs(rain[sky] - clear[sky]).sum(2).std() > 5  # streaks texture the sky


def test_wind_slants_the_rain(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    calm = _render(geometry, ego, values={"precipitation": 100}).astype(float).mean(2)
    windy = _render(geometry, ego, values={"precipitation": 100, "wind_intensity": 100})
    windy = windy.astype(float).mean(2)

    def slant(img: np.ndarray) -> int:
        sky = img[20:150] - img[20:150].mean()
        scores = {dx: float((sky[1:, max(dx, 0) :][:, : 780] * sky[:-1, max(-dx, 0) :][:, :780])
                            .mean()) for dx in range(-3, 4)}  # fmt: skip
        return max(scores, key=scores.get)

    assert slant(windy) != slant(calm)


def test_vehicles_in_view() -> None:
    ego = Pose(0.0, 0.0, 0.0)
    assert vehicles_in_view(CAM, ego, (_ahead(ego, 20.0),))
    assert not vehicles_in_view(CAM, ego, (_ahead(ego, -20.0),))  # behind
    assert not vehicles_in_view(CAM, ego, (_ahead(ego, 3000.0),))  # sub-pixel
    assert not vehicles_in_view(CAM, ego, ())


def test_render_speed(tjunction_geometry) -> None:
    """CPU time per 800x450 frame (process time, so other load on the machine is excluded)."""
    geometry, ego = tjunction_geometry
    car = (_ahead(ego, 12.0, 0.0, 0.7),)
    values = {"precipitation": 80, "wetness": 80, "precipitation_deposits": 60, "fog_density": 40}
    _render(geometry, ego, car, values)
    t = time.process_time()
    for i in range(10):
        _render(geometry, ego, car, values, seed=i)
    per_frame = (time.process_time() - t) / 10
    assert per_frame < 0.04, f"{per_frame * 1000:.1f} ms per frame"


def test_cli_render_writes_the_frame_at_time_t(tmp_path, capsys) -> None:
    import json

    from PIL import Image

    from sitcov.cli import main
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace

    sit = make_generator("random", load_hyperspace()).ask(np.random.default_rng(1))
    out = tmp_path / "frame.png"
    main(["render", "--situation", json.dumps(sit.to_dict()), "--time", "3", "--out", str(out)])
    img = np.asarray(Image.open(out))
    assert img.shape == (450, 800, 3)
    assert "t = 3.00 s" in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        main(["render", "--situation", "{not json", "--time", "1"])
    assert exc.value.code == 2
    assert "situation JSON" in capsys.readouterr().err
