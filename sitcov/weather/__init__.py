"""Weather and road state: CARLA-unit environment values -> the physical conditions of a run.

The bottom layer shared by the simulators (which read grip and wind force), the sensors
(which read fog, light and rain) and the calibration; it imports nothing of sitcov but its
errors. Which weather reaches the vehicles is the physics profile (``PHYSICS_PROFILES``,
docs/weather.md).
"""

from sitcov.weather._conditions import (
    PHYSICS_PROFILES,
    WEATHER_ELEMENTS,
    Conditions,
    check_profile,
    conditions_from_values,
    fog_transmittance,
    rain_wind_of,
)

__all__ = [
    "PHYSICS_PROFILES",
    "WEATHER_ELEMENTS",
    "Conditions",
    "check_profile",
    "conditions_from_values",
    "fog_transmittance",
    "rain_wind_of",
]
