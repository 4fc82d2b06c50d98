"""What the adapter reads from CARLA: actor states, the ego's observation, camera images.

Shared by the backend (spawning, checks) and the episode (the step loop); neither owns the
other, so these helpers live here.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sitcov.av._base import EgoState, Observation
from sitcov.sim.carla._geometry import to_sitcov
from sitcov.sim.carla._metrics import VehicleState


def image_to_rgb(image: Any) -> np.ndarray:
    """A carla.Image (BGRA bytes) as an HxWx3 uint8 RGB array."""
    bgra = np.frombuffer(image.raw_data, dtype=np.uint8).reshape(image.height, image.width, 4)
    return bgra[:, :, [2, 1, 0]]  # fancy indexing copies into a contiguous array


def vehicle_state(actor: Any) -> VehicleState:
    """An actor's pose, velocity and box in the sitcov frame (any actor: car, bike, walker)."""
    tf = actor.get_transform()
    vel = actor.get_velocity()
    x, y, yaw = to_sitcov(tf.location.x, tf.location.y, tf.rotation.yaw)
    ext = actor.bounding_box.extent
    return VehicleState(x, y, yaw, vel.x, -vel.y, ext.x, ext.y)


def ego_state(state: VehicleState, t: float) -> EgoState:
    """What the ego's localisation reports."""
    return EgoState(x=state.x, y=state.y, yaw=state.yaw, speed=state.speed, t=t)


def make_observation(t: float, state: VehicleState, image: np.ndarray | None) -> Observation:
    """Camera-mode observation (detections are the stack's job)."""
    return Observation(t=t, ego=ego_state(state, t), image=image)
