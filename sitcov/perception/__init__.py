"""Perception: camera geometry, the perception error model, renderer and detector."""

from sitcov.perception._base import ActorView, CameraSpec, Detection, Pose, Sensor

__all__ = ["ActorView", "CameraSpec", "Detection", "Pose", "Sensor"]
