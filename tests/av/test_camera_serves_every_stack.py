"""Camera mode serves every stack: detections from the real detector for a stack that wants
detections, frames for one that wants images, one clear line for what cannot be served."""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

from sitcov.av import AVStack, Control, Observation, RunInfo, make_stack
from sitcov.errors import SetupError
from sitcov.hyperspace import Situation
from sitcov.perception import project_box
from sitcov.sim.embedded import EmbeddedBackend

STACK = Path(__file__).resolve().parent / "stacks" / "recording_stack.py"
#: Intersection situations of the default hyperspace (ego, OV, conflict): the OV comes from
#: the right, from the left and from ahead.
INTSITS = [
    {"ego": "L-B", "ov": "R-B", "conflict": "c4"},
    {"ego": "B-R", "ov": "L-R", "conflict": "c2"},
    {"ego": "B-L", "ov": "R-L", "conflict": "c5"},
    {"ego": "R-L", "ov": "L-B", "conflict": "c3"},
]


def _situation(intsit: dict) -> Situation:
    values = {"intsit": intsit, "friction": 1.0}  # clear daylight: every weather element 0
    return Situation(dict.fromkeys(values, "-"), values)


class _Recorder(AVStack):
    """A Python stack that wants ``kind`` and keeps what it observed."""

    def __init__(self, kind: str | None) -> None:
        self.wants = kind
        self.seen: list[Observation] = []

    def reset(self, info: RunInfo) -> None:
        self.seen.clear()

    def step(self, observation: Observation) -> Control:
        if observation.t < 3.0:
            self.seen.append(observation)
        return Control(throttle=0.3)


@pytest.mark.slow
def test_external_detection_stack_gets_the_detectors_boxes_in_camera_mode(
    ssd_model, tmp_path, monkeypatch
) -> None:
    """>= 90 % of the frames in which a car's true box is >= 10 % of the image width carry
    a car detection (measured: 24 of 24 such frames, 4 situations, clear noon)."""
    monkeypatch.setenv("SITCOV_MODEL_DIR", str(ssd_model.parent))
    log = tmp_path / "steps.jsonl"
    stack = make_stack(
        f"cmd:{sys.executable} {STACK}", params={"env": {"SITCOV_TEST_LOG": str(log)}}
    )
    backend = EmbeddedBackend(perception="camera")
    big: set[tuple[float, float]] = set()

    def observe(camera, pose, actors, conditions) -> None:
        for actor in actors:
            proj = project_box(camera, pose, actor)
            if proj is not None and proj.visible and proj.width >= 0.1 * camera.width:
                big.add((pose.x, pose.y))

    backend.frame_observer = observe
    try:
        for i, intsit in enumerate(INTSITS):
            backend.run(_situation(intsit), stack, seed=100 + i)
    finally:
        stack.close()
    steps = [json.loads(line) for line in log.read_text().splitlines()]
    frames = {(s["ego"]["x"], s["ego"]["y"]): s["detections"] for s in steps}
    assert all(s["image"] is None for s in steps)  # detections, not frames
    matched = [frames[key] for key in big if key in frames]
    assert len(matched) >= 20 and len(matched) >= 0.9 * len(big)
    with_car = sum(any(d["label"] == "car" for d in dets) for dets in matched)
    assert with_car >= 0.9 * len(matched), (with_car, len(matched))
    assert all(d["score"] >= 0.3 for dets in matched for d in dets)  # the output floor


def test_python_stack_wanting_detections_gets_them_in_camera_mode(ssd_model, monkeypatch):
    monkeypatch.setenv("SITCOV_MODEL_DIR", str(ssd_model.parent))
    stack = _Recorder("detections")
    EmbeddedBackend(perception="camera", sim_timeout=3.0).run(_situation(INTSITS[0]), stack, 1)
    frames = [o for o in stack.seen if o.detections is not None]
    assert frames and all(o.image is None and o.objects is None for o in stack.seen)


def test_a_stack_that_wants_images_gets_frames_in_camera_mode() -> None:
    stack = _Recorder("image")
    backend = EmbeddedBackend(perception="camera", sim_timeout=3.0)
    backend.skip_empty_frames = False
    backend.run(_situation(INTSITS[0]), stack, 1)
    images = [o.image for o in stack.seen if o.image is not None]
    assert images and all(isinstance(i, np.ndarray) and i.shape == (450, 800, 3) for i in images)
    assert all(o.detections is None for o in stack.seen)


def test_images_from_the_pem_fail_with_one_line() -> None:
    with pytest.raises(SetupError, match="wants camera images.*--perception camera") as err:
        EmbeddedBackend().run(_situation(INTSITS[0]), _Recorder("image"), 1)
    assert "\n" not in str(err.value)


def test_external_image_stack_in_pem_mode_stops_the_campaign_with_one_line(tmp_path) -> None:
    stack = make_stack(
        f"cmd:{sys.executable} {STACK}", params={"env": {"SITCOV_TEST_WANTS": "image"}}
    )
    try:
        with pytest.raises(SetupError, match="external stack .* wants camera images"):
            EmbeddedBackend().run(_situation(INTSITS[0]), stack, 1)
    finally:
        stack.close()


def test_unknown_wants_is_a_config_error() -> None:
    from sitcov.errors import ConfigError

    with pytest.raises(ConfigError, match="wants"):
        EmbeddedBackend().run(_situation(INTSITS[0]), _Recorder("lidar"), 1)
