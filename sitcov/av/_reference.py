"""The reference modular ego stack: route following by PID, camera perception and a latched AEB.

This is the stack of the paper (Tahir & Alexander): CARLA's local planner and PID
controllers drive the route at 25 km/h; a camera-only perception stage feeds an emergency
brake that fires when a detection of a road user (by default a car, a person or a bicycle:
the ``classes`` parameter) passes three tests (score, centering, apparent size: the box
width for a car, the scaled box height for a person or cyclist, :data:`CLASS_SIZE`) and
then brakes fully until the run ends. The seeded faults change those tests'
parameters (see :mod:`sitcov.av._faults`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Mapping, Sequence
from typing import Any, ClassVar

from sitcov.av._base import AVStack, Control, Observation, RunInfo
from sitcov.av._faults import resolve_params
from sitcov.av._pid import LateralPID, LongitudinalPID
from sitcov.perception._base import CameraSpec, Detection

Detector = Callable[[Any], Sequence[Detection]]

#: Distance to the last route point at which the route counts as driven [m] (CARLA: 1 m).
_ARRIVED = 1.0


#: How the distance test judges "close enough" per detection class: which extent of the
#: box [px] stands for closeness, and the factor that makes it car-equivalent. A car's
#: box WIDTH is the paper's measure. A person's box is tall and narrow, and its width
#: hardly depends on the distance the way a car's does (0.5 m shoulders, arms swinging),
#: so its HEIGHT is used, scaled by car width / person height (1.61 m / 1.75 m): a person
#: then passes the test at the distance a car seen from behind would. A cyclist's width
#: changes with its heading (0.6 m head-on, 1.8 m side-on) but its height (1.7 m) does
#: not, so its height scaled by 1.61 / 1.7 is used. Other classes use the width.
CLASS_SIZE: dict[str, tuple[str, float]] = {
    "car": ("width", 1.0),
    "person": ("height", 1.61 / 1.75),
    "bicycle": ("height", 1.61 / 1.7),
}


def aeb_test(
    detection: Detection,
    image_width: float,
    threshold: float,
    centering: tuple[float, float],
    distance: float,
    label: str | Collection[str] = "car",
) -> bool:
    """The paper's three tests on one detection; True means "brake now".

    1. ``score >= threshold`` (and the detection's class is ``label`` or in it);
    2. ``lo < mid_x < hi`` with mid_x the box centre over the image width;
    3. ``round((1 - size / image_width) ** 4, 1) <= distance`` (a bigger box means a
       closer road user), ``size`` the box width for a car and the scaled box height for
       a person or a cyclist (:data:`CLASS_SIZE`).
    """
    cls = detection.label
    if (cls != label if isinstance(label, str) else cls not in label) or (
        detection.score < threshold
    ):
        return False
    x0, y0, x1, y1 = detection.box
    mid_x = 0.5 * (x0 + x1) / image_width
    if not centering[0] < mid_x < centering[1]:
        return False
    axis, scale = CLASS_SIZE.get(cls, ("width", 1.0))
    size = (x1 - x0) if axis == "width" else (y1 - y0) * scale
    ratio = size / image_width
    return round((1.0 - ratio) ** 4, 1) <= distance


def aeb_min_box_width(distance: float) -> float:
    """The narrowest box (fraction of the image width) that can pass the distance test.

    ``round((1 - r) ** 4, 1) <= distance`` needs ``(1 - r) ** 4 < q + 0.05`` with ``q``
    the distance rounded down to a tenth.
    """
    tenth = math.floor(distance * 10.0) / 10.0
    return max(0.0, 1.0 - min(tenth + 0.05, 1.0) ** 0.25)


def aeb_min_box_sizes(
    distance: float, classes: Collection[str], camera: CameraSpec
) -> dict[str, tuple[float, float]]:
    """Per class judged by height (:data:`CLASS_SIZE`): the smallest box (width, height
    fractions of the image) whose scaled height can pass the distance test."""
    width = aeb_min_box_width(distance)
    out: dict[str, tuple[float, float]] = {}
    for cls in classes:
        axis, scale = CLASS_SIZE.get(cls, ("width", 1.0))
        if axis == "height":
            out[cls] = (0.0, min(1.0, width * camera.width / (scale * camera.height)))
    return out


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
        self._label = p["label"]
        self._classes = frozenset((*p["classes"], p["label"]))
        self.min_box_sizes = (
            aeb_min_box_sizes(self._distance, self._classes, self.camera) if self.aeb else {}
        )
        self._target = p["target_speed_kmh"]
        self._la_base = p["lookahead_base"]
        self._la_gain = p["lookahead_gain"]
        self._max_throttle = p["max_throttle"]
        self._max_brake = p["max_brake"]
        self._max_steer = p["max_steer"]
        self._dsteer = p["max_steer_change"]
        self._route: tuple[tuple[float, float], ...] = ()
        self._lat = LateralPID(p["lat_kp"], p["lat_kd"], p["lat_ki"], 0.05, p["pid_window"])
        self._lon = LongitudinalPID(p["lon_kp"], p["lon_kd"], p["lon_ki"], 0.05, p["pid_window"])
        self._reset_state()

    def _reset_state(self) -> None:
        self._idx = 0
        self._done = False
        self._steer = 0.0
        self._fired_at: float | None = None
        self._lat.reset()
        self._lon.reset()

    def reset(self, info: RunInfo) -> None:
        """Start a run: take the route, camera and control period; clear the AEB latch."""
        self._route = tuple(info.route) or (tuple(info.goal),)
        self.camera = info.camera
        self._lat.dt = self._lon.dt = float(info.dt)
        self._reset_state()

    @property
    def aeb_fired(self) -> bool:
        """Whether the emergency brake has fired in this run."""
        return self._fired_at is not None

    def step(self, observation: Observation) -> Control:
        """One control step: perception and AEB first, then route following."""
        if self._fired_at is not None:
            return Control(0.0, 1.0, self._steer, {"aeb": True, "aeb_time": self._fired_at})
        if (
            self.aeb
            and (observation.detections is not None or observation.image is not None)
            and self._perceive(observation)
        ):  # a new frame (between frames the last decision holds)
            self._fired_at = observation.t
            return Control(0.0, 1.0, self._steer, {"aeb": True, "aeb_time": self._fired_at})
        return self._drive(observation)

    def _perceive(self, observation: Observation) -> bool:
        detections = observation.detections
        if detections is None:
            if observation.image is None:
                return False  # no new frame: keep the last decision
            detections = self._detect(observation.image)
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

    def _drive(self, observation: Observation) -> Control:
        ego = observation.ego
        x, y = ego.x, ego.y
        route = self._route
        last = len(route) - 1
        reach = self._la_base + self._la_gain * ego.speed
        idx = self._idx
        while idx < last:
            wx, wy = route[idx]
            if math.hypot(wx - x, wy - y) >= reach:
                break
            idx += 1
        self._idx = idx
        tx, ty = route[idx]
        if idx == last and (self._done or math.hypot(tx - x, ty - y) < _ARRIVED):
            # Route consumed: stop, as CARLA's local planner does with an empty queue.
            self._done = True
            return Control(0.0, 1.0, 0.0)
        accel = self._lon.step(self._target, ego.speed * 3.6)
        steer = self._lat.step(x, y, ego.yaw, tx, ty)
        # CARLA's steering regulation: limited change per step, capped magnitude.
        prev = self._steer
        if steer > prev + self._dsteer:
            steer = prev + self._dsteer
        elif steer < prev - self._dsteer:
            steer = prev - self._dsteer
        cap = self._max_steer
        steer = cap if steer > cap else (-cap if steer < -cap else steer)
        self._steer = steer
        if accel >= 0.0:
            return Control(min(accel, self._max_throttle), 0.0, steer)
        return Control(0.0, min(-accel, self._max_brake), steer)

    def config(self) -> dict[str, Any]:
        """Name, fault and the effective parameters (JSON-serialisable)."""
        params = dict(self.params)
        params["centering"] = list(params["centering"])
        params["classes"] = list(params["classes"])
        return {"name": self.name, "fault": self.fault, "aeb": self.aeb, "params": params}


class NoPerceptionStack(ReferenceStack):
    """The reference stack with its emergency brake removed: drives the route blindly.

    Used to check that the adversarial OV really meets the ego.
    """

    name: ClassVar[str] = "no-perception"

    def __init__(self, fault: str | None = None, params: Mapping[str, Any] | None = None) -> None:
        super().__init__(fault=fault, params=params, aeb=False)
