"""Perception types shared by sensors (PEM, camera detector) and AV stacks."""

from __future__ import annotations

import abc
import functools
import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

from sitcov._frozen import fast_init

if TYPE_CHECKING:
    import numpy as np

    from sitcov.weather import Conditions


@dataclass(frozen=True)
class CameraSpec:
    """A pinhole dash-cam rigidly mounted on the ego (paper defaults).

    Attributes:
        width: image width [px].
        height: image height [px].
        fov_deg: horizontal field of view [deg].
        mount_x: forward offset from the vehicle centre [m].
        mount_z: height above the road [m].
    """

    width: int = 800
    height: int = 450
    fov_deg: float = 100.0
    mount_x: float = 2.5
    mount_z: float = 1.0

    @functools.cached_property
    def focal_px(self) -> float:
        """Focal length [px] from the horizontal field of view (computed once: every
        projection reads it)."""
        return self.width / (2.0 * math.tan(math.radians(self.fov_deg) / 2.0))


@fast_init
@dataclass(frozen=True)
class Detection:
    """One detected object in image coordinates.

    Attributes:
        box: (x_min, y_min, x_max, y_max) [px], clipped to the image.
        score: detector confidence in [0, 1].
        label: class name, ``"car"`` for vehicles.
    """

    box: tuple[float, float, float, float]
    score: float
    label: str = "car"


@fast_init
@dataclass(frozen=True)
class Pose:
    """A planar pose: position [m] and heading [rad], counter-clockwise from +x."""

    x: float
    y: float
    yaw: float


@fast_init
@dataclass(frozen=True)
class ActorView:
    """What a sensor needs to know about another road user.

    Attributes:
        pose: centre of the vehicle's footprint.
        length, width, height: box dimensions [m].
        speed: [m/s].
        color: body colour (R, G, B), 0..255 each; None = the renderer's default
            (sitcov.perception._colors.DEFAULT_COLOR).
        kind: the road user's kind: ``car``, ``truck``, ``cyclist`` or ``pedestrian``
            (sensors report it as the detection's class label).
    """

    pose: Pose
    length: float
    width: float
    height: float
    speed: float = 0.0
    color: tuple[int, int, int] | None = None
    kind: str = "car"


class Sensor(abc.ABC):
    """Turns the world as seen from the ego's camera into detections.

    ``detect`` is called by the backend at the sensor rate; it must draw any noise from
    ``rng`` only, so runs are reproducible.
    """

    camera: CameraSpec

    @abc.abstractmethod
    def detect(
        self,
        ego: Pose,
        actors: tuple[ActorView, ...],
        conditions: Conditions,
        rng: np.random.Generator,
    ) -> tuple[Detection, ...]:
        """Detections of ``actors`` in the current frame."""
