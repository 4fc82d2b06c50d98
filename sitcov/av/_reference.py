"""The reference modular ego stack: route following by PID, camera perception and an AEB.

This is the stack of the paper (Tahir & Alexander): CARLA's local planner and PID
controllers drive the route at 25 km/h; a camera-only perception stage feeds an emergency
brake that fires when a detection of a road user (by default a car, a person or a bicycle:
the ``classes`` parameter) passes three tests (score, centering, apparent size: the box
width for a car, the scaled box height for a person or cyclist, :data:`CLASS_SIZE`).
Once fired, it brakes fully to a standstill, holds while frames still trigger it and for
``aeb_hold`` seconds after the last one that did, then hands back to route following, so
the stack can finish its route after a stop. The paper's brake latched until the end of
the run: that is the ``aeb_latch`` parameter, and the stack named ``reference-latched``
(:class:`LatchedReferenceStack`), which the paper's Table 2 protocol uses. The seeded
faults change the three tests' parameters (see :mod:`sitcov.av._faults`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from math import atan2, cos, sin
from typing import Any, ClassVar

import numpy as np

from sitcov.av._aeb import aeb_min_box_sizes, aeb_min_box_width, aeb_test
from sitcov.av._base import AVStack, Control, Observation, RunInfo
from sitcov.av._faults import resolve_params
from sitcov.av._pid import window_pid
from sitcov.perception._base import CameraSpec, Detection

Detector = Callable[[Any], Sequence[Detection]]

#: The releasing AEB hands back only once the car stands (below this speed [m/s]): like a
#: production AEB it brakes to a standstill and holds there (the judge's stationary speed).
_HELD_SPEED = 0.3
#: Distance to the last route point at which the route counts as driven [m] (CARLA: 1 m).
_ARRIVED = 1.0
#: ``math.hypot`` under the name :func:`_route_step` uses (``sitcov/_jit.py``
#: compiles that code with a bit-identical replacement).
hypot = math.hypot


class ReferenceStack(AVStack):
    """The paper's ego stack, with faults and every parameter configurable.

    Args:
        fault: ``None`` or a key of :data:`sitcov.av.FAULTS` (``"f1"``, ``"f1-raw"``, ``"f2"``,
            ``"f3"``, ``"f4"``; F1 relative to the detector, see :mod:`sitcov.av._fault_map`;
            F4: the AEB ignores pedestrians).
        params: overrides of :data:`sitcov.av.DEFAULT_PARAMS` (applied after the fault).
        aeb: False disables the emergency brake (the stack then ignores perception).
        detector: camera mode only: ``image -> detections``; defaults lazily to
            ``sitcov.perception.SSDDetector()``.

    Raises:
        ConfigError: unknown fault or parameter, or an invalid value.
    """

    name: ClassVar[str] = "reference"

    def __init__(
        self,
        fault: str | None = None,
        params: Mapping[str, Any] | None = None,
        aeb: bool = True,
        detector: Detector | None = None,
    ) -> None:
        self.fault = fault
        self.params = resolve_params(fault, params)
        self.aeb = bool(aeb)
        self.detector = detector
        self.camera = CameraSpec()
        p = self.params
        self._threshold = p["threshold"]
        self._centering = p["centering"]
        self._distance = p["distance"]
        self.min_box_width = aeb_min_box_width(self._distance) if self.aeb else math.inf
        self.aeb_latches = bool(p["aeb_latch"])
        self._hold = float(p["aeb_hold"])
        self._label = p["label"]
        self._classes = frozenset((*p["classes"], p["label"]))
        self.min_box_sizes = (
            aeb_min_box_sizes(self._distance, self._classes, self.camera) if self.aeb else {}
        )
        # the centering test: a detection centred outside it never fires the AEB
        self.centre_window = (float(self._centering[0]), float(self._centering[1]))
        self._route: tuple[tuple[float, float], ...] = ()
        self._dt = 0.05
        self._reset_state()

    def _reset_state(self) -> None:
        self._steer = 0.0
        self._fired_at: float | None = None  # latched: when it fired
        self._braking_since: float | None = None  # releasing AEB: when it fired, while on
        self._clear_since: float | None = None  # ... and since when no frame triggered it
        self._state: Any = None  # the route step's array, made at the first step

    def reset(self, info: RunInfo) -> None:
        """Start a run: take the route, camera and control period; clear the AEB latch."""
        self._route = tuple(info.route) or (tuple(info.goal),)
        self.camera = info.camera
        self._dt = float(info.dt)
        self._reset_state()

    def _start(self) -> None:
        """The route step's array for this run (:func:`route_state`): gains, a fresh state
        and the route's points."""
        p = self.params
        gains = (
            *(p[k] for k in ("lookahead_base", "lookahead_gain", "target_speed_kmh")),
            *(p[k] for k in ("lon_kp", "lon_kd", "lon_ki", "lat_kp", "lat_kd", "lat_ki")),
            self._dt,
            p["pid_window"],
            *(p[k] for k in ("max_throttle", "max_brake", "max_steer", "max_steer_change")),
        )
        self._state = route_state(gains, self._route)

    @property
    def aeb_fired(self) -> bool:
        """Whether the emergency brake is latched (or, releasing, braking) now."""
        return self._fired_at is not None or self._braking_since is not None

    def step(self, observation: Observation) -> Control:
        """One control step: perception and AEB first, then route following."""
        ego = observation.ego
        thr, brk, steer, fired = self._step_values(
            observation.t,
            ego.x,
            ego.y,
            ego.yaw,
            ego.speed,
            observation.detections,
            observation.image,
        )
        if fired is None:
            return Control(thr, brk, steer)
        if self.aeb_latches:
            return Control(thr, brk, steer, {"aeb": True, "aeb_time": fired})
        return Control(thr, brk, steer, {"aeb_active": True, "aeb_time": fired})

    def plain_step(self) -> Callable[..., tuple[float, float, float, float | None]] | None:
        """:meth:`step` on plain values for a backend that calls it every control step
        (no ``Observation`` or ``Control`` objects): ``(t, x, y, yaw, speed, detections,
        image) -> (throttle, brake, steer, aeb_time)``, ``aeb_time`` None until the AEB
        fires; or None when a subclass overrides :meth:`step` (then only it says what a
        step does)."""
        return self._step_values if type(self).step is ReferenceStack.step else None

    def _step_values(
        self,
        t: float,
        x: float,
        y: float,
        yaw: float,
        speed: float,
        detections: Sequence[Detection] | None,
        image: Any,
    ) -> tuple[float, float, float, float | None]:
        """:meth:`step`'s decision: (throttle, brake, steer, the AEB's firing time while it
        brakes, else None); see the module docstring for latching and releasing."""
        if self._fired_at is not None:
            return 0.0, 1.0, self._steer, self._fired_at
        frame = self.aeb and (detections is not None or image is not None)
        since = self._braking_since
        if since is not None:  # releasing AEB, braking: hold, then hand back
            if frame:  # a new frame (between frames the last decision holds)
                if self._perceive(detections, image):
                    self._clear_since = None
                elif self._clear_since is None:
                    self._clear_since = t
            clear = self._clear_since
            if clear is None or t - clear < self._hold - 1e-9 or speed >= _HELD_SPEED:
                return 0.0, 1.0, self._steer, since
            self._braking_since = self._clear_since = None
        elif frame and self._perceive(detections, image):
            if self.aeb_latches:
                self._fired_at = t
            else:
                self._braking_since = t
            return 0.0, 1.0, self._steer, t
        # route following: the next waypoint, the two PIDs and CARLA's steering
        # regulation, all in _route_step (compiled when numba is there)
        if self._state is None:
            self._start()
        thr, brk, steer, self._steer = (_STEP or _step_kernel())(self._state, x, y, yaw, speed)
        return thr, brk, steer, None

    def _perceive(self, detections: Sequence[Detection] | None, image: Any) -> bool:
        if detections is None:
            if image is None:
                return False  # no new frame: keep the last decision
            detections = self._detect(image)
        width, classes = self.camera.width, self._classes
        for det in detections:
            if aeb_test(det, width, self._threshold, self._centering, self._distance, classes):
                return True
        return False

    def _detect(self, image: Any) -> Sequence[Detection]:
        if self.detector is None:
            from sitcov.perception import SSDDetector  # lazy: needs the camera extra

            self.detector = SSDDetector()
        return self.detector(image)

    def config(self) -> dict[str, Any]:
        """Name, fault and the effective parameters (JSON-serialisable)."""
        params = dict(self.params)
        params["centering"] = list(params["centering"])
        params["classes"] = list(params["classes"])
        return {"name": self.name, "fault": self.fault, "aeb": self.aeb, "params": params}


#: Layout of the route step's one array (:func:`route_state`; one array because each array
#: argument costs a compiled call about 0.3 us of checks): the 15 gains (indices 0-14, in
#: ``ReferenceStack._start``'s order), then the state: waypoint index, route consumed,
#: last steer, window length and ring head (shared by both PIDs: they push together),
#: each PID's running sum and last error, the number of route points; then the two error
#: windows (``pid_window`` each) and the route's xs and ys.
_IDX, _DONE, _STEER, _COUNT, _HEAD, _LON, _LAT, _N, _RINGS = 15, 16, 17, 18, 19, 20, 22, 24, 25


#: :func:`route_state`'s fresh arrays per (route object, gains, kind), copied for each run (a
#: map's routes are the same objects run after run); the route is held, so its id stays.
_FRESH: dict[tuple[int, tuple[float, ...], bool], tuple[Any, Any]] = {}


def route_state(gains: Sequence[float], route: Sequence[tuple[float, float]]) -> Any:
    """The array :func:`_route_step` takes (layout above) with a fresh state: a float
    array for the compiled step, else a list (the step updates it in place). A copy of
    the one made at the route's first run."""
    key = (id(route), tuple(gains), (_STEP or _step_kernel()) is _route_step)
    held = _FRESH.get(key)
    if held is None or held[0] is not route:
        if len(_FRESH) >= 256:
            _FRESH.clear()
        held = _FRESH[key] = (route, _route_state(gains, route))
    return held[1].copy()


def _route_state(gains: Sequence[float], route: Sequence[tuple[float, float]]) -> Any:
    """:func:`route_state`, made afresh."""
    window = int(gains[10])
    state = [0, 0.0, 0.0, 0, 0, 0.0, 0.0, 0.0, 0.0, len(route)] + [0.0] * (2 * window)
    values = [*map(float, gains), *state, *(float(x) for x, _ in route)]
    values += [float(y) for _, y in route]
    if (_STEP or _step_kernel()) is _route_step:
        return values
    return np.array(values, dtype=np.float64)


def _route_step(st: Any, x: float, y: float, yaw: float, speed: float) -> tuple[float, ...]:
    """One route-following step (as CARLA's local planner and PID controllers do it):
    ``(throttle, brake, steer, steer kept for the AEB)``.

    The target is the first waypoint at least ``lookahead_base + lookahead_gain * speed``
    ahead; at the last one within :data:`_ARRIVED` the route is consumed (full brake).
    Else a longitudinal PID on the speed error [km/h] and a lateral PID on the heading
    error to the target (:func:`sitcov.av._pid.window_pid`, the classes' arithmetic);
    the steer changes by at most ``max_steer_change`` per step, capped at ``max_steer``.
    ``st``: gains, state and route (layout above; the state is updated in place). Plain
    floats and indexing, so numba compiles this very code (``sitcov/_jit.py``).
    """
    window, n = int(st[10]), int(st[_N])
    xs, ys, last = _RINGS + 2 * window, _RINGS + 2 * window + n, n - 1
    reach = st[0] + st[1] * speed
    idx = int(st[_IDX])
    while idx < last:
        if hypot(st[xs + idx] - x, st[ys + idx] - y) >= reach:
            break
        idx += 1
    st[_IDX] = idx
    tx, ty = st[xs + idx], st[ys + idx]
    if idx == last and (st[_DONE] != 0.0 or hypot(tx - x, ty - y) < _ARRIVED):
        st[_DONE] = 1.0  # route consumed: stop, as CARLA's planner does with an empty queue
        return 0.0, 1.0, 0.0, st[_STEER]
    head = int(st[_HEAD])
    full = int(st[_COUNT]) == window
    count = window if full else int(st[_COUNT]) + 1
    u = window_pid(st, _LON, _RINGS, st[2] - speed * 3.6, st, 3, full, head, count)
    accel = 1.0 if u > 1.0 else (-1.0 if u < -1.0 else u)
    wx, wy = tx - x, ty - y  # heading error to the target
    if wx == 0.0 and wy == 0.0:
        error = 0.0
    else:
        hx, hy = cos(yaw), sin(yaw)
        error = atan2(hx * wy - hy * wx, hx * wx + hy * wy)
    u = window_pid(st, _LAT, _RINGS + window, error, st, 6, full, head, count)
    steer = 1.0 if u > 1.0 else (-1.0 if u < -1.0 else u)
    st[_COUNT] = count
    st[_HEAD] = head + 1 if head + 1 < window else 0
    prev, change, cap = st[_STEER], st[14], st[13]
    if steer > prev + change:  # CARLA's steering regulation
        steer = prev + change
    elif steer < prev - change:
        steer = prev - change
    steer = cap if steer > cap else (-cap if steer < -cap else steer)
    st[_STEER] = steer
    if accel >= 0.0:
        return (st[11] if st[11] < accel else accel), 0.0, steer, steer
    return 0.0, (st[12] if st[12] < -accel else -accel), steer, steer


_STEP: Any = None


def _step_kernel() -> Any:
    """:func:`_route_step` compiled by numba when it is installed (``_jit.py``; the same
    bits), else itself. Loaded once per process."""
    global _STEP
    if _STEP is None:
        from sitcov._jit import compiled, typed_entry

        gains = [3.0, 0.5, 25.0, 0.15, 0.05, 0.07, 0.58, 0.02, 0.5, 0.05, 2.0, 0.75, 0.3, 0.8, 0.1]
        state = [0.0] * 10 + [0.0] * 4
        state[_N - 15] = 3.0
        route = [0.0, 5.0, 10.0, 0.0, 0.0, 1.0]
        example = np.array(gains + state + route, dtype=np.float64)
        _STEP = compiled(_route_step, example, 0.0, 0.5, 0.1, 3.0, helpers=(window_pid,))
        _STEP = typed_entry(_STEP) or _route_step
    return _STEP


class LatchedReferenceStack(ReferenceStack):
    """The paper's reference stack exactly: once its AEB fires it brakes to the end of the
    run (``aeb_latch``). ``sitcov experiment faults --av reference-latched`` runs the
    paper's Table 2 protocol with it (docs/experiments.md)."""

    name: ClassVar[str] = "reference-latched"

    def __init__(
        self,
        fault: str | None = None,
        params: Mapping[str, Any] | None = None,
        aeb: bool = True,
        detector: Detector | None = None,
    ) -> None:
        super().__init__(fault, {"aeb_latch": True, **(params or {})}, aeb, detector)


class NoPerceptionStack(ReferenceStack):
    """The reference stack with its emergency brake removed: drives the route blindly.

    Used to check that the adversarial OV really meets the ego.
    """

    name: ClassVar[str] = "no-perception"

    def __init__(self, fault: str | None = None, params: Mapping[str, Any] | None = None) -> None:
        super().__init__(fault=fault, params=params, aeb=False)
