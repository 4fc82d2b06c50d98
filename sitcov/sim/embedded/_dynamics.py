"""Single-track (bicycle) vehicle dynamics with saturating tyres, in plain-float Python.

Parameters are CommonRoad's vehicle 2 (BMW 320i), read once from
``vehiclemodels.parameters_vehicle2``. The model is integrated here rather than with
CommonRoad's functions, which are far too slow to call every 25 ms sub-step:

- lateral tyre force ``Fy = Fy_max * tanh(C * Fz * alpha / Fy_max)``: linear with the
  cornering stiffness for small slip angles, saturating at the friction limit;
- combined slip by a friction ellipse: ``Fy_max = sqrt((mu*Fz)^2 - Fx^2)``;
- braking as ABS does it (force split by axle load, each axle's longitudinal force,
  rolling resistance included, capped at ``ABS_SHARE * mu * Fz``), so a full brake
  decelerates at ~``0.9 * min(mu, brake_max) * g`` and the tyres keep at least
  ``sqrt(1 - ABS_SHARE^2) = 44 %`` of their grip for steering; the same cap holds the
  drive (traction control); rear-wheel drive, up to ~3 m/s^2;
- below ``V_KIN_LOW`` the kinematic single-track model, blended into the dynamic one up to
  ``V_KIN_HIGH``, because tyre slip angles are ill-defined at walking pace (and the
  explicit sub-step would be unstable); the kinematic model gets its velocity change
  from the tyres too, so its accelerations (path curvature, snapping the direction of
  travel) never exceed ``mu * g``.

The integrator is one plain-float function (:func:`integrate`) that numba compiles when
it is installed (``_jit.py``: same bits, about three times as fast per call).

See ``docs/embedded.md`` for the equations.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from math import atan, atan2, cos, pi, sin, sqrt, tan, tanh
from typing import Any

import numpy as np

from sitcov.sim.embedded._path import _track as track

G = 9.81  #: gravity [m/s^2]
#: Control period [s] and dynamic sub-steps per period.
DT = 0.05
SUBSTEPS = 2
#: Speeds [m/s] between which the kinematic model hands over to the dynamic one.
V_KIN_LOW = 2.0
V_KIN_HIGH = 4.0
#: Height of a saloon car for sensors and renderers [m].
VEHICLE_HEIGHT = 1.45
#: Share of an axle's grip mu*Fz its longitudinal force may use (ABS / traction control)
#: [-]. CommonRoad's own Pacejka tyre for this car (vehiclemodels parameters_vehicle2,
#: MF combined slip) at the slip of peak braking force (~0.16, where ABS holds the
#: wheel) and a 0.05 rad slip angle gives 0.93 of the peak braking force and 0.55 of the
#: peak side force; the ellipse with 0.9 leaves 0.44, a little less (conservative).
ABS_SHARE = 0.9
#: ``math.hypot`` under the name :func:`integrate` uses (``_jit.py`` compiles that code
#: with a bit-identical replacement).
hypot = math.hypot


@dataclass(frozen=True)
class VehicleParams:
    """Physical parameters of a vehicle (SI units).

    Attributes:
        mass: [kg]. iz: yaw inertia [kg m^2]. lf, lr: centre of gravity to front/rear axle [m].
        h_cg: height of the centre of gravity [m]. length, width, height: body [m].
        steer_max: maximum road-wheel angle [rad]. c_front, c_rear: normalised cornering
            stiffness, lateral force per unit load per radian [1/rad].
        accel_max: full-throttle acceleration at low speed [m/s^2].
        power: engine power limit at the wheels [W]. brake_max: full-brake deceleration on
            a dry road [g]. drag: aerodynamic drag 0.5*rho*cd*A [kg/m]. roll: rolling
            resistance coefficient [-].
    """

    mass: float
    iz: float
    lf: float
    lr: float
    h_cg: float
    length: float
    width: float
    height: float
    steer_max: float
    c_front: float
    c_rear: float
    accel_max: float = 3.0
    power: float = 100_000.0
    brake_max: float = 1.0
    drag: float = 0.5 * 1.225 * 0.29 * 2.2
    roll: float = 0.012

    @property
    def wheelbase(self) -> float:
        """lf + lr [m]."""
        return self.lf + self.lr


def bmw_320i() -> VehicleParams:
    """CommonRoad vehicle 2 (BMW 320i): mass, inertia, geometry, steering, tyre stiffness."""
    from vehiclemodels.parameters_vehicle2 import parameters_vehicle2

    p = parameters_vehicle2()
    stiffness = -p.tire.p_ky1 / p.tire.p_dy1  # as CommonRoad's ST model derives C_S
    return VehicleParams(
        mass=float(p.m),
        iz=float(p.I_z),
        lf=float(p.a),
        lr=float(p.b),
        h_cg=float(p.h_cg),
        length=float(p.l),
        width=float(p.w),
        height=VEHICLE_HEIGHT,
        steer_max=float(p.steering.max),
        c_front=float(stiffness),
        c_rear=float(stiffness),
    )


def integrate(
    k: tuple[float, ...],
    x: float,
    y: float,
    yaw: float,
    vx: float,
    vy: float,
    r: float,
    throttle: float,
    brake: float,
    delta: float,
    mu: float,
    lateral_accel: float,
    dt: float,
    substeps: int,
) -> tuple[float, float, float, float, float, float]:
    """``substeps`` explicit sub-steps of the single-track model (the equations of the
    module docstring): the new ``(x, y, yaw, vx, vy, r)``.

    ``k`` holds the vehicle's constants (``Vehicle._k``); commands are already clamped and
    ``delta`` is the road-wheel angle [rad]. Plain floats and module-level math functions
    only, so that numba can compile this very code (``_jit.py``): the floating-point
    operations and their order are those of the equations either way.
    """
    (m, iz, lf, lr, wb, fzf, fzr, cf, cr, fdrive, power, fbrake, drag, roll) = k
    h = dt / substeps
    share_f = fzf / (fzf + fzr)
    share_r = 1.0 - share_f
    muf, mur = mu * fzf, mu * fzr
    capf, capr = ABS_SHARE * muf, ABS_SHARE * mur
    mug = mu * G
    cos_d, sin_d, tan_d = cos(delta), sin(delta), tan(delta)
    cos_bk = sin_bk = 0.0
    if vx < V_KIN_HIGH + 1.0:  # the kinematic model may be needed this period
        beta_k = atan(lr * tan_d / wb)
        cos_bk, sin_bk = cos(beta_k), sin(beta_k)
    drive = fdrive * throttle
    fb = fbrake * brake
    for _ in range(substeps):
        v = hypot(vx, vy)
        # longitudinal tyre forces: drive (rear), brake split by axle load, rolling
        # resistance by axle load; each axle's net force within ABS_SHARE * mu * Fz
        fd = drive
        if v > 1.0 and fd * v > power * throttle:
            fd = power * throttle / v
        if v > 0.05:
            fxf = -(fb + roll) * share_f
            fxr = fd - (fb + roll) * share_r
            resist = drag * v * v
        else:
            fxf = -fb * share_f
            fxr = fd - fb * share_r
            resist = 0.0
        if fxf < -capf:
            fxf = -capf
        if fxr > capr:
            fxr = capr
        elif fxr < -capr:
            fxr = -capr
        if v >= V_KIN_HIGH:
            w = 1.0
        elif v <= V_KIN_LOW:
            w = 0.0
        else:
            w = (v - V_KIN_LOW) / (V_KIN_HIGH - V_KIN_LOW)
        if w > 0.0:
            # dynamic single-track with saturating tyres
            alpha_f = delta - atan2(vy + lf * r, vx)
            alpha_r = -atan2(vy - lr * r, vx)
            fyf_max = sqrt(muf * muf - fxf * fxf)
            fyr_max = sqrt(mur * mur - fxr * fxr)
            fyf = fyf_max * tanh(cf * alpha_f / fyf_max) if fyf_max > 0.0 else 0.0
            fyr = fyr_max * tanh(cr * alpha_r / fyr_max) if fyr_max > 0.0 else 0.0
            fyf_c = fxf * sin_d + fyf * cos_d
            vx_n = vx + ((fxf * cos_d - fyf * sin_d + fxr - resist) / m + vy * r) * h
            vy_n = vy + ((fyf_c + fyr) / m + lateral_accel - vx * r) * h
            r_n = r + ((lf * fyf_c - lr * fyr) / iz) * h
            if vx_n < 0.0:
                vx_n = 0.0
        if w < 1.0:
            # kinematic single-track (speed along the body, no slip): the target
            # velocity, reached only as far as the tyres' mu*g allows
            v_kin = v + (fxf + fxr - resist) / m * h
            if v_kin < 0.0:
                v_kin = 0.0
            r_k = v_kin * cos_bk * tan_d / wb
            if v_kin * abs(r_k) > mug:  # steady turn: v^2 * curvature <= mu*g
                r_k = mug / v_kin if r_k > 0.0 else -mug / v_kin
            ax = (v_kin * cos_bk - vx) / h - vy * r  # tyre force / m needed [m/s^2]
            ay = (v_kin * sin_bk - vy) / h + vx * r - lateral_accel
            need = hypot(ax, ay)
            if need > mug:
                ax, ay = ax * mug / need, ay * mug / need
            vx_k = vx + (ax + vy * r) * h
            vy_k = vy + (ay + lateral_accel - vx * r) * h
            if vx_k < 0.0:
                vx_k = 0.0
            if w > 0.0:
                vx_n = w * vx_n + (1.0 - w) * vx_k
                vy_n = w * vy_n + (1.0 - w) * vy_k
                r_n = w * r_n + (1.0 - w) * r_k
            else:
                vx_n, vy_n, r_n = vx_k, vy_k, r_k
        # position update with the mean velocity over the sub-step (semi-implicit)
        yaw_n = yaw + 0.5 * (r + r_n) * h
        mvx, mvy = 0.5 * (vx + vx_n), 0.5 * (vy + vy_n)
        c, s = cos(yaw), sin(yaw)
        x += (mvx * c - mvy * s) * h
        y += (mvx * s + mvy * c) * h
        yaw = yaw_n
        vx, vy, r = vx_n, vy_n, r_n
    return x, y, yaw, vx, vy, r


def integrate_tracked(
    k: tuple[float, ...],
    x: float,
    y: float,
    yaw: float,
    vx: float,
    vy: float,
    r: float,
    throttle: float,
    brake: float,
    delta: float,
    mu: float,
    lateral_accel: float,
    dt: float,
    substeps: int,
    route: Any,
    hint: int,
) -> tuple[float, float, float, float, float, float, float, int]:
    """:func:`integrate`, the heading wrapped to [-pi, pi], then the new position tracked
    on ``route`` from segment ``hint`` (``_path._track``): ``(x, y, yaw, vx, vy, r, s,
    segment)``. One compiled call per car and step instead of two (a call into numba
    costs more than either computation)."""
    x, y, yaw, vx, vy, r = integrate(
        k, x, y, yaw, vx, vy, r, throttle, brake, delta, mu, lateral_accel, dt, substeps
    )
    if yaw > pi or yaw < -pi:
        yaw = atan2(sin(yaw), cos(yaw))
    s, i = track(route, x, y, hint)
    return x, y, yaw, vx, vy, r, s, i


def move_tracked(
    k: Any,
    steer_max: float,
    x: float,
    y: float,
    yaw: float,
    vx: float,
    vy: float,
    r: float,
    throttle: float,
    brake: float,
    steer: float,
    mu: float,
    lateral_accel: float,
    dt: float,
    substeps: int,
    route: Any,
    hint: int,
) -> tuple[bool, float, float, float, float, float, float, float, float, int]:
    """:meth:`Vehicle.step` on a route: the commands clamped, then :func:`integrate_tracked`,
    or, standing with no drive, only the tracking (nothing moves: wind cannot push a
    braked car). ``(moved, steering angle, x, y, yaw, vx, vy, r, s, segment)``; the state
    is the one given when not ``moved``. One compiled call per car and step, the clamps
    included."""
    throttle = 0.0 if throttle < 0.0 else (1.0 if throttle > 1.0 else throttle)
    if throttle == 0.0 and vx == 0.0 and vy == 0.0 and r == 0.0:
        s, i = track(route, x, y, hint)
        return False, 0.0, x, y, yaw, vx, vy, r, s, i
    brake = 0.0 if brake < 0.0 else (1.0 if brake > 1.0 else brake)
    steer = -1.0 if steer < -1.0 else (1.0 if steer > 1.0 else steer)
    delta = steer * steer_max
    x, y, yaw, vx, vy, r, s, i = integrate_tracked(
        k, x, y, yaw, vx, vy, r, throttle, brake, delta, mu, lateral_accel, dt, substeps,
        route, hint,
    )  # fmt: skip
    return True, delta, x, y, yaw, vx, vy, r, s, i


_INTEGRATE: Any = None
_MOVE: Any = None


def _move_kernel() -> Any:
    """:func:`move_tracked` compiled by numba when it is installed, else itself."""
    global _MOVE
    if _MOVE is None:
        from sitcov._jit import compiled, typed_entry

        k = _constants(Vehicle(default_params(), 0.0, 0.0, 0.0)._k, True)
        route = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        example = (k, 0.6, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.1, 1.0, 0.0, DT, SUBSTEPS)
        helpers = (integrate, ("track", track), integrate_tracked)
        _MOVE = typed_entry(compiled(move_tracked, *example, route, 0, helpers=helpers))
        _MOVE = _MOVE or move_tracked
    return _MOVE


def _kernel() -> Any:
    """:func:`integrate` compiled by numba when it is installed (``_jit.py``), else itself."""
    global _INTEGRATE
    if _INTEGRATE is None:
        from sitcov._jit import compiled, typed_entry

        k = _constants(Vehicle(default_params(), 0.0, 0.0, 0.0)._k, True)
        example = (k, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.5, 0.0, 0.1, 1.0, 0.0, DT, SUBSTEPS)
        _INTEGRATE = typed_entry(compiled(integrate, *example)) or integrate
    return _INTEGRATE


def _constants(k: tuple[float, ...], as_array: bool | None = None) -> Any:
    """``Vehicle._k`` as the integrator takes it fastest: a float array for the compiled
    one (numba checks one array's type faster than 14 floats'), else the tuple."""
    if as_array is None:
        as_array = _kernel() is not integrate
    if not as_array:
        return k
    return np.array(k, dtype=np.float64)


_DEFAULT: VehicleParams | None = None


def default_params() -> VehicleParams:
    """The reference vehicle, built once per process."""
    global _DEFAULT
    if _DEFAULT is None:
        _DEFAULT = bmw_320i()
    return _DEFAULT


class Vehicle:
    """State and integrator of one single-track vehicle.

    State: position ``x, y`` [m] of the centre of gravity, heading ``yaw`` [rad], body-frame
    velocities ``vx`` (forward), ``vy`` (left) [m/s] and yaw rate ``r`` [rad/s]. The
    vehicle never reverses (there is no reverse gear in :class:`~sitcov.av.Control`).
    """

    __slots__ = ("p", "x", "y", "yaw", "vx", "vy", "r", "steer", "_k", "_kc")

    def __init__(
        self, params: VehicleParams, x: float, y: float, yaw: float, speed: float = 0.0
    ) -> None:
        self.p = params
        self.x, self.y, self.yaw = float(x), float(y), float(yaw)
        self.vx, self.vy, self.r = float(speed), 0.0, 0.0
        self.steer = 0.0
        m, g, lf, lr = params.mass, G, params.lf, params.lr
        wb = lf + lr
        fzf, fzr = m * g * lr / wb, m * g * lf / wb
        # constants used every sub-step
        self._k = (
            m,
            params.iz,
            lf,
            lr,
            wb,
            fzf,
            fzr,
            params.c_front * fzf,
            params.c_rear * fzr,
            params.accel_max * m,
            params.power,
            params.brake_max * m * g,
            params.drag,
            params.roll * m * g,
        )
        self._kc: Any = None  # _k as the integrator takes it (set at the first step)

    @property
    def speed(self) -> float:
        """Speed over ground [m/s]."""
        return math.hypot(self.vx, self.vy)

    def step(
        self,
        throttle: float,
        brake: float,
        steer: float,
        mu: float,
        lateral_accel: float = 0.0,
        dt: float = DT,
        substeps: int = SUBSTEPS,
        route: Any = None,
        hint: int = 0,
    ) -> tuple[float, int] | None:
        """Advance by ``dt`` under constant commands.

        Args:
            throttle, brake: in [0, 1]. steer: in [-1, 1], positive left, times steer_max.
            mu: tyre-road friction [-]. lateral_accel: external acceleration to the
                vehicle's left [m/s^2] (crosswind).
            route, hint: a path's points as its tracker takes them (``Path.tracker``)
                and the last segment: then the commands' clamps, the integration and the
                tracking of the new position are one compiled call (:func:`move_tracked`)
                and ``(s, segment)`` is returned (``_path._track``'s values); else None.
        """
        if route is not None:  # clamps, integration and tracking in one compiled call
            kc = self._kc
            if kc is None:
                kc = self._kc = _constants(self._k)
            moved, delta, x, y, yaw, vx, vy, r, s, i = (_MOVE or _move_kernel())(
                kc, self.p.steer_max, self.x, self.y, self.yaw, self.vx, self.vy, self.r,
                throttle, brake, steer, mu, lateral_accel, dt, substeps, route, hint,
            )  # fmt: skip
            if moved:
                self.x, self.y, self.yaw, self.vx, self.vy, self.r = x, y, yaw, vx, vy, r
                self.steer = delta
            return s, i
        throttle = 0.0 if throttle < 0.0 else (1.0 if throttle > 1.0 else throttle)
        vx, vy, r = self.vx, self.vy, self.r
        if throttle == 0.0 and vx == 0.0 and vy == 0.0 and r == 0.0:
            return None  # standing still with no drive: nothing moves (as move_tracked)
        brake = 0.0 if brake < 0.0 else (1.0 if brake > 1.0 else brake)
        steer = -1.0 if steer < -1.0 else (1.0 if steer > 1.0 else steer)
        self.steer = delta = steer * self.p.steer_max
        kc = self._kc
        if kc is None:
            kc = self._kc = _constants(self._k)
        x, y, yaw, self.vx, self.vy, self.r = (_INTEGRATE or _kernel())(
            kc, self.x, self.y, self.yaw, vx, vy, r, throttle, brake, delta, mu,
            lateral_accel, dt, substeps,
        )  # fmt: skip
        if yaw > math.pi or yaw < -math.pi:
            yaw = math.atan2(math.sin(yaw), math.cos(yaw))
        self.x, self.y, self.yaw = x, y, yaw
        return None
