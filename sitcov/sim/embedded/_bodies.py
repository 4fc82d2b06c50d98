"""Bodies of road users: how each kind moves under (throttle, brake, steer) commands.

Every body has the same small interface as :class:`~sitcov.sim.embedded._dynamics.Vehicle`
(the car): position ``x, y`` [m], heading ``yaw`` [rad], body-frame velocity ``vx``
(forward) and ``vy`` (left) [m/s], ``speed`` and ``step(throttle, brake, steer, mu,
lateral_accel, dt)`` with throttle, brake in [0, 1] and steer in [-1, 1]. Controllers
therefore drive any kind the same way; the body decides what a command means.

- ``car``: the single-track vehicle with saturating tyres (``_dynamics.Vehicle``, a BMW 320i).
- ``cyclist``: :class:`Bicycle`, the kinematic bicycle model, 0 to 8 m/s.
- ``pedestrian``: :class:`Walker`, a point mass with acceleration limits that turns on the
  spot at a limited rate.

Parameters are data (:data:`BODY_SPECS`), each with its source.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sitcov.errors import ConfigError
from sitcov.sim.embedded._dynamics import G, Vehicle, default_params


@dataclass(frozen=True)
class BodySpec:
    """Size and limits of one kind of road user (SI units).

    Attributes:
        kind: ``car``, ``cyclist`` or ``pedestrian``.
        length, width, height: the box sensors see and collisions use [m].
        v_max: top speed [m/s]. a_max: full-throttle acceleration [m/s^2].
        b_max: full-brake deceleration on a dry road [m/s^2] (capped by mu g).
        wheelbase: [m] (bicycle). steer_max: largest steering angle [rad] (bicycle).
        turn_rate: largest heading rate [rad/s] (pedestrian).
        walk_speed: a pedestrian's or cyclist's ordinary cruising speed [m/s].
    """

    kind: str
    length: float
    width: float
    height: float
    v_max: float
    a_max: float
    b_max: float
    wheelbase: float = 0.0
    steer_max: float = 0.0
    turn_rate: float = 0.0
    walk_speed: float = 0.0


def _car_spec() -> BodySpec:
    p = default_params()
    return BodySpec("car", p.length, p.width, p.height, 50.0, p.accel_max, p.brake_max * G)


#: Body parameters per kind. Sources:
#: - car: CommonRoad vehicle 2 (BMW 320i), see ``_dynamics.py``; the limits here are only
#:   descriptive, the single-track model has its own.
#: - cyclist: box 1.8 x 0.6 x 1.7 m (bicycle plus upright rider; a city bicycle is
#:   1.7-1.9 m long, handlebars ~0.6 m wide); speed 0-8 m/s (0-29 km/h, the range of
#:   urban cycling); acceleration 1.5 m/s^2 and braking 3.5 m/s^2 are assumed values of
#:   the usual order for a pedal cyclist's start-up and hard (two-brake) stop; wheelbase
#:   1.1 m and steering limit 0.6 rad of a city bicycle; cruise 4.5 m/s (~16 km/h).
#: - pedestrian: box 0.5 x 0.5 x 1.75 m (shoulder width and stature of an adult); walking
#:   0.8-1.8 m/s, cruise 1.4 m/s (Knoblauch et al. 1996, TRR 1538: mean crossing speeds
#:   1.25-1.5 m/s, slow walkers ~0.9 m/s), running up to 3 m/s; acceleration 1.5 m/s^2
#:   and deceleration 2.0 m/s^2 (assumed: a pedestrian reaches walking speed within about
#:   a second and can stop within a step or two); turn rate 4 rad/s (assumed).
BODY_SPECS: dict[str, BodySpec] = {
    "cyclist": BodySpec(
        "cyclist", 1.8, 0.6, 1.7, 8.0, 1.5, 3.5, wheelbase=1.1, steer_max=0.6, walk_speed=4.5
    ),
    "pedestrian": BodySpec(
        "pedestrian", 0.5, 0.5, 1.75, 3.0, 1.5, 2.0, turn_rate=4.0, walk_speed=1.4
    ),
}


@dataclass(frozen=True)
class SpeedDistribution:
    """A normal distribution of cruising speeds truncated to a plausible range [m/s]."""

    mean: float
    sd: float
    low: float
    high: float

    def draw(self, rng: np.random.Generator) -> float:
        """One speed [m/s]: normal draws until one falls in [low, high] (a fixed number of
        draws per value, so the stream stays reproducible)."""
        for _ in range(64):
            v = float(rng.normal(self.mean, self.sd))
            if self.low <= v <= self.high:
                return v
        return self.mean


#: How fast people walk and ride, drawn per actor and run (``_scene``), so timed road users
#: meet the ego by when and where they start, not by creeping. Sources:
#: - pedestrian: free walking speed, mean 1.34 m/s, standard deviation 0.26 m/s (Weidmann
#:   1993, "Transporttechnik der Fussgaenger", ETH Zuerich IVT Schriftenreihe 90, the
#:   meta-analysis of 58 studies), kept within 1.0-1.8 m/s: Knoblauch, Pietrucha & Nitzburg
#:   1996 (TRR 1538) measured mean crossing speeds 1.27 m/s (over 65) to 1.51 m/s (younger),
#:   15th percentiles 0.97-1.25 m/s; HCM 2010 designs crosswalks for 1.07-1.2 m/s.
#: - cyclist: mean 4.8 m/s (17 km/h), standard deviation 0.9 m/s, kept within 3-7 m/s: the
#:   bulk of free-flow bicycle speeds in the studies compiled by Allen et al. 1998
#:   ("Operational analysis of uninterrupted bicycle facilities", TRR 1636) lies between
#:   7.5 and 12.4 mph (3.4-5.5 m/s); regular bicycles in mixed urban traffic average 3.7 m/s
#:   (Hangzhou; Adv. Mech. Eng. 2015, doi:10.1177/1687814015616918); commuters on the flat
#:   ride faster, ~6 m/s (Parkin & Rotheram 2010, Transport Policy 17).
SPEEDS: dict[str, SpeedDistribution] = {
    "pedestrian": SpeedDistribution(1.34, 0.26, 1.0, 1.8),
    "cyclist": SpeedDistribution(4.8, 0.9, 3.0, 7.0),
}


def body_spec(kind: str) -> BodySpec:
    """The :class:`BodySpec` of ``kind`` (``car``, ``cyclist``, ``pedestrian``)."""
    if kind == "car":
        return _car_spec()
    spec = BODY_SPECS.get(kind)
    if spec is None:
        raise ConfigError(field="kind", value=kind, expected="car | cyclist | pedestrian")
    return spec


class _KinematicBody:
    """State shared by the kinematic bodies: pose, speed along the heading (``vx``) and a
    lateral speed that stays 0 (kept so every body has the car's ``vx``/``vy``)."""

    __slots__ = ("spec", "x", "y", "yaw", "vx", "vy")

    def __init__(self, spec: BodySpec, x: float, y: float, yaw: float, speed: float = 0.0):
        self.spec = spec
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        self.vx, self.vy = float(speed), 0.0

    @property
    def speed(self) -> float:
        """Speed over ground [m/s]."""
        return self.vx


class Bicycle(_KinematicBody):
    """Kinematic bicycle (rear-axle reference, centre of the box used as position).

    The speed changes by ``a_max * throttle - b_max * brake`` (braking capped by the road's
    ``mu g``) and stays in ``[0, v_max]``; the heading turns at ``v tan(delta) / wheelbase``
    with ``delta = steer * steer_max``, its lateral acceleration capped at ``mu g``.
    Crosswind is ignored (a rider leans into it).
    """

    __slots__ = ()

    def step(
        self,
        throttle: float,
        brake: float,
        steer: float,
        mu: float,
        lateral_accel: float = 0.0,
        dt: float = 0.05,
    ) -> None:
        """Advance by ``dt`` [s] under constant commands (see the class docstring)."""
        p = self.spec
        v0 = self.vx
        accel = p.a_max * min(max(throttle, 0.0), 1.0)
        accel -= min(p.b_max * min(max(brake, 0.0), 1.0), mu * G)
        v1 = min(max(v0 + accel * dt, 0.0), p.v_max)
        v = 0.5 * (v0 + v1)
        rate = v * math.tan(min(max(steer, -1.0), 1.0) * p.steer_max) / p.wheelbase
        if v > 0.0 and abs(rate) * v > mu * G:
            rate = math.copysign(mu * G / v, rate)
        yaw = self.yaw + 0.5 * rate * dt
        self.x += v * math.cos(yaw) * dt
        self.y += v * math.sin(yaw) * dt
        self.yaw = math.atan2(math.sin(self.yaw + rate * dt), math.cos(self.yaw + rate * dt))
        self.vx = v1


class Walker(_KinematicBody):
    """A pedestrian: point mass with acceleration limits, heading turned at a limited rate.

    ``throttle`` accelerates at up to ``a_max``, ``brake`` decelerates at up to ``b_max``;
    the speed stays in ``[0, v_max]``; ``steer`` in [-1, 1] turns the heading at that
    fraction of ``turn_rate`` (a person turns on the spot). Wind is ignored.
    """

    __slots__ = ()

    def step(
        self,
        throttle: float,
        brake: float,
        steer: float,
        mu: float,
        lateral_accel: float = 0.0,
        dt: float = 0.05,
    ) -> None:
        """Advance by ``dt`` [s] under constant commands (see the class docstring)."""
        p = self.spec
        v0 = self.vx
        if v0 == 0.0 and throttle <= 0.0 and steer == 0.0:
            return  # standing, not starting, not turning: nothing changes
        accel = p.a_max * min(max(throttle, 0.0), 1.0) - p.b_max * min(max(brake, 0.0), 1.0)
        v1 = min(max(v0 + accel * dt, 0.0), p.v_max)
        yaw = self.yaw + min(max(steer, -1.0), 1.0) * p.turn_rate * dt
        v = 0.5 * (v0 + v1)
        self.x += v * math.cos(yaw) * dt
        self.y += v * math.sin(yaw) * dt
        self.yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        self.vx = v1


Body = Vehicle | Bicycle | Walker


def make_body(kind: str, x: float, y: float, yaw: float) -> Body:
    """A body of ``kind`` standing at (x, y) with heading ``yaw``."""
    if kind == "car":
        return Vehicle(default_params(), x, y, yaw)
    spec = body_spec(kind)
    return Bicycle(spec, x, y, yaw) if kind == "cyclist" else Walker(spec, x, y, yaw)
