"""The black-box boundary between sitcov and the AV stack under test."""

from __future__ import annotations

import abc
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING, Any, ClassVar

from sitcov._frozen import fast_init
from sitcov.perception._base import CameraSpec, Detection
from sitcov.perception._objects import ObjectState

if TYPE_CHECKING:
    import numpy as np

    from sitcov.hyperspace import Situation


@dataclass(frozen=True)
class RunInfo:
    """Given to the stack once, at the start of a run.

    Attributes:
        dt: control period [s].
        route: the ego's route as (x, y) waypoints [m], start to goal, about 1 m apart.
        goal: the goal position (x, y) [m].
        map_name: name of the map.
        camera: the camera the backend renders / simulates for this stack.
        seed: the run's seed (a stack may use it for its own randomness).
        situation: the full situation, only in grey-box mode (None in black-box mode).
    """

    dt: float
    route: tuple[tuple[float, float], ...]
    goal: tuple[float, float]
    map_name: str
    camera: CameraSpec
    seed: int
    situation: Situation | None = None


@fast_init
@dataclass(frozen=True)
class EgoState:
    """The ego's own state (what its localisation would report)."""

    x: float
    y: float
    yaw: float
    speed: float
    t: float


#: What a stack may observe each frame (``AVStack.wants``, the external protocol's hello).
OBSERVATION_KINDS = ("detections", "image", "objects")


@fast_init
@dataclass(frozen=True)
class Observation:
    """What the stack sees at one control step: one of three kinds, as the stack wants
    (:attr:`AVStack.wants`); the others are None. All are None on steps without a new
    frame (frames come at the sensor rate, 10 Hz; steps at 20 Hz).

    Attributes:
        t: simulation time [s].
        ego: the ego's own state.
        detections: image boxes with scores and classes: the PEM's in PEM mode, the real
            detector's on the rendered frame in camera mode.
        image: an HxWx3 uint8 camera frame (camera mode only).
        objects: the object list, every road user in the ego frame
            (:class:`sitcov.perception.ObjectState`; both modes, from the world state plus
            the backend's optional noise and miss model).
    """

    t: float
    ego: EgoState
    detections: tuple[Detection, ...] | None = None
    image: np.ndarray | None = None
    objects: tuple[ObjectState, ...] | None = None


@fast_init
@dataclass(frozen=True)
class Control:
    """The stack's command for the next control period.

    Attributes:
        throttle: in [0, 1].
        brake: in [0, 1].
        steer: in [-1, 1], positive turns left (counter-clockwise), scaled by the vehicle's
            maximum steering angle.
        info: optional diagnostics (e.g. ``{"aeb": True}``), stored with the run's metrics.
            Reserved key ``"aeb"``: True means the stack's emergency brake has latched and
            it ignores perception from now on (it brakes to the end of the run); a backend
            may then stop producing camera frames for it. Reserved key ``"aeb_active"``:
            True means its emergency brake brakes now but will release (perception goes
            on); either key records when the AEB first fired (``Outcome.aeb_time``).
    """

    throttle: float = 0.0
    brake: float = 0.0
    steer: float = 0.0
    info: dict[str, Any] = field(default_factory=dict)


class AVStack(abc.ABC):
    """An autonomous-driving stack under test, seen as a black box.

    The backend calls ``reset(info)`` once per run, then ``step(observation)`` every
    ``info.dt`` seconds until the run ends, and ``close()`` when the stack is no longer
    needed (after the last run). A stack must not keep state across ``reset`` calls that
    changes its behaviour, or runs would not be reproducible.
    """

    #: Registry name, e.g. ``"reference"``.
    name: ClassVar[str] = "custom"
    #: What the stack observes (:data:`OBSERVATION_KINDS`): ``"detections"``, ``"image"``
    #: or ``"objects"``; None (the default) takes what the backend's perception gives
    #: natively: detections from the PEM, images in camera mode. A backend that cannot
    #: serve the kind (images from the PEM) refuses the campaign with one line
    #: (``SetupError``). Read after ``reset`` (an external stack says it in its hello).
    wants: str | None = None
    #: The dash-cam the stack expects; backends simulate or render this camera.
    camera: CameraSpec = CameraSpec()
    #: The narrowest box, as a fraction of the image width, that the stack ever acts on
    #: (0 = any). A camera-mode backend may skip rendering and detecting frames in which
    #: no vehicle's true box comes near this width (see docs/camera.md, frame gating);
    #: a stack that declares it promises detections narrower than this never change its
    #: control.
    min_box_width: float = 0.0
    #: Per detection class (``car``, ``person``, ``bicycle``): the smallest box the stack
    #: acts on, (width as a fraction of the image width, height as a fraction of the image
    #: height); e.g. ``{"person": (0.0, 0.2)}`` = persons from 20 % of the image height.
    #: A camera-mode backend may skip frames in which no actor of a listed class comes near
    #: its size (unlisted vehicles: ``min_box_width``; unlisted others: any visible box).
    min_box_sizes: Mapping[str, tuple[float, float]] = MappingProxyType({})
    #: The horizontal region the stack looks at: the open interval (lo, hi), as fractions
    #: of the image width, outside which it ignores every detection's box centre (the
    #: reference AEB's ``centering``); (0, 1) = anywhere. A camera-mode backend may skip
    #: frames in which no actor's true box comes near that interval (docs/camera.md,
    #: frame gating); a stack that declares it promises detections centred outside it
    #: never change its control.
    centre_window: tuple[float, float] = (0.0, 1.0)

    @abc.abstractmethod
    def reset(self, info: RunInfo) -> None:
        """Prepare for a new run."""

    @abc.abstractmethod
    def step(self, observation: Observation) -> Control:
        """Return the control for this step."""

    def close(self) -> None:  # noqa: B027
        """Release resources."""

    def config(self) -> dict[str, Any]:
        """JSON-serialisable configuration stored with each run (faults, parameters)."""
        return {"name": self.name}
