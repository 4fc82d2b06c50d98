"""Perception: camera geometry, the perception error model, renderer and detector."""

from sitcov.perception._base import ActorView, CameraSpec, Detection, Pose, Sensor
from sitcov.perception._camera import Projection, project_box
from sitcov.perception._detector import Detector, SSDDetector
from sitcov.perception._models import (
    ModelFetchError,
    ModelNotFoundError,
    fetch_model,
    model_dir,
    model_path,
)
from sitcov.perception._objects import (
    OBJECT_NOISE_FILE,
    ObjectMisses,
    ObjectNoise,
    ObjectState,
    load_object_noise,
    object_list,
    pem_miss_processes,
)
from sitcov.perception._pem import PEMFeatures, PEMSensor, pem_logit, pem_score
from sitcov.perception._pem_params import PEM_PARAMS_FILE, PEMParams, load_pem_params
from sitcov.perception._renderer import render_frame

__all__ = [
    "OBJECT_NOISE_FILE",
    "ObjectMisses",
    "ObjectNoise",
    "ObjectState",
    "load_object_noise",
    "object_list",
    "pem_miss_processes",
    "PEM_PARAMS_FILE",
    "ActorView",
    "CameraSpec",
    "Detection",
    "Detector",
    "ModelFetchError",
    "ModelNotFoundError",
    "SSDDetector",
    "PEMFeatures",
    "PEMParams",
    "PEMSensor",
    "Pose",
    "Projection",
    "Sensor",
    "load_pem_params",
    "pem_logit",
    "pem_score",
    "fetch_model",
    "model_dir",
    "model_path",
    "project_box",
    "render_frame",
]
