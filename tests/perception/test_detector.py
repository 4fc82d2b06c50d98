"""SSD post-processing (anchors, decoding, NMS) and the detector on rendered frames."""

from __future__ import annotations

import math
import sys

import numpy as np
import pytest

from sitcov.perception import ActorView, CameraSpec, Detection, Detector, Pose, project_box
from sitcov.perception._anchors import decode_boxes, ssd_anchors
from sitcov.perception._nms import iou, nms, per_class_nms


def test_anchor_count_matches_the_model_output() -> None:
    anchors = ssd_anchors()
    assert anchors.shape == (1917, 4)
    # Lowest layer: 19x19 cells x 3 anchors, centred on the cells.
    first = anchors[:3]
    assert np.allclose(first[:, :2], [0.5 / 19, 0.5 / 19])
    assert np.allclose(first[0, 2:], [0.1, 0.1])  # the small square anchor
    assert math.isclose(first[1, 2] * first[1, 3], 0.2**2, rel_tol=1e-5)  # ratio-2 anchor area
    assert first[1, 3] / first[1, 2] == pytest.approx(2.0, rel=1e-5)  # w/h = 2
    # Last layer: a single cell at the centre, six anchors, largest scale 0.95.
    last = anchors[-6:]
    assert np.allclose(last[:, :2], 0.5)
    assert last[0, 2] == pytest.approx(0.95, rel=1e-5)
    assert ((anchors[:, :2] > 0) & (anchors[:, :2] < 1)).all()


def test_decoding_zero_regression_returns_the_anchor() -> None:
    anchors = ssd_anchors()[:50]
    boxes = decode_boxes(np.zeros((50, 4), np.float32), anchors)
    yc, xc, h, w = anchors.T
    assert np.allclose(boxes, np.stack([xc - w / 2, yc - h / 2, xc + w / 2, yc + h / 2], 1))


def test_decoding_applies_scales_in_yxhw_order() -> None:
    anchor = np.array([[0.5, 0.4, 0.2, 0.1]], np.float32)  # yc, xc, h, w
    raw = np.array([[1.0, -2.0, 5.0 * math.log(2.0), 0.0]], np.float32)
    x0, y0, x1, y1 = decode_boxes(raw, anchor)[0]
    # Independently: yc' = 0.5 + 1/10*0.2, xc' = 0.4 - 2/10*0.1, h' = 2*0.2, w' = 0.1.
    assert (x0 + x1) / 2 == pytest.approx(0.38, abs=1e-6)
    assert (y0 + y1) / 2 == pytest.approx(0.52, abs=1e-6)
    assert y1 - y0 == pytest.approx(0.4, abs=1e-6)
    assert x1 - x0 == pytest.approx(0.1, abs=1e-6)


def test_iou_golden_values() -> None:
    a = np.array([0.0, 0.0, 2.0, 2.0])
    b = np.array([[1.0, 1.0, 3.0, 3.0], [2.0, 2.0, 3.0, 3.0], [0.0, 0.0, 2.0, 2.0]])
    assert np.allclose(iou(a, b), [1 / 7, 0.0, 1.0])


def test_nms_keeps_the_best_of_overlapping_boxes() -> None:
    boxes = np.array([[0, 0, 10, 10], [1, 1, 11, 11], [20, 20, 30, 30], [0, 0, 10, 9]], float)
    scores = np.array([0.6, 0.9, 0.5, 0.3])
    assert nms(boxes, scores, 0.5) == [1, 2]
    assert nms(boxes, scores, 0.99) == [1, 0, 2, 3]
    # Same boxes, different classes: nothing suppressed across classes.
    classes = np.array([0, 1, 0, 1])
    assert per_class_nms(boxes, scores, classes, 0.5) == [1, 0, 2]


def test_nms_is_deterministic_on_ties() -> None:
    boxes = np.array([[0, 0, 10, 10], [0, 0, 10, 10], [0, 0, 10, 10]], float)
    assert nms(boxes, np.array([0.5, 0.5, 0.5]), 0.5) == [0]


def test_detector_is_an_interface_users_can_implement() -> None:
    class Fixed(Detector):
        def __call__(self, image):
            return (Detection((1.0, 2.0, 3.0, 4.0), 0.9),)

    assert Fixed()(np.zeros((4, 4, 3), np.uint8))[0].score == 0.9
    with pytest.raises(TypeError):
        Detector()  # type: ignore[abstract]


def test_missing_litert_raises_missing_extra(monkeypatch) -> None:
    from sitcov.errors import MissingExtraError
    from sitcov.perception import SSDDetector

    monkeypatch.setitem(sys.modules, "ai_edge_litert.interpreter", None)
    with pytest.raises(MissingExtraError, match=r"sitcov\[camera\]"):
        SSDDetector()


def _frame(geometry, ego: Pose, rel: tuple[float, float, float], color=(150, 30, 35)):
    """Render the OV at (forward, left, yaw relative to the ego) from the camera."""
    from sitcov.perception import render_frame

    cam = CameraSpec()
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    fx, ly, yaw = rel
    cx, cy = ego.x + (cam.mount_x + fx) * c - ly * s, ego.y + (cam.mount_x + fx) * s + ly * c
    actor = ActorView(Pose(cx, cy, ego.yaw + yaw), 4.5, 1.9, 1.5)
    img = render_frame(cam, ego, (actor,), None, geometry, np.random.default_rng(0),
                       body_colors=[color])  # fmt: skip
    return img, project_box(cam, ego, actor)


def test_detector_finds_a_rendered_car_where_it_is(ssd_detector, tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    img, proj = _frame(geometry, ego, (9.0, 0.0, 0.0))
    dets = ssd_detector(img)
    assert dets, "no detection of a car 9 m ahead"
    best = max(dets, key=lambda d: d.score)
    assert best.label == "car"
    assert iou(np.array(proj.box), np.array([best.box]))[0] > 0.6
    assert best.score > 0.3
    # Deterministic: the same frame gives the identical result.
    assert ssd_detector(img) == dets


def test_detector_reports_no_confident_car_on_an_empty_road(
    ssd_detector, tjunction_geometry
) -> None:
    from sitcov.perception import render_frame

    geometry, ego = tjunction_geometry
    img = render_frame(CameraSpec(), ego, (), None, geometry, np.random.default_rng(0))
    assert all(d.score < 0.3 for d in ssd_detector(img))


def test_camera_mode_skips_only_frames_without_a_vehicle_in_view() -> None:
    """Frame skipping changes nothing for a stack that sees no car in car-free frames."""
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim.embedded import EmbeddedBackend

    class Counting(Detector):
        def __init__(self) -> None:
            self.calls = 0

        def __call__(self, image):
            assert image.shape == (450, 800, 3) and image.dtype == np.uint8
            self.calls += 1
            return ()

    sit = make_generator("random", load_hyperspace()).ask(np.random.default_rng(8))
    outcomes, calls = [], []
    for skip in (True, False):
        backend = EmbeddedBackend(perception="camera", sensor_rate_hz=2.0)
        backend.skip_empty_frames = skip
        det = Counting()
        outcomes.append(backend.run(sit, ReferenceStack(detector=det), 4))
        calls.append(det.calls)
    assert outcomes[0].collision == outcomes[1].collision
    assert outcomes[0].sim_time == outcomes[1].sim_time
    assert 0 < calls[0] <= calls[1]
