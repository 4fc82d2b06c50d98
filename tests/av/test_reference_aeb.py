"""The AEB's three tests, the latch, the release and the perception modes of the reference stack."""

from __future__ import annotations

import pytest

from sitcov.av import (
    EgoState,
    LatchedReferenceStack,
    Observation,
    ReferenceStack,
    RunInfo,
    aeb_test,
    make_stack,
)
from sitcov.perception import CameraSpec, Detection

W = 800.0  # image width [px]


def det(mid: float, width: float, score: float = 0.9, label: str = "car") -> Detection:
    """A detection centred at ``mid`` (fraction of W) with box width ``width`` (fraction)."""
    x0, x1 = (mid - width / 2) * W, (mid + width / 2) * W
    return Detection((x0, 200.0, x1, 260.0), score, label)


# Width ratios at the edges of round((1 - r)^4, 1): 0.6 needs (1-r)^4 < 0.65 -> r > 0.1021;
# 0.35 (rounded values are multiples of 0.1) needs (1-r)^4 < 0.35 -> r > 0.2308.
CASES = [
    # (detection, fires at defaults, f1, f2, f3)
    (det(0.5, 0.20, 0.90), True, False, True, False),
    (det(0.5, 0.30, 0.96), True, True, True, True),
    (det(0.5, 0.30, 0.50), True, False, True, True),  # score == threshold passes
    (det(0.5, 0.30, 0.49), False, False, False, False),
    (det(0.5, 0.11, 0.99), True, True, True, False),  # just wide enough at d = 0.6
    (det(0.5, 0.09, 0.99), False, False, False, False),  # too narrow (far) everywhere
    (det(0.75, 0.30, 0.99), True, True, False, True),  # off-centre: only f2 ignores it
    (det(0.2, 0.30, 0.99), True, True, False, True),
    (det(0.04, 0.06, 0.99), False, False, False, False),  # narrow box at the left edge
    (det(0.985, 0.12, 0.99), False, False, False, False),  # mid_x beyond 0.98
    (det(0.5, 0.30, 0.99, "person"), False, False, False, False),
]


@pytest.mark.parametrize("case", CASES)
def test_aeb_truth_table(case):
    d, default, f1, f2, f3 = case
    assert aeb_test(d, W, 0.5, (0.05, 0.98), 0.6) is default
    assert aeb_test(d, W, 0.95, (0.05, 0.98), 0.6) is f1
    assert aeb_test(d, W, 0.5, (0.3, 0.6), 0.6) is f2
    assert aeb_test(d, W, 0.5, (0.05, 0.98), 0.35) is f3


@pytest.mark.parametrize("fault", [None, "f1-raw", "f2", "f3"])
@pytest.mark.parametrize("index", range(len(CASES)))
def test_stack_uses_the_fault_values(fault, index):
    d, *expected = CASES[index]  # the f1 column is the paper's raw 0.95: fault f1-raw
    want = expected[[None, "f1-raw", "f2", "f3"].index(fault)]
    stack = _started(ReferenceStack(fault=fault))
    control = stack.step(_obs(1.0, (d,)))
    assert (control.brake == 1.0) is want
    assert stack.aeb_fired is want


def test_f1_fires_exactly_from_its_computed_threshold():
    theta = ReferenceStack(fault="f1").params["threshold"]
    assert 0.5 < theta < 0.95
    for score, want in ((theta, True), (theta - 1e-3, False), (0.5, False), (0.9, True)):
        stack = _started(ReferenceStack(fault="f1"))
        stack.step(_obs(1.0, (det(0.5, 0.30, score),)))
        assert stack.aeb_fired is want


def _started(stack: ReferenceStack) -> ReferenceStack:
    route = tuple((float(i), 0.0) for i in range(100))
    stack.reset(RunInfo(0.05, route, route[-1], "test", CameraSpec(), seed=0))
    return stack


def _obs(t: float, detections=None, image=None, speed: float = 6.9) -> Observation:
    ego = EgoState(10.0, 0.0, 0.0, speed, t)
    return Observation(t, ego, detections=detections, image=image)


def _still(t: float, detections=None) -> Observation:
    """An observation of the ego standing."""
    return _obs(t, detections, speed=0.0)


def test_latch_holds_to_the_end_and_reset_clears_it():
    stack = _started(LatchedReferenceStack())
    for t in (0.0, 0.05, 0.1):
        c = stack.step(_obs(t, ()))
        assert c.brake < 1.0 and "aeb" not in c.info
    fired = stack.step(_obs(0.15, (det(0.5, 0.3),)))
    assert (fired.throttle, fired.brake) == (0.0, 1.0)
    assert fired.info == {"aeb": True, "aeb_time": 0.15}
    for t in (0.2, 0.25, 5.0):  # nothing seen any more: still braking fully
        c = stack.step(_obs(t, ()))
        assert (c.throttle, c.brake, c.steer) == (0.0, 1.0, fired.steer)
        assert c.info["aeb_time"] == 0.15
    _started(stack)
    assert not stack.aeb_fired
    assert stack.step(_obs(0.0, ())).brake < 1.0


def test_steer_is_held_when_firing():
    stack = _started(ReferenceStack())
    ego = EgoState(10.0, 1.0, 0.0, 6.9, 0.0)  # 1 m left of the route: steers right
    steers = [stack.step(Observation(0.05 * i, ego, detections=())).steer for i in range(5)]
    assert steers[-1] < 0.0
    c = stack.step(Observation(0.3, ego, detections=(det(0.5, 0.3),)))
    assert c.steer == steers[-1]


def test_no_new_frame_keeps_the_last_decision():
    stack = _started(ReferenceStack())
    assert stack.step(_obs(0.0, None)).brake < 1.0
    assert not stack.aeb_fired


def test_aeb_disabled_ignores_detections():
    stack = _started(ReferenceStack(aeb=False))
    assert stack.step(_obs(0.0, (det(0.5, 0.5),))).brake < 1.0


def test_camera_mode_runs_the_detector_on_new_frames_only():
    calls = []

    def detector(image):
        calls.append(image)
        return (det(0.5, 0.3),) if image == "close" else ()

    stack = _started(ReferenceStack(detector=detector, params={"aeb_latch": True}))
    assert stack.step(_obs(0.0, image="far")).brake < 1.0
    assert stack.step(_obs(0.05)).brake < 1.0  # no frame: no detector call
    assert calls == ["far"]
    assert stack.step(_obs(0.1, image="close")).info == {"aeb": True, "aeb_time": 0.1}
    assert calls == ["far", "close"]
    stack.step(_obs(0.15, image="close"))
    assert len(calls) == 2  # latched: perception no longer consulted


def test_image_width_comes_from_the_run_camera():
    route = tuple((float(i), 0.0) for i in range(100))
    # A 240-px-wide box is 0.3 of an 800-px image (passes f3's distance test) but only 0.15
    # of a 1600-px image (fails it).
    d = Detection((280.0, 100.0, 520.0, 200.0), 0.9)
    assert aeb_test(d, 800, 0.5, (0.05, 0.98), 0.35)
    assert not aeb_test(d, 1600, 0.5, (0.05, 0.98), 0.35)
    stack = ReferenceStack(fault="f3")
    stack.reset(RunInfo(0.05, route, route[-1], "t", CameraSpec(width=1600, height=900), 0))
    assert stack.step(_obs(0.0, (d,))).brake < 1.0
    stack.reset(RunInfo(0.05, route, route[-1], "t", CameraSpec(), 0))
    assert stack.step(_obs(0.0, (d,))).brake == 1.0


def test_released_aeb_holds_then_hands_back_after_the_trigger_clears():
    """The default AEB brakes fully to a standstill, holds while frames trigger it and for
    ``aeb_hold`` seconds after the last one that did (between frames the last decision
    holds), then the route follower drives again; it fires again on a new trigger."""
    stack = _started(ReferenceStack())
    assert stack.params["aeb_hold"] == 1.0 and not stack.aeb_latches
    close = (det(0.5, 0.3),)
    fired = stack.step(_still(0.1, close))
    assert fired.brake == 1.0 and fired.info == {"aeb_active": True, "aeb_time": 0.1}
    assert stack.step(_still(0.2, close)).brake == 1.0  # still triggering
    assert stack.step(_still(0.3, ())).brake == 1.0  # cleared at 0.3: hold until 1.3
    assert stack.step(_still(0.35)).brake == 1.0  # no frame: holds
    assert stack.step(_still(1.25, ())).brake == 1.0
    assert stack.step(_obs(1.3, ())).brake == 1.0  # still rolling: brakes on to a stand
    c = stack.step(_still(1.35, ()))
    assert c.brake < 1.0 and c.info == {} and not stack.aeb_fired  # handed back
    assert stack.step(_still(1.4, close)).info == {"aeb_active": True, "aeb_time": 1.4}
    # a trigger during the hold restarts it
    stack.step(_still(1.5, ()))
    stack.step(_still(2.0, close))
    assert stack.step(_still(2.1, ())).brake == 1.0  # cleared at 2.1
    assert stack.step(_still(3.05, ())).brake == 1.0
    assert stack.step(_still(3.1, ())).brake < 1.0


@pytest.mark.parametrize("hold", [0.0, 2.5])
def test_hold_time_is_a_parameter(hold):
    stack = _started(ReferenceStack(params={"aeb_hold": hold}))
    stack.step(_still(0.0, (det(0.5, 0.3),)))
    stack.step(_still(0.1, ()))
    assert (stack.step(_still(0.1 + hold - 0.05, ())).brake == 1.0) is (hold > 0.0)
    assert stack.step(_still(0.1 + hold, ())).brake < 1.0


def test_latched_variant_is_a_named_stack_and_a_parameter():
    for stack in (make_stack("reference-latched"), ReferenceStack(params={"aeb_latch": True})):
        assert stack.aeb_latches and stack.config()["params"]["aeb_latch"] is True
    latched = make_stack("reference-latched", fault="f2")
    assert latched.name == "reference-latched" and latched.params["centering"] == (0.3, 0.6)
    assert not make_stack("reference").aeb_latches


def test_aeb_latch_must_be_a_boolean():
    from sitcov.errors import ConfigError

    with pytest.raises(ConfigError, match="params.aeb_latch"):
        ReferenceStack(params={"aeb_latch": "yes"})
