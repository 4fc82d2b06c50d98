"""Fault F1 relative to the detector in use: the paper's θ = 0.95 mapped onto our SSD's scores.

The paper's detector (COCO SSD-MobileNet-v1) and ours (OIDv4 SSD-MobileNetV2, described by
the PEM in ``sitcov/perception/data/pem.yaml``) put different numbers on the same car: ours
never scores a rendered car near 0.95, so the raw threshold removes the emergency brake
altogether. F1 is therefore defined by what the threshold *does*, not by its number:

    F1's threshold θ₁ is the score threshold at which the AEB still accepts the fraction
    ``F1_ACCEPTANCE_RATIO`` of the true-positive frames that the nominal θ = 0.5 accepts,
    over a reference set of views of the OV at the AEB's decision distance in clear weather.

The acceptance of one view is the PEM's probability of reporting it with a score >= θ
(:func:`sitcov.perception._pem.pass_probability`: the detection term times the noisy
score's tail; ``Φ((z - logit θ) / σ)`` for a normal law that always outputs the car).
The reference views are the OV straight ahead of the camera (box centred), seen at
relative headings 0° (rear) to 180° (front) in 15° steps, each at the distance where its
box is exactly as wide as the AEB's distance test requires (``aeb_min_box_width`` of the
nominal ``distance``). The threshold is computed, not typed in, so a recalibrated PEM
moves it. The OV's body is :data:`REFERENCE_CAR`.
docs/reference-stack.md gives the derivation and the numbers.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from sitcov.perception import PEMParams
    from sitcov.perception._pem import PEMFeatures

#: The paper's raw F1 threshold (COCO SSD-MobileNet-v1 scores) [-].
F1_RAW_THRESHOLD = 0.95
#: The nominal threshold the fault is measured against [-].
NOMINAL_THRESHOLD = 0.5
#: Share of the nominal AEB's accepted true-positive frames that F1 still accepts [-]
#: (an assumption about COCO SSD-MobileNet-v1, argued in docs/reference-stack.md).
F1_ACCEPTANCE_RATIO = 0.25
#: Relative headings of the OV in the reference views [deg] (0 = rear view, 180 = front).
REFERENCE_HEADINGS: tuple[int, ...] = tuple(range(0, 181, 15))
#: The OV's body in the reference views: length, width, height [m]. It is the embedded
#: simulator's car (CommonRoad's BMW 320i, ``vehiclemodels.parameters_vehicle2``, 4.508 m x
#: 1.61 m, with the simulator's saloon height 1.45 m), the car the PEM was calibrated on.
#: Stored here so that the stacks do not import the simulator that drives them;
#: tests/av/test_fault_map.py checks that it still equals the simulator's car.
REFERENCE_CAR: tuple[float, float, float] = (4.508, 1.61, 1.45)


def reference_views(params: PEMParams | None = None, distance: float = 0.6) -> list[PEMFeatures]:
    """PEM features of the reference views: each heading at the AEB's decision distance.

    Args:
        params: the PEM (default: the shipped ``pem.yaml``).
        distance: the AEB distance parameter whose narrowest passing box sets the range.
    """
    from sitcov.av._aeb import aeb_min_box_width
    from sitcov.perception import CameraSpec, PEMSensor
    from sitcov.perception._base import ActorView, Pose
    from sitcov.weather import conditions_from_values

    sensor = PEMSensor(params=params, camera=CameraSpec())
    camera = sensor.camera
    clear = conditions_from_values({})
    ego = Pose(0.0, 0.0, 0.0)
    target = aeb_min_box_width(distance) * camera.width

    def features(heading: float, gap: float) -> Any:
        pose = Pose(camera.mount_x + gap, 0.0, heading)
        actor = ActorView(pose, *REFERENCE_CAR)
        return sensor.features(ego, actor, clear)

    views = []
    for deg in REFERENCE_HEADINGS:
        heading = math.radians(deg)
        near, far = 1.0, 200.0  # box width falls with the gap: bisect to the target width
        for _ in range(50):
            mid = 0.5 * (near + far)
            feats = features(heading, mid)
            if feats is not None and feats.width_px >= target:
                near = mid
            else:
                far = mid
        views.append(features(heading, near))
    return views


def acceptance(
    threshold: float, views: list[PEMFeatures], params: PEMParams | None = None
) -> float:
    """Mean probability over ``views`` that the PEM's score reaches ``threshold``.

    A score below the detector's output floor is never reported, so the effective
    threshold is ``max(threshold, floor)``.
    """
    from sitcov.perception._pem import load_pem_params, pass_probability

    p = params or load_pem_params()
    return sum(pass_probability(view, p, threshold) for view in views) / len(views)


def mapped_threshold(
    ratio: float = F1_ACCEPTANCE_RATIO,
    params: PEMParams | None = None,
    nominal: float = NOMINAL_THRESHOLD,
    distance: float = 0.6,
) -> float:
    """The threshold whose acceptance over the reference views is ``ratio`` times nominal's.

    Acceptance falls monotonically with the threshold, so bisection on [nominal, 1) finds
    it; the result is rounded to 1e-4.

    Raises:
        ValueError: ``ratio`` outside (0, 1], or the nominal threshold accepts nothing.
    """
    from sitcov.perception._pem import load_pem_params

    if not 0.0 < ratio <= 1.0:
        raise ValueError(f"ratio must be in (0, 1], got {ratio!r}")
    p = params or load_pem_params()
    views = reference_views(p, distance)
    target = ratio * acceptance(nominal, views, p)
    if target <= 0.0:
        raise ValueError("the nominal threshold accepts none of the reference views")
    lo, hi = nominal, 1.0 - 1e-9
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        if acceptance(mid, views, p) >= target:
            lo = mid
        else:
            hi = mid
    return round(lo, 4)


@lru_cache(maxsize=1)
def f1_threshold() -> float:
    """F1's threshold for the shipped detector: :func:`mapped_threshold` of the shipped PEM.

    Camera mode uses the same value: the PEM file describes the same SSD.
    """
    return mapped_threshold()
