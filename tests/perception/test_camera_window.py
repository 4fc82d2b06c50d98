"""Camera mode renders fewer frames without changing what a stack does.

- The centre window: a stack declares the horizontal region it looks at
  (``AVStack.centre_window``; the reference AEB's ``centering``, the right-blind example's
  left part); a frame in which no road user's true box comes near that region is not
  rendered, and no detection of such a frame could have passed the stack's tests. A stack
  that declares nothing loses no frame.
- Repeated frames: when nothing moved since the last rendered frame and the renderer draws
  nothing at random (no rain), the frame is the last one again: it is not rendered nor
  detected again, and the detector gives the same detections for the same pixels.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from examples.aeb_stacks import RightBlind, ThreeFrames
from sitcov.av import ReferenceStack
from sitcov.av._protocol import PROTOCOL_VERSION, parse_hello
from sitcov.errors import StackError
from sitcov.perception import ActorView, CameraSpec, Detection, Pose
from sitcov.perception._camera import project_box
from sitcov.perception._renderer import KIND_CLASS, actors_in_view
from sitcov.sim.embedded import EmbeddedBackend
from sitcov.sim.embedded._ego import EgoDriver
from sitcov.weather._conditions import conditions_from_values

CAMERA = CameraSpec()
KINDS = {"car": (4.5, 1.9, 1.5), "pedestrian": (0.5, 0.5, 1.75), "cyclist": (1.8, 0.6, 1.7)}


def _random_actor(rng: np.random.Generator) -> ActorView:
    """A road user 3-30 m ahead of an ego at the origin heading +x, anywhere across."""
    kind = str(rng.choice(list(KINDS)))
    length, width, height = KINDS[kind]
    pose = Pose(float(rng.uniform(3, 30)), float(rng.uniform(-15, 15)), rng.uniform(-3.2, 3.2))
    return ActorView(pose, length, width, height, 1.0, kind=kind)


def _candidate_detections(
    camera: CameraSpec, ego: Pose, actor: ActorView, gate: float
) -> list[Detection]:
    """Detections of ``actor`` the gate must account for: at most ``1 / gate`` times as
    wide and tall as its true box and covering the true box's centre (measured: the
    detector's boxes are at most 1.32x as wide as a car's true box, their centres within
    the true box), at score 1."""
    proj = project_box(camera, ego, actor)
    if proj is None or not proj.visible:
        return []
    x0, y0, x1, y1 = proj.box
    w, h, mx = x1 - x0, y1 - y0, 0.5 * (x0 + x1)
    out = []
    for scale in (1.0, 0.5 * (1.0 + 1.0 / gate), 1.0 / gate):
        bw, bh = w * scale, h * scale
        for c in (mx - 0.499 * bw, mx, mx + 0.499 * bw):
            box = (c - 0.5 * bw, y1 - bh, c + 0.5 * bw, y1)
            out.append(Detection(box, 1.0, KIND_CLASS[actor.kind]))
    return out


@pytest.mark.parametrize("gate", [0.5, 0.7])
@pytest.mark.parametrize(
    "make", [RightBlind, lambda: ReferenceStack(fault="f2"), lambda: RightBlind(fault="f3")]
)
def test_a_frame_the_window_skips_has_no_detection_the_stack_acts_on(make: Any, gate: float):
    """Over random road users: when the gate skips a frame, no detection of any road user
    in it (within the box error the gate allows) passes the stack's tests; the window
    skips frames the size gate alone renders, and rendered frames do hold passing ones."""
    stack = make()
    backend = EmbeddedBackend(perception="camera", frame_gate=gate)
    backend._min_sizes = backend._gate_sizes(stack, CAMERA)
    backend._window = backend._gate_window(stack, CAMERA)
    assert backend._window is not None
    min_px = backend._gate_px(stack, CAMERA)
    rng = np.random.default_rng(3)
    ego = Pose(0.0, 0.0, 0.0)
    skipped_by_window = passing_rendered = 0
    for _ in range(600):
        actors = tuple(_random_actor(rng) for _ in range(int(rng.integers(1, 3))))
        dets = [d for a in actors for d in _candidate_detections(CAMERA, ego, a, gate)]
        acts = any(stack._perceive((d,), None) for d in dets)
        if backend._needs_frame(CAMERA, ego, actors, min_px):
            passing_rendered += acts
            continue
        assert not acts, actors
        skipped_by_window += actors_in_view(CAMERA, ego, actors, min_px, backend._min_sizes)
    assert skipped_by_window > 20
    assert passing_rendered > 20


def test_skipped_frames_mean_no_passing_detection_for_three_frames() -> None:
    """A skipped frame gives ``detections=()``: for the three-frames stack a frame without
    a passing detection, which starts its count over (as before the window gate)."""
    stack = ThreeFrames()
    hit = Detection((300.0, 100.0, 500.0, 300.0), 0.9, "car")
    assert [stack._perceive((hit,), None) for _ in range(2)] == [False, False]
    assert not stack._perceive((), None)  # a skipped frame
    assert [stack._perceive((hit,), None) for _ in range(3)] == [False, False, True]


class _Silent:
    """A stack that declares nothing (an external stack without the hello fields)."""

    camera = CAMERA


def test_a_stack_that_declares_nothing_gets_every_frame() -> None:
    backend = EmbeddedBackend(perception="camera")
    assert backend._gate_window(_Silent(), CAMERA) is None
    wide = ReferenceStack(params={"centering": (0.0, 1.0)})
    assert backend._gate_window(wide, CAMERA) is None  # looks everywhere: no window
    assert backend._gate_window(ReferenceStack(), CAMERA) == pytest.approx((40.0, 784.0))
    assert RightBlind().centre_window == pytest.approx((0.05, 0.4))
    backend.skip_empty_frames = False
    assert backend._gate_window(RightBlind(), CAMERA) is None
    # frame_gate 0: the box error is unbounded, the window never skips a visible actor
    assert EmbeddedBackend(perception="camera", frame_gate=0.0)._gate_spread() == math.inf


def test_external_stack_declares_its_window_in_the_hello() -> None:
    hello = {"type": "hello", "protocol": PROTOCOL_VERSION, "wants": "detections"}
    assert "centre_window" not in parse_hello(hello, who="s")
    peer = parse_hello({**hello, "centre_window": [0.1, 0.6]}, who="s")
    assert peer["centre_window"] == (0.1, 0.6)
    for bad in ([0.6, 0.1], [0.1], "left", [0.0, 1.5], [True, 1]):
        with pytest.raises(StackError, match="centre_window"):
            parse_hello({**hello, "centre_window": bad}, who="s")


# --- repeated frames ----------------------------------------------------------------------


def _world(x: float, actor_x: float) -> Any:
    view = ActorView(Pose(actor_x, 0.0, 0.0), 4.5, 1.9, 1.5, 0.0)
    actor = SimpleNamespace(active=True, view=lambda: view)
    return SimpleNamespace(ego=SimpleNamespace(body=SimpleNamespace(x=x, y=0.0, yaw=0.0)),
                           actors=[actor])  # fmt: skip


def _driver(rain: float, kind: str) -> tuple[EgoDriver, list[int], list[int]]:
    """A camera-mode driver whose renderer and detector count their calls."""
    backend = EmbeddedBackend(perception="camera")
    renders: list[int] = []
    detects: list[int] = []

    def render(camera: Any, pose: Any, actors: Any, conditions: Any, _g: Any, rng: Any):
        renders.append(1)
        img = np.full((camera.height, camera.width, 3), int(pose.x * 10) % 256, np.uint8)
        img[0, 0, 0] = int(rng.integers(0, 256)) if rain else 0  # rain: a random draw
        return img

    def detect(image: np.ndarray) -> tuple[Detection, ...]:
        detects.append(1)
        return (Detection((0.0, 0.0, 10.0, 10.0), float(image[1, 1, 0]) / 255, "car"),)

    backend._render_frame = render  # test hook: the renderer the backend loads lazily
    backend.detector = detect
    values = {"precipitation": rain, "cloudiness": 0.0, "fog_density": 0.0}
    cond = conditions_from_values(values, wind_direction=0.0, profile="carla")
    stack = SimpleNamespace(camera=CAMERA)
    rng = np.random.default_rng(0)
    return EgoDriver(backend, stack, None, cond, rng, 7, 0, 0, 0.0, kind), renders, detects


def test_a_frame_that_repeats_the_last_is_not_rendered_again() -> None:
    driver, renders, _ = _driver(0.0, "image")
    first = driver._perceive(_world(1.0, 20.0), 0)[1]
    again = driver._perceive(_world(1.0, 20.0), 2)[1]
    assert len(renders) == 1
    assert again is not first and np.array_equal(again, first)
    again[:] = 0  # the stack may write into its frame: the kept one stays as rendered
    assert np.array_equal(driver._perceive(_world(1.0, 20.0), 4)[1], first)
    driver._perceive(_world(1.0, 20.5), 6)  # the road user moved: a new frame
    driver._perceive(_world(1.5, 20.5), 8)  # the ego moved
    assert len(renders) == 3


def test_frames_with_rain_are_always_rendered() -> None:
    driver, renders, _ = _driver(50.0, "image")
    for k in range(3):
        driver._perceive(_world(1.0, 20.0), 2 * k)
    assert len(renders) == 3


def test_detections_of_a_repeated_frame_are_not_detected_again() -> None:
    driver, renders, detects = _driver(0.0, "camera-detections")
    first = driver._perceive(_world(1.0, 20.0), 0)[0]
    assert driver._perceive(_world(1.0, 20.0), 2)[0] == first
    assert (len(renders), len(detects)) == (1, 1)
    driver._perceive(_world(2.0, 20.0), 4)
    assert (len(renders), len(detects)) == (2, 2)


def test_detector_gives_the_same_detections_for_the_same_pixels(ssd_detector, monkeypatch):
    calls: list[int] = []
    inner = ssd_detector._detect

    def counting(image: np.ndarray) -> Any:
        calls.append(1)
        return inner(image)

    monkeypatch.setattr(ssd_detector, "_detect", counting)
    img = np.random.default_rng(11).integers(0, 256, (450, 800, 3), dtype=np.uint8)
    first = ssd_detector(img)
    assert ssd_detector(img.copy()) == first and len(calls) == 1
    changed = img.copy()
    changed[449, 799, 2] ^= 1  # one value in a row the quick check skips
    ssd_detector(changed)
    assert len(calls) == 2
    assert inner(img) == first  # the network itself is deterministic


def test_the_verdict_check_reruns_the_stored_rows_it_names() -> None:
    """``benchmarks/bench_camera_gate_verdicts.py`` picks, per stack, the first situations
    of one stream of the stored camera rows, with the run seeds the experiment used."""
    import sys
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    sys.path.insert(0, str(root / "tests"))
    try:
        from benchmark_modules import load_benchmark
    finally:
        sys.path.remove(str(root / "tests"))
    from sitcov.campaign._agreement import read_rows, stream_seed

    bench = load_benchmark("bench_camera_gate_verdicts")
    rows = bench.select(read_rows(root / bench.ROWS), 3, "A", None)
    assert len(rows) == 12 and {r["stream"] for r in rows} == {"A"}
    assert len({r["stack"] for r in rows}) == 4
    assert all(r["index"] < 3 and r["run_seed"] == stream_seed("A", 8, r["index"]) for r in rows)


def test_the_default_gate_covers_the_detectors_box_error(ssd_detector, tjunction_geometry):
    """The margin ``frame_gate`` stands for, checked on the real detector: over cars seen
    from the rear, the side and at an angle, 6-20 m ahead and off to either side, every
    detection that passes the score test and overlaps the car's true box is at most
    ``1 / FRAME_GATE`` times as wide (a car is gated on its width), and centred inside
    the true box."""
    from sitcov.perception import render_frame
    from sitcov.perception._nms import iou
    from sitcov.sim.embedded._backend import FRAME_GATE

    geometry, ego = tjunction_geometry
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    checked, worst = 0, 0.0
    for fwd in (6.0, 9.0, 13.0, 20.0):
        for left in (-3.0, 0.0, 3.0):
            for yaw in (0.0, 0.8, 1.57):
                x = ego.x + (CAMERA.mount_x + fwd) * c - left * s
                y = ego.y + (CAMERA.mount_x + fwd) * s + left * c
                car = ActorView(Pose(x, y, ego.yaw + yaw), 4.5, 1.9, 1.5)
                img = render_frame(CAMERA, ego, (car,), None, geometry, np.random.default_rng(0))
                true = project_box(CAMERA, ego, car).box
                w = true[2] - true[0]
                for d in ssd_detector(img):
                    if d.label != "car" or d.score < 0.5:
                        continue
                    if iou(np.array(true), np.array([d.box]))[0] <= 0.3:
                        continue
                    checked += 1
                    worst = max(worst, (d.box[2] - d.box[0]) / w)
                    assert true[0] <= 0.5 * (d.box[0] + d.box[2]) <= true[2], (fwd, left, yaw)
    assert checked >= 10
    assert worst <= 1.0 / FRAME_GATE, worst
