"""Weather -> physical conditions, per physics profile.

Properties and physically meaningful bounds (handbook ranges, definitions), never the
code's own formula recomputed: see docs/weather.md for the table these tests back.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Mapping
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.weather import PHYSICS_PROFILES, WEATHER_ELEMENTS, Conditions, conditions_from_values


@functools.lru_cache(maxsize=1)
def _hyperspace():
    return load_hyperspace()


def hyperspace_values(bins: Mapping[str, str]) -> dict[str, Any]:
    """Concrete values of a default-hyperspace situation with the given bins (rest lowest)."""
    hs = _hyperspace()
    chosen = {e.name: bins.get(e.name, hs.labels(e.name)[0]) for e in hs.elements}
    return dict(hs.situation_from_bins(chosen).values)


PERCENT = st.floats(min_value=0.0, max_value=100.0)
FRICTION = st.floats(min_value=0.1, max_value=1.0)
WATER = ("wetness", "precipitation", "precipitation_deposits")
#: Wet/dry peak-friction ratio of asphalt, Wong, Theory of Ground Vehicles, Table 1.3:
#: 0.5-0.7 wet over 0.8-0.9 dry, i.e. 0.55..0.88.
HANDBOOK_WET_RATIO = (0.5, 0.9)


def weather() -> st.SearchStrategy[dict[str, float]]:
    """Any weather (every element in CARLA units) with any friction element."""
    return st.fixed_dictionaries(
        {name: PERCENT for name in WEATHER_ELEMENTS} | {"friction": FRICTION}
    )


def _extremes(element: str, profile: str = "carla") -> tuple[Conditions, Conditions]:
    """Conditions with only ``element`` at its lowest and at its highest bin."""
    labels = load_hyperspace().labels(element)
    low = conditions_from_values(hyperspace_values({element: labels[0]}), profile=profile)
    high = conditions_from_values(hyperspace_values({element: labels[-1]}), profile=profile)
    return low, high


@pytest.mark.parametrize("profile", PHYSICS_PROFILES)
def test_clear_defaults(profile: str) -> None:
    cond = conditions_from_values({}, profile=profile)
    assert cond.mu == 1.0
    assert cond.illumination == 1.0
    assert cond.rain_noise == 0.0
    assert cond.wind_speed == 0.0 and cond.wind_lateral_accel == 0.0
    assert cond.visibility > 10_000  # clear air


# --- carla profile: weather reaches the camera only ------------------------------------------


@settings(max_examples=200, deadline=None)
@given(values=weather(), element=st.sampled_from(WEATHER_ELEMENTS), new=PERCENT)
def test_carla_weather_never_changes_mu_nor_pushes(
    values: dict[str, float], element: str, new: float
) -> None:
    """Changing any element other than friction leaves mu unchanged; wind has no force."""
    before = conditions_from_values(values)
    after = conditions_from_values({**values, element: new})
    assert after.mu == before.mu == values["friction"]
    assert after.wind_lateral_accel == before.wind_lateral_accel == 0.0


def test_carla_friction_is_mu() -> None:
    low, high = _extremes("friction")
    assert (low.mu, high.mu) == (0.1, 1.0)


@settings(max_examples=100, deadline=None)
@given(values=weather())
def test_perception_is_the_same_in_both_profiles(values: dict[str, float]) -> None:
    carla = conditions_from_values(values, wind_direction=0.3, profile="carla")
    physical = conditions_from_values(values, wind_direction=0.3, profile="physical")
    for field in ("fog_extinction", "fog_start", "illumination", "rain_noise", "wind_speed"):
        assert getattr(carla, field) == getattr(physical, field)
    assert carla.raw == physical.raw


# --- physical profile: water film and crosswind ------------------------------------------------


@settings(max_examples=200, deadline=None)
@given(values=weather(), element=st.sampled_from(WATER), more=PERCENT)
def test_physical_more_water_never_raises_mu(
    values: dict[str, float], element: str, more: float
) -> None:
    wetter = {**values, element: max(values[element], more)}
    assert conditions_from_values(wetter, profile="physical").mu <= (
        conditions_from_values(values, profile="physical").mu
    )


@pytest.mark.parametrize("element", WATER)
def test_physical_each_water_element_lowers_mu_monotonically(element: str) -> None:
    """On a dry road, each element alone lowers mu strictly along its bins."""
    labels = load_hyperspace().labels(element)
    mus = [
        conditions_from_values(
            hyperspace_values({element: label, "friction": "1.0"}), profile="physical"
        ).mu
        for label in labels
    ]
    assert all(a > b for a, b in zip(mus, mus[1:], strict=False)), mus


def test_physical_flooded_road_keeps_handbook_wet_grip() -> None:
    """All three water elements at 100 do not compound below the handbook's wet range."""
    lo, hi = HANDBOOK_WET_RATIO
    soaked = {name: 100.0 for name in WATER}
    for friction in (0.2, 0.6, 1.0):
        cond = conditions_from_values({**soaked, "friction": friction}, profile="physical")
        assert lo * friction <= cond.mu <= hi * friction
        for name in WATER:  # each alone: wet, but not wetter than all of them
            alone = conditions_from_values({name: 100.0, "friction": friction}, profile="physical")
            assert cond.mu <= alone.mu <= hi * friction


def test_physical_damp_road_keeps_most_grip() -> None:
    """Thin dampness costs far less than a wet road (the inverse-S curve's plateau)."""
    damp = conditions_from_values({"wetness": 2}, profile="physical").mu
    wet = conditions_from_values({"wetness": 100}, profile="physical").mu
    assert damp > 0.95 and wet < 0.8


def test_physical_wind_pushes() -> None:
    low, high = _extremes("wind_intensity", "physical")
    assert low.wind_lateral_accel == 0.0
    # gale (Beaufort 8) on a 1.1 t saloon: RMS side force of the order of 1 m/s^2,
    # below the 2-3 m/s^2 that would blow a car off a dry road
    assert 0.3 < high.wind_lateral_accel < 2.0


# --- perception quantities (both profiles) -----------------------------------------------------


@pytest.mark.parametrize("element", WATER)
def test_water_adds_perception_noise(element: str) -> None:
    levels = [conditions_from_values({element: v}).rain_noise for v in range(0, 101, 20)]
    assert levels[0] == 0.0
    assert all(a < b for a, b in zip(levels, levels[1:], strict=False))
    assert levels[-1] <= 1.0


def test_fog_density_lowers_visibility() -> None:
    low, high = _extremes("fog_density")
    assert high.fog_extinction > low.fog_extinction
    assert high.visibility < low.visibility
    dense = conditions_from_values({"fog_density": 100})
    assert 10.0 < dense.visibility < 50.0  # "dense fog" in road-weather practice: < 50 m
    # Koschmieder's visibility is where 2 % of the contrast survives
    assert dense.transmittance(dense.visibility) == pytest.approx(0.02, rel=0.01)


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
    assert far.transmittance(far.fog_start) == 1.0


def test_cloudiness_dims_illumination() -> None:
    levels = [conditions_from_values({"cloudiness": c}).illumination for c in range(0, 101, 10)]
    assert all(a >= b for a, b in zip(levels, levels[1:], strict=False))
    # overcast lets through 15-40 % of clear-sky irradiance; scattered cloud hardly dims
    assert 0.15 < levels[-1] < 0.4
    assert levels[5] > 0.8


def test_rain_angle_follows_wind() -> None:
    calm = conditions_from_values({"precipitation": 80, "wind_intensity": 0})
    windy = conditions_from_values({"precipitation": 80, "wind_intensity": 100}, wind_direction=1.0)
    assert calm.raw["rain_angle"] == 0.0
    assert math.radians(30) < windy.raw["rain_angle"] < math.radians(90)
    assert windy.raw["wind_direction"] == 1.0


@pytest.mark.parametrize("profile", PHYSICS_PROFILES)
def test_every_environment_element_moves_something(profile: str) -> None:
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
        low, high = _extremes(element, profile)
        moved = [f for f in fields if getattr(low, f) != getattr(high, f)]
        assert moved, f"{element} has no effect"


def test_bad_value_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match="fog_density"):
        conditions_from_values({"fog_density": "thick"})
    with pytest.raises(ConfigError, match="friction"):
        conditions_from_values({"friction": float("nan")})


def test_unknown_profile_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match=r"profile: expected carla \| physical"):
        conditions_from_values({}, profile="realistic")
