"""examples/aeb_stacks.py: the threshold-0.7, three-frame and right-blind decision rules."""

from __future__ import annotations

from pathlib import Path

import pytest

from sitcov.av import EgoState, Observation, RunInfo, make_stack
from sitcov.perception import CameraSpec, Detection

ROOT = Path(__file__).resolve().parents[2]
NEAR_LEFT = Detection((200.0, 150.0, 380.0, 300.0), 0.6)  # centre 290 < 400, wide: close
NEAR_RIGHT = Detection((420.0, 150.0, 600.0, 300.0), 0.6)
NEAR_MID = Detection((250.0, 150.0, 430.0, 300.0), 0.6)  # centre 340: 0.425 of the width


@pytest.fixture(autouse=True)
def _examples(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(ROOT))


def _brakes(stack, frames) -> list[bool]:
    route = tuple((float(i), 0.0) for i in range(30))
    stack.reset(RunInfo(0.05, route, route[-1], "t-junction", CameraSpec(), 0))
    ego = EgoState(0.0, 0.0, 0.0, 6.0, 0.0)
    return [stack.step(Observation(0.05 * k, ego, dets)).brake == 1.0
            for k, dets in enumerate(frames)]  # fmt: skip


def test_threshold_07_needs_a_score_of_07() -> None:
    stack = make_stack("examples.aeb_stacks:Threshold07")
    assert stack.params["threshold"] == 0.7
    assert _brakes(stack, [(NEAR_LEFT,)]) == [False]
    strong = Detection(NEAR_LEFT.box, 0.7)
    assert _brakes(stack, [(strong,)]) == [True]
    assert make_stack("examples.aeb_stacks:Threshold07", params={"threshold": 0.6}).params[
        "threshold"] == 0.6  # fmt: skip


def test_three_frames_needs_three_consecutive_passing_frames() -> None:
    stack = make_stack("examples.aeb_stacks:ThreeFrames")
    hit, miss = (NEAR_LEFT,), ()
    assert _brakes(stack, [hit, hit, miss, hit, hit, hit]) == [False] * 5 + [True]
    assert make_stack("reference") and _brakes(make_stack("reference"), [hit]) == [True]
    assert _brakes(stack, [hit, hit]) == [False, False]  # reset clears the streak


def test_right_blind_ignores_the_right_60_percent_only() -> None:
    """Blind from 0.4 of the image width on (examples/aeb_stacks.py says why)."""
    stack = make_stack("examples.aeb_stacks:RightBlind")
    assert _brakes(stack, [(NEAR_RIGHT,)]) == [False]
    assert _brakes(stack, [(NEAR_MID,)]) == [False]
    assert _brakes(make_stack("reference"), [(NEAR_MID,)]) == [True]
    assert _brakes(stack, [(NEAR_LEFT,)]) == [True]
    assert _brakes(stack, [(NEAR_RIGHT, NEAR_LEFT)]) == [True]


def test_right_blind_filters_its_detector_in_camera_mode() -> None:
    stack = make_stack("examples.aeb_stacks:RightBlind")
    stack.detector = lambda image: (NEAR_RIGHT,)
    route = tuple((float(i), 0.0) for i in range(30))
    stack.reset(RunInfo(0.05, route, route[-1], "t-junction", CameraSpec(), 0))
    ego = EgoState(0.0, 0.0, 0.0, 6.0, 0.0)
    assert stack.step(Observation(0.0, ego, None, image=object())).brake < 1.0
    stack.detector = lambda image: (NEAR_LEFT,)
    assert stack.step(Observation(0.05, ego, None, image=object())).brake == 1.0
