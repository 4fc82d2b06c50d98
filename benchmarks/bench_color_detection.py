"""Detection rate of the OV per palette colour in clear daylight (docs/camera.md).

Frames: the OV at 6, 8, 10, 12 and 14 m, bearings -20/0/20 deg, seen from the rear, the
front and both sides, from the ego at the start of leg B of the T-junction, clear noon,
box at least 10 % of the image width. A detection counts when it is reported (score >= 0.3)
and overlaps the projected box (IoU >= 0.3); ``>= 0.5`` is the reference AEB's threshold.

    python benchmarks/bench_color_detection.py [--values '{"cloudiness": 100}'] [--pem]

``--pem`` prints instead the shipped PEM's ``P(score >= 0.5)`` per colour and view over the
same poses (no rendering: the PEM's event probability ``Phi(z / noise_sigma)``).
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np
from scipy.special import ndtr

from sitcov.calibration._calibrate import _ego_pose
from sitcov.calibration._camera_runs import match
from sitcov.perception import (
    ActorView,
    CameraSpec,
    PEMSensor,
    Pose,
    SSDDetector,
    pem_logit,
    project_box,
    render_frame,
)
from sitcov.perception._colors import PALETTE
from sitcov.sim import conditions_from_values

CAM = CameraSpec()
VIEWS = {"rear": (0.0,), "front": (math.pi,), "side": (math.pi / 2, -math.pi / 2)}
DISTANCES = (6.0, 8.0, 10.0, 12.0, 14.0)
BEARINGS = (-20.0, 0.0, 20.0)


def rates(
    values: dict[str, float], pem: bool = False
) -> dict[str, dict[str, tuple[float, float, int]]]:
    """colour -> view -> (rate at 0.3, rate at 0.5, frames); with ``pem`` the PEM's
    probabilities of a score >= 0.3 and >= 0.5 instead of the detector's rates."""
    detector = None if pem else SSDDetector(min_score=0.05)
    sensor = PEMSensor(camera=CAM)
    ego, geometry = _ego_pose()
    cond = conditions_from_values(values)
    cx = ego.x + CAM.mount_x * math.cos(ego.yaw)
    cy = ego.y + CAM.mount_x * math.sin(ego.yaw)
    out: dict[str, dict[str, tuple[float, float, int]]] = {}
    for name, (rgb, _) in PALETTE.items():
        out[name] = {}
        for view, yaws in VIEWS.items():
            scores = []
            for dist in DISTANCES:
                for bearing in BEARINGS:
                    for yaw_off in yaws:
                        los = ego.yaw + math.radians(bearing)
                        x, y = cx + dist * math.cos(los), cy + dist * math.sin(los)
                        pose = Pose(x, y, los + yaw_off)
                        actor = ActorView(pose, 4.5, 1.9, 1.5, 0.0, rgb)
                        proj = project_box(CAM, ego, actor)
                        if proj is None or proj.width < 0.1 * CAM.width:
                            continue
                        if detector is None:
                            scores.append(_pem_passes(sensor, ego, actor, cond))
                            continue
                        rng = np.random.default_rng(0)
                        img = render_frame(CAM, ego, (actor,), cond, geometry, rng)
                        score = match(proj.box, detector(img))[0]
                        scores.append((float(score >= 0.3), float(score >= 0.5)))
            s = np.asarray(scores)
            out[name][view] = (float(s[:, 0].mean()), float(s[:, 1].mean()), len(s))
    return out


def _pem_passes(
    sensor: PEMSensor, ego: Pose, actor: ActorView, cond: object
) -> tuple[float, float]:
    """The PEM's probabilities that the frame's score reaches 0.3 and 0.5."""
    p = sensor.params
    feats = sensor.features(ego, actor, cond)
    if feats is None:
        return 0.0, 0.0
    z = pem_logit(feats, p)
    sigma = max(p.noise_sigma + p.rain_sigma * feats.rain_noise, 1e-9)
    return tuple(float(ndtr((z - math.log(t / (1 - t))) / sigma)) for t in (0.3, 0.5))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--values", default="{}", help="weather values as JSON (default clear)")
    parser.add_argument("--pem", action="store_true", help="the shipped PEM's probabilities")
    args = parser.parse_args()
    table = rates(json.loads(args.values), pem=args.pem)
    print("| colour | share | rear >=0.3 / >=0.5 | front | side | all >=0.5 | frames |")
    print("|---|---|---|---|---|---|---|")
    for name, views in table.items():
        cells = [f"{100 * a:.0f} / {100 * b:.0f} %" for a, b, _ in views.values()]
        n = sum(v[2] for v in views.values())
        pooled = sum(b * k for _, b, k in views.values()) / max(1, n)
        cells.append(f"{100 * pooled:.0f} %")
        print(f"| {name} | {100 * PALETTE[name][1]:.0f} % | " + " | ".join(cells) + f" | {n} |")


if __name__ == "__main__":
    main()
