"""Weather and road state in CARLA units -> the physical quantities dynamics and sensors use.

Every environment element of the default hyperspace moves at least one quantity of
:class:`Conditions`; the numbers and their sources are in ``docs/weather.md``.
Missing elements take clear-weather, dry-road defaults (CARLA's ``ClearNoon``).

Two physics profiles (``PHYSICS_PROFILES``) decide what weather does to the vehicles:
``carla`` (the default) does what CARLA 0.9.x does, nothing (tyre friction is the friction
element; wetness, rain, puddles, fog and clouds reach only the camera; wind only slants the
rain); ``physical`` adds the real-world couplings, a wet-road grip loss and a crosswind
force, each with its source. Perception quantities are the same in both.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from sitcov.errors import ConfigError


@dataclass(frozen=True)
class Conditions:
    """Physical quantities derived from a situation's environment elements.

    Dynamics read ``mu`` and ``wind_lateral_accel``; sensors read the rest. The mapping
    from CARLA-unit weather values to these quantities is documented in
    ``sitcov.sim.conditions_from_values``.

    Attributes:
        mu: effective tyre-road friction coefficient [-].
        fog_extinction: fog extinction coefficient beta [1/m] (Koschmieder: visibility 3.912/beta).
        fog_start: distance from the camera at which fog begins [m].
        illumination: relative scene illumination in (0, 1], 1 = clear noon.
        rain_noise: perception noise intensity in [0, 1] from rain, spray and glare.
        wind_speed: mean wind speed [m/s].
        wind_lateral_accel: RMS of the wind's lateral acceleration [m/s^2] (0 in the
            ``carla`` physics profile: CARLA's wind moves no vehicle).
        rain_wind: the precipitation times the wind intensity, both as fractions of 100
            [-]: the rain the wind slants, which a camera's detector sees differently
            (the PEM's ``noise_up_rain_wind_gain``; docs/pem.md, "The wind in the rain").
        raw: the environment values as given (CARLA units), for renderers.
    """

    mu: float = 1.0
    fog_extinction: float = 0.0
    fog_start: float = 0.0
    illumination: float = 1.0
    rain_noise: float = 0.0
    wind_speed: float = 0.0
    wind_lateral_accel: float = 0.0
    rain_wind: float = 0.0
    raw: dict[str, Any] = field(default_factory=dict)

    def transmittance(self, distance: float) -> float:
        """Fraction of contrast that survives fog over ``distance`` metres
        (Koschmieder, :func:`fog_transmittance`)."""
        return fog_transmittance(self.fog_extinction, self.fog_start, distance)

    @property
    def visibility(self) -> float:
        """Meteorological visibility [m] (inf without fog)."""
        if self.fog_extinction <= 0:
            return math.inf
        return self.fog_start + KOSCHMIEDER / self.fog_extinction


#: Koschmieder's constant: -ln(0.02), the 2 % contrast threshold that defines the
#: meteorological visibility V (contrast transmittance exp(-3.912 d / V) = 0.02 at d = V).
KOSCHMIEDER = 3.912


def fog_transmittance(extinction: float, start: float, distance: float) -> float:
    """Contrast transmittance of the air between the camera and a point ``distance`` m away.

    Koschmieder's law, ``T = exp(-3.912 * d_fog / V)``: ``V = 3.912 / extinction`` is the
    visibility [m] of the fog itself and ``d_fog = max(0, distance - start)`` the part of
    the line of sight inside it [m]. That is CARLA's exponential (height) fog seen along a
    level ray: no fog before ``fog_distance`` metres from the camera, then a constant
    density (its height falloff does not act at the camera's height). An object's colour
    reaches the camera as ``T * colour + (1 - T) * airlight`` (the renderer) and its
    contrast against the fog as ``T`` times its own (the PEM's contrast term).

    This is THE fog law of sitcov: :meth:`Conditions.transmittance`, the renderer (every
    road user's faces, the ground per pixel and the sky) and the PEM's compiled score
    (``perception._pem``, as a numba helper: keep it scalar, plain ``math``) all call it.

    Args:
        extinction: the fog's extinction coefficient beta = 3.912 / V [1/m]
            (``Conditions.fog_extinction``).
        start: where the fog starts, from the camera [m] (``Conditions.fog_start``).
        distance: length of the line of sight [m].

    Returns:
        T in (0, 1]: 1 before the fog starts.
    """
    beyond = distance - start
    return math.exp(-extinction * (beyond if beyond > 0.0 else 0.0))


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

#: Physics profiles: how weather reaches the vehicles (see ``docs/weather.md``).
#: ``carla``: as CARLA 0.9.x, weather acts on the camera only; ``physical``: wet-road grip
#: and crosswind force as well.
PHYSICS_PROFILES: tuple[str, ...] = ("carla", "physical")

# --- physical profile: one water-film state, one wet/dry grip curve ----------------------
#: Water-film depth on a fully wet road (wetness 100) [mm]: the thin-film range in which
#: Kulakowski & Harwood (ASTM STP 1031, 1990) measured most of the friction loss.
FILM_WET = 0.25
#: Water-film depth in heavy rain (precipitation 100) [mm]: order of the film a road
#: carries in heavy rain (Gallaway et al., FHWA-RD-79-31, 1979).
FILM_RAIN = 1.0
#: Depth of standing water in puddles (precipitation_deposits = their area share) [mm].
FILM_PUDDLE = 3.0
#: Wet/dry grip ratio once the film is thick [-]: Wong, *Theory of Ground Vehicles*
#: (Table 1.3): asphalt peak friction 0.8-0.9 dry, 0.5-0.7 wet; Do et al. (2014): the
#: damp state alone costs 30-40 %. 0.55 is the low end of the handbook's ratio.
WET_GRIP_RATIO = 0.55
#: Film depth at which half of the wet loss has happened [mm] (Kulakowski & Harwood:
#: friction falls significantly between 0.025 and 0.23 mm; Do et al.: inverse-S curve).
FILM_CRITICAL = 0.1

#: Extinction coefficient at fog_density 100 [1/m]: Koschmieder visibility 3.912/0.1565 = 25 m.
FOG_BETA_MAX = KOSCHMIEDER / 25.0
#: Clear-air extinction [1/m] (visibility ~ 20 km).
CLEAR_AIR_BETA = KOSCHMIEDER / 20000.0

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


def rain_wind_of(values: Mapping[str, Any]) -> float:
    """:attr:`Conditions.rain_wind` of environment ``values`` (CARLA units): the
    precipitation times the wind intensity, both as fractions of 100 [-]."""
    return _fraction(values, "precipitation") * _fraction(values, "wind_intensity")


def side_force_accel(wind_speed: float, mass: float = REFERENCE_MASS) -> float:
    """Lateral acceleration of a vehicle in a beam wind [m/s^2]: 0.5 rho C_y A v^2 / m."""
    return 0.5 * AIR_DENSITY * SIDE_FORCE_COEFF * SIDE_AREA * wind_speed * wind_speed / mass


def wet_grip_ratio(film_mm: float) -> float:
    """Wet/dry tyre-road grip ratio for a water film ``film_mm`` deep [-].

    An inverse-S curve (Do et al. 2014): dry grip while the film is far thinner than
    ``FILM_CRITICAL``, half the loss at it, ``WET_GRIP_RATIO`` once the film is thick.
    Full hydroplaning is not modelled: it needs ~90 km/h on a car tyre (Horne's
    hydroplaning speed, NASA TN D-2056), far above junction speeds.
    """
    if film_mm <= 0.0:
        return 1.0
    x = film_mm / FILM_CRITICAL
    return WET_GRIP_RATIO + (1.0 - WET_GRIP_RATIO) / (1.0 + x * x)


def road_grip_factor(wetness: float, precipitation: float, deposits: float) -> float:
    """Share of the dry grip the road keeps under water (physical profile) [-].

    The three elements describe ONE state, the water on the road, so they are not
    compounded as independent losses: the film between puddles is the thicker of the
    wet-road film (``wetness``) and the rain film (``precipitation``); ``deposits`` is
    the share of the road under standing water, whose grip is mixed in by area. All
    arguments are fractions in [0, 1].
    """
    film = max(FILM_WET * wetness, FILM_RAIN * precipitation)
    return (1.0 - deposits) * wet_grip_ratio(film) + deposits * wet_grip_ratio(FILM_PUDDLE)


def _friction(values: Mapping[str, Any]) -> float:
    """The friction element as a coefficient, clamped to 0.01..1.5."""
    raw = values.get("friction", DEFAULTS["friction"])
    try:
        friction = float(raw)
    except (TypeError, ValueError):
        raise ConfigError(field="friction", value=raw, expected="a number") from None
    if not math.isfinite(friction):
        raise ConfigError(field="friction", value=raw, expected="a number")
    return min(1.5, max(0.01, friction))


def check_profile(profile: str, field: str = "physics") -> str:
    """``profile`` if it is a known physics profile, else a one-line ConfigError."""
    if profile not in PHYSICS_PROFILES:
        raise ConfigError(field=field, value=profile, expected=" | ".join(PHYSICS_PROFILES))
    return profile


def conditions_from_values(
    values: Mapping[str, Any], *, wind_direction: float = 0.0, profile: str = "carla"
) -> Conditions:
    """Derive physical conditions from a situation's environment values (CARLA units).

    Args:
        values: element -> value; ``friction`` in 0.1..1.0, the others in 0..100.
            Other keys (e.g. ``intsit``) are ignored; missing elements are clear and dry.
        wind_direction: direction the wind blows towards, world frame [rad]; backends
            draw it from the run's random generator. Stored in ``raw`` for renderers.
        profile: ``carla`` (default): mu is the friction element alone and the wind
            pushes nothing, as in CARLA 0.9.x; ``physical``: mu also falls with the water
            on the road (:func:`road_grip_factor`) and the wind has a side force.

    Returns:
        Conditions: ``mu``, fog extinction and start, illumination (Kasten-Czeplak), rain
        noise, wind speed and (physical profile) its lateral acceleration. The
        perception quantities are the same in both profiles.

    Raises:
        ConfigError: a value is not a number, or an unknown profile.
    """
    check_profile(profile, "profile")
    friction = _friction(values)
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

    physical = profile == "physical"
    mu = friction * road_grip_factor(wet, rain, deposits) if physical else friction
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
        wind_lateral_accel=side_force_accel(wind_speed) * _RMS_SIN2 if physical else 0.0,
        rain_wind=rain_wind_of(values),
        raw=raw,
    )
