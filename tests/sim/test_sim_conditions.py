"""Weather -> physical conditions: every element moves its quantity the documented way."""

from __future__ import annotations

import math

import pytest
from _sim_helpers import hyperspace_values

from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import Conditions, conditions_from_values


def _extremes(element: str) -> tuple[Conditions, Conditions]:
    """Conditions with only ``element`` at its lowest and at its highest bin."""
    labels = load_hyperspace().labels(element)
    low = conditions_from_values(hyperspace_values({element: labels[0]}))
    high = conditions_from_values(hyperspace_values({element: labels[-1]}))
    return low, high


def test_clear_defaults() -> None:
    cond = conditions_from_values({})
    assert cond.mu == pytest.approx(1.0)
    assert cond.illumination == pytest.approx(1.0)
    assert cond.rain_noise == 0.0
    assert cond.wind_speed == 0.0 and cond.wind_lateral_accel == 0.0
    assert cond.visibility > 10_000  # clear air


def test_friction_raises_mu() -> None:
    low, high = _extremes("friction")
    assert low.mu == pytest.approx(0.1) and high.mu == pytest.approx(1.0)


@pytest.mark.parametrize("element", ["wetness", "precipitation", "precipitation_deposits"])
def test_water_lowers_mu_and_adds_noise(element: str) -> None:
    low, high = _extremes(element)
    assert high.mu < low.mu
    assert high.rain_noise > low.rain_noise


def test_all_water_keeps_wet_road_grip() -> None:
    """Fully wet, raining and flooded: 45 % of dry grip (wet asphalt ~0.4-0.6 of dry)."""
    cond = conditions_from_values(
        {"wetness": 100, "precipitation": 100, "precipitation_deposits": 100, "friction": 1.0}
    )
    assert cond.mu == pytest.approx(0.45)
    assert 0.0 < cond.rain_noise <= 1.0


def test_fog_density_lowers_visibility() -> None:
    low, high = _extremes("fog_density")
    assert high.fog_extinction > low.fog_extinction
    assert high.visibility < low.visibility
    # Koschmieder: densest fog (fog starting at the camera) gives about 25 m
    dense = conditions_from_values({"fog_density": 100})
    assert dense.visibility == pytest.approx(25.0, rel=0.01)
    assert dense.transmittance(25.0) == pytest.approx(math.exp(-3.912), rel=0.01)


def test_fog_distance_pushes_fog_away() -> None:
    labels = load_hyperspace().labels("fog_distance")
    near = conditions_from_values(
        hyperspace_values({"fog_distance": labels[0], "fog_density": "100"})
    )
    far = conditions_from_values(
        hyperspace_values({"fog_distance": labels[-1], "fog_density": "100"})
    )
    assert far.fog_start > near.fog_start
    assert far.transmittance(50.0) > near.transmittance(50.0)
    assert far.transmittance(far.fog_start) == pytest.approx(1.0)


def test_cloudiness_dims_illumination() -> None:
    low, high = _extremes("cloudiness")
    assert high.illumination < low.illumination
    # Kasten-Czeplak: full overcast lets a quarter of clear-sky irradiance through
    assert high.illumination == pytest.approx(0.25)
    half = conditions_from_values({"cloudiness": 50})
    assert half.illumination == pytest.approx(1 - 0.75 * 0.5**3.4)


def test_wind_intensity_adds_lateral_disturbance() -> None:
    low, high = _extremes("wind_intensity")
    assert high.wind_speed > low.wind_speed
    assert high.wind_lateral_accel > low.wind_lateral_accel
    # gale at 20 m/s on a 1.1 t saloon: RMS ~0.7 m/s^2 (0.5 rho Cy A v^2 / m * sqrt(3/8))
    assert high.wind_lateral_accel == pytest.approx(
        0.5 * 1.225 * 0.8 * 4.508 * 1.45 * 400 / 1093.3 * math.sqrt(3 / 8), rel=1e-3
    )


def test_rain_angle_follows_wind() -> None:
    calm = conditions_from_values({"precipitation": 80, "wind_intensity": 0})
    windy = conditions_from_values({"precipitation": 80, "wind_intensity": 100}, wind_direction=1.0)
    assert calm.raw["rain_angle"] == 0.0
    assert windy.raw["rain_angle"] > 0.5
    assert windy.raw["wind_direction"] == 1.0


def test_every_environment_element_moves_something() -> None:
    hs = load_hyperspace()
    fields = (
        "mu",
        "fog_extinction",
        "fog_start",
        "illumination",
        "rain_noise",
        "wind_speed",
        "wind_lateral_accel",
    )
    for element in hs.element_names:
        if element == "intsit":
            continue
        low, high = _extremes(element)
        moved = [f for f in fields if getattr(low, f) != getattr(high, f)]
        assert moved, f"{element} has no effect"


def test_bad_value_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="fog_density"):
        conditions_from_values({"fog_density": "thick"})
