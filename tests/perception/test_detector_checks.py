"""Acceptance checks of the camera path (issue 5): detection rates by view and in fog."""

from __future__ import annotations

import math
from functools import partial

import numpy as np
import pytest

from sitcov.calibration._calibrate import PALETTE
from sitcov.perception import ActorView, CameraSpec, Pose, project_box, render_frame
from sitcov.perception._nms import iou
from sitcov.sim import conditions_from_values

CAM = CameraSpec()
VIEWS = {"rear": (0.0,), "front": (math.pi,), "side": (math.pi / 2, -math.pi / 2)}
FLOOR = 0.3  # the detector's reporting threshold in use


NEAR = (6.0, 8.0, 10.0, 12.0, 14.0)  # [m] boxes of 10% of the image width and more
RANGE = (8.0, 12.0, 16.0, 20.0, 25.0, 30.0)  # [m]


#: Whether the detector found the OV in a frame, by the frame's key (see ``_rate``): the
#: fog test's clear frames at 8 and 12 m are the daylight test's frames at those distances
#: (same pose, colour and seed), so they are rendered and detected once per worker (the
#: tests share the xdist group ``detector_check_frames``); ~1/6 of the fog test's frames.
_HITS: dict[tuple, bool] = {}


def _frames(geometry, ego: Pose, view: str, values=None, distances=NEAR, min_width=0.1):
    """Frames of the OV at ``distances``, bearings -20..20 deg, in five colours, whose box
    is at least ``min_width`` of the image width: (key, render, box), ``render()`` drawing
    the frame (deterministic: its own seeded generator)."""
    values = values or {}
    cond = conditions_from_values(values)
    cx = ego.x + CAM.mount_x * math.cos(ego.yaw)
    cy = ego.y + CAM.mount_x * math.sin(ego.yaw)
    for dist in distances:
        for bearing in (-20.0, 0.0, 20.0):
            for k, color in enumerate(PALETTE):
                los = ego.yaw + math.radians(bearing)
                yaw = los + VIEWS[view][k % len(VIEWS[view])]
                actor = ActorView(
                    Pose(cx + dist * math.cos(los), cy + dist * math.sin(los), yaw), 4.5, 1.9, 1.5
                )
                proj = project_box(CAM, ego, actor)
                if proj is None or proj.width < min_width * CAM.width:
                    continue
                key = (id(geometry), ego.x, ego.y, ego.yaw, view, tuple(sorted(values.items())),
                       dist, bearing, k)  # fmt: skip
                render = partial(render_frame, CAM, ego, (actor,), cond, geometry,
                                 np.random.default_rng(k), body_colors=[color])  # fmt: skip
                yield key, render, proj


def _rate(detector, geometry, ego, view, values=None, threshold=FLOOR, **kw) -> tuple[float, int]:
    hits = n = 0
    for key, render, proj in _frames(geometry, ego, view, values, **kw):
        n += 1
        key = (id(detector), threshold, *key)
        if key not in _HITS:
            dets = [d for d in detector(render()) if d.score >= threshold]
            boxes = np.array([d.box for d in dets])
            _HITS[key] = bool(dets) and iou(np.array(proj.box), boxes).max() >= 0.3
        hits += _HITS[key]
    return hits / n, n


@pytest.mark.slow
@pytest.mark.xdist_group("detector_check_frames")
@pytest.mark.parametrize("view", sorted(VIEWS))
def test_clear_daylight_detection_rate_by_view(ssd_detector, tjunction_geometry, view) -> None:
    geometry, ego = tjunction_geometry
    rate, n = _rate(ssd_detector, geometry, ego, view)
    assert n >= 40
    assert rate >= 0.9, f"{view}: {rate:.0%} of {n} frames"


@pytest.mark.slow
@pytest.mark.xdist_group("detector_check_frames")
def test_fog_100_is_detected_clearly_less_often(ssd_detector, tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    # Same frames (8..30 m, every view), with and without fog (visibility 25 m).
    kw = {"distances": RANGE, "min_width": 0.0}
    clear = np.mean([_rate(ssd_detector, geometry, ego, v, **kw)[0] for v in VIEWS])
    fog = np.mean([_rate(ssd_detector, geometry, ego, v, {"fog_density": 100}, **kw)[0]
                   for v in VIEWS])  # fmt: skip
    assert fog <= clear - 0.25, f"clear {clear:.0%}, fog 100 {fog:.0%}"


@pytest.mark.slow
def test_camera_mode_runs_end_to_end_and_is_deterministic(ssd_model) -> None:
    """The embedded backend in camera mode drives the reference stack from real detections."""
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception import SSDDetector
    from sitcov.sim.embedded import EmbeddedBackend

    sit = make_generator("random", load_hyperspace()).ask(np.random.default_rng(3))
    backend = EmbeddedBackend(perception="camera", sensor_rate_hz=5.0)
    stack = ReferenceStack(detector=SSDDetector(ssd_model))
    first = backend.run(sit, stack, 11)
    assert first.status in ("pass", "fail")
    assert first.aeb_fired  # the OV crosses the ego's path in every IntSit
    assert backend.run(sit, stack, 11) == first


@pytest.mark.slow
def test_pem_and_camera_mode_mostly_reach_the_same_verdict(ssd_model) -> None:
    """The shipped PEM stands in for the camera: same situations and seeds, same verdicts.

    Runs 0..29 of seed 2, a seed neither the calibration (seed 1) nor its design (seed 0)
    used. A deterministic regression check (the same 30 runs every time), not a statistical
    claim: at 30 runs a true agreement of 81 % falls below 0.75 on about one seed in six.
    The agreement figures with their intervals come from `sitcov experiment agreement`
    (docs/pem.md), which runs 200 situations per held-out seed.
    """
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception import SSDDetector
    from sitcov.sim.embedded import EmbeddedBackend

    gen = make_generator("random", load_hyperspace())
    camera = EmbeddedBackend(perception="camera")
    pem = EmbeddedBackend(perception="pem")
    cam_stack, pem_stack = ReferenceStack(detector=SSDDetector(ssd_model)), ReferenceStack()
    verdicts = []
    for i in range(30):
        sit, seed = gen.ask(ask_rng(2, i)), run_seed(2, i)
        verdicts.append(
            (camera.run(sit, cam_stack, seed).failed, pem.run(sit, pem_stack, seed).failed)
        )
    agree = sum(c == p for c, p in verdicts) / len(verdicts)
    cam_rate = sum(c for c, _ in verdicts) / len(verdicts)
    pem_rate = sum(p for _, p in verdicts) / len(verdicts)
    assert agree >= 0.75, (agree, cam_rate, pem_rate)
    assert abs(cam_rate - pem_rate) <= 0.15, (cam_rate, pem_rate)
