"""Weather and road state in CARLA units -> the physical quantities dynamics and sensors use.

Every environment element of the default hyperspace moves at least one quantity of
:class:`~sitcov.sim.Conditions`; the numbers and their sources are in ``docs/weather.md``.
Missing elements take clear-weather, dry-road defaults (CARLA's ``ClearNoon``).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from sitcov.errors import ConfigError
from sitcov.sim._base import Conditions

#: Clear, dry defaults in CARLA units (percent 0..100; friction is a coefficient).
DEFAULTS: dict[str, float] = {
    "cloudiness": 0.0,
    "precipitation": 0.0,
    "precipitation_deposits": 0.0,
    "wind_intensity": 0.0,
    "fog_density": 0.0,
    "fog_distance": 0.0,
    "wetness": 0.0,
    "friction": 1.0,
}

#: The environment elements that are weather parameters (carla.WeatherParameters names).
WEATHER_ELEMENTS: tuple[str, ...] = tuple(name for name in DEFAULTS if name != "friction")

#: Friction loss on a fully wet surface (wetness 100) [-]: wet asphalt keeps ~0.7 of dry.
WET_LOSS = 0.30
#: Extra loss from heavy rain (precipitation 100): a thicker water film [-].
RAIN_LOSS = 0.10
#: Extra loss from standing water (precipitation_deposits 100): puddles, partial aquaplaning [-].
DEPOSIT_LOSS = 0.15
# With everything at 100 the road keeps 1 - 0.55 = 45 % of its dry grip.

#: Extinction coefficient at fog_density 100 [1/m]: Koschmieder visibility 3.912/0.1565 = 25 m.
FOG_BETA_MAX = 3.912 / 25.0
#: Clear-air extinction [1/m] (visibility ~ 20 km).
CLEAR_AIR_BETA = 3.912 / 20000.0

#: Kasten-Czeplak cloud factor: G/G_clear = 1 - K_A * N**K_B, N = cloud fraction.
KASTEN_A = 0.75
KASTEN_B = 3.4

#: Weights of the perception-noise sources (rain streaks, spray from deposits, wet glare).
RAIN_NOISE_PRECIP = 0.6
RAIN_NOISE_DEPOSITS = 0.25
RAIN_NOISE_WETNESS = 0.15

#: Mean wind speed at wind_intensity 100 [m/s] (Beaufort 8, "gale": 17.2-20.7 m/s).
WIND_SPEED_MAX = 20.0
#: Air density at 15 C, sea level [kg/m^3].
AIR_DENSITY = 1.225
#: Side-force coefficient of a saloon car in a beam wind [-].
SIDE_FORCE_COEFF = 0.8
#: Side area of the reference vehicle: length 4.508 m x height 1.45 m [m^2].
SIDE_AREA = 4.508 * 1.45
#: Mass of the reference vehicle (CommonRoad vehicle 2, BMW 320i) [kg].
REFERENCE_MASS = 1093.3
#: Terminal fall speed of a ~2 mm raindrop [m/s] (Gunn & Kinzer 1949), for the rain angle.
RAIN_FALL_SPEED = 6.5
#: RMS of sin^2 over a uniformly distributed wind direction: sqrt(3/8) [-].
_RMS_SIN2 = math.sqrt(3.0 / 8.0)


def _fraction(values: Mapping[str, Any], name: str) -> float:
    """A 0..100 CARLA percentage as a fraction in [0, 1]."""
    raw = values.get(name, DEFAULTS[name])
    try:
        number = float(raw)
    except (TypeError, ValueError):
        raise ConfigError(field=name, value=raw, expected="a number in 0..100") from None
    if not math.isfinite(number):
        raise ConfigError(field=name, value=raw, expected="a number in 0..100")
    return min(1.0, max(0.0, number / 100.0))


def side_force_accel(wind_speed: float, mass: float = REFERENCE_MASS) -> float:
    """Lateral acceleration of a vehicle in a beam wind [m/s^2]: 0.5 rho C_y A v^2 / m."""
    return 0.5 * AIR_DENSITY * SIDE_FORCE_COEFF * SIDE_AREA * wind_speed * wind_speed / mass


def conditions_from_values(values: Mapping[str, Any], *, wind_direction: float = 0.0) -> Conditions:
    """Derive physical conditions from a situation's environment values (CARLA units).

    Args:
        values: element -> value; ``friction`` in 0.1..1.0, the others in 0..100.
            Other keys (e.g. ``intsit``) are ignored; missing elements are clear and dry.
        wind_direction: direction the wind blows towards, world frame [rad]; backends
            draw it from the run's random generator. Stored in ``raw`` for renderers.

    Returns:
        Conditions: ``mu`` (friction x wet-road factor), fog extinction and start,
        illumination (Kasten-Czeplak), rain noise, wind speed and its lateral acceleration.

    Raises:
        ConfigError: a value is not a number.
    """
    raw_friction = values.get("friction", DEFAULTS["friction"])
    try:
        friction = float(raw_friction)
    except (TypeError, ValueError):
        raise ConfigError(field="friction", value=raw_friction, expected="a number") from None
    friction = min(1.5, max(0.01, friction))
    wet = _fraction(values, "wetness")
    rain = _fraction(values, "precipitation")
    deposits = _fraction(values, "precipitation_deposits")
    cloud = _fraction(values, "cloudiness")
    fog = _fraction(values, "fog_density")
    wind = _fraction(values, "wind_intensity")
    fog_distance_raw = values.get("fog_distance", DEFAULTS["fog_distance"])
    try:
        fog_start = max(0.0, float(fog_distance_raw))
    except (TypeError, ValueError):
        raise ConfigError(field="fog_distance", value=fog_distance_raw, expected="metres") from None

    mu = friction * (1.0 - WET_LOSS * wet - RAIN_LOSS * rain - DEPOSIT_LOSS * deposits)
    beta = CLEAR_AIR_BETA + FOG_BETA_MAX * fog
    illumination = 1.0 - KASTEN_A * cloud**KASTEN_B
    rain_noise = 1.0 - (
        (1.0 - RAIN_NOISE_PRECIP * rain)
        * (1.0 - RAIN_NOISE_DEPOSITS * deposits)
        * (1.0 - RAIN_NOISE_WETNESS * wet)
    )
    wind_speed = WIND_SPEED_MAX * wind
    raw = {k: v for k, v in values.items() if k in DEFAULTS}
    raw["wind_direction"] = float(wind_direction)
    raw["rain_angle"] = math.atan2(wind_speed, RAIN_FALL_SPEED) if rain > 0 else 0.0
    return Conditions(
        mu=mu,
        fog_extinction=beta,
        fog_start=fog_start,
        illumination=illumination,
        rain_noise=rain_noise,
        wind_speed=wind_speed,
        wind_lateral_accel=side_force_accel(wind_speed) * _RMS_SIN2,
        raw=raw,
    )
