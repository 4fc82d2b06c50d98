"""The renderer's auto-exposure: CARLA's default histogram exposure, at steady state."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitcov.perception import ActorView, CameraSpec, Pose, project_box, render_frame
from sitcov.perception._renderer import (
    EXPOSURE_MAX_BRIGHT,
    EXPOSURE_MIN_BRIGHT,
    EXPOSURE_REFERENCE,
    exposure_gain,
    metered_luminance,
)
from sitcov.sim import conditions_from_values

CAM = CameraSpec()
LUMA = np.asarray([0.2126, 0.7152, 0.0722])


def _frame(geometry, ego: Pose, values: dict[str, float], car: bool = True) -> np.ndarray:
    cx = ego.x + CAM.mount_x * math.cos(ego.yaw)
    cy = ego.y + CAM.mount_x * math.sin(ego.yaw)
    los = ego.yaw + 0.2
    actor = ActorView(
        Pose(cx + 12 * math.cos(los), cy + 12 * math.sin(los), los + 1.5), 4.5, 1.9, 1.5
    )
    cond = conditions_from_values(values)
    actors = (actor,) if car else ()
    return render_frame(CAM, ego, actors, cond, geometry, np.random.default_rng(0)).astype(float)


def _car_box(ego: Pose) -> tuple[int, int, int, int]:
    cx = ego.x + CAM.mount_x * math.cos(ego.yaw)
    cy = ego.y + CAM.mount_x * math.sin(ego.yaw)
    los = ego.yaw + 0.2
    actor = ActorView(
        Pose(cx + 12 * math.cos(los), cy + 12 * math.sin(los), los + 1.5), 4.5, 1.9, 1.5
    )
    return tuple(int(v) for v in project_box(CAM, ego, actor).box)  # type: ignore[return-value]


def test_full_overcast_keeps_the_brightness_and_the_cars_contrast(tjunction_geometry) -> None:
    """Without exposure a cloudiness-100 frame was ~0.3x as bright; the camera adapts.

    What cloud leaves after the exposure is what diffuse light does: flatter shading of the
    car's faces, not a lower contrast between the car and the road (their reflectances do
    not change with the light); fog, by contrast, takes that contrast away.
    Tolerances: mean luminance within 10 % of clear noon's at cloudiness 100 (measured:
    3 % darker), 15 % at 60 (measured: 5 % brighter: the metering keys on the sky, which
    turns grey); the car's contrast keeps >= 85 % at cloudiness 100 (measured 92 %) and
    falls below 40 % in dense fog (measured 28 %).
    """
    geometry, ego = tjunction_geometry
    x0, y0, x1, y1 = _car_box(ego)

    def looks(values: dict[str, float]) -> tuple[float, float, float]:
        car = _frame(geometry, ego, values) @ LUMA
        diff = np.abs(car - _frame(geometry, ego, values, car=False) @ LUMA)[y0:y1, x0:x1]
        body = car[y0:y1, x0:x1][diff > 3]
        return car.mean(), diff.mean(), body.std()

    clear = looks({})
    for values, tol in (({"cloudiness": 100}, 0.10), ({"cloudiness": 60}, 0.15)):
        assert looks(values)[0] == pytest.approx(clear[0], rel=tol), values
    overcast = looks({"cloudiness": 100})
    assert overcast[1] >= 0.85 * clear[1]  # the car stands out from the road as before
    assert overcast[2] < 0.95 * clear[2]  # its faces are shaded more evenly
    assert looks({"fog_density": 100})[1] < 0.4 * clear[1]


def test_overcast_light_is_cooler_on_a_daylight_white_balance(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    clear = _frame(geometry, ego, {}, car=False)
    cloudy = _frame(geometry, ego, {"cloudiness": 100}, car=False)
    road = (slice(400, 450), slice(300, 500))  # grey asphalt: its tint is the light's
    ratio = lambda img: img[road][..., 2].mean() / img[road][..., 0].mean()  # noqa: E731
    assert ratio(cloudy) > ratio(clear) * 1.05


def _uniform(value: float) -> np.ndarray:
    return np.full((40, 60, 3), value, dtype=np.float32)


def test_exposure_adapts_only_within_carlas_window() -> None:
    window = EXPOSURE_MAX_BRIGHT - EXPOSURE_MIN_BRIGHT  # 2 EV
    # As bright as clear noon, or brighter (fog): no change (clear noon is the window's top).
    ref = 255.0 * EXPOSURE_REFERENCE ** (1 / 2.2)
    assert exposure_gain(_uniform(ref)) == pytest.approx(1.0, abs=0.01)
    assert exposure_gain(_uniform(250.0)) == 1.0
    # One stop darker: brightened by one stop (a factor 2 in linear light).
    one_stop = 255.0 * (EXPOSURE_REFERENCE / 2) ** (1 / 2.2)
    assert exposure_gain(_uniform(one_stop)) ** 2.2 == pytest.approx(2.0, rel=0.02)
    # Night-dark: at most the window's 2 EV.
    assert exposure_gain(_uniform(5.0)) ** 2.2 == pytest.approx(2.0**window, rel=1e-6)


def test_metering_keys_on_the_bright_part_of_the_histogram() -> None:
    """The 80-98.3 % band: a dark lower half does not move the metered value."""
    img = _uniform(180.0)
    half_dark = img.copy()
    half_dark[:20] = 10.0
    assert metered_luminance(half_dark) == pytest.approx(metered_luminance(img), rel=1e-6)
    tiny_glint = img.copy()
    tiny_glint[0, :5] = 255.0  # < 1.7 % of the pixels: above the band
    assert metered_luminance(tiny_glint) == pytest.approx(metered_luminance(img), rel=1e-6)
