"""The per-class frame gate: a stack declares the smallest box it acts on per class
(``min_box_sizes``); camera mode skips frames in which no actor comes near it, and that
never hides a pedestrian or cyclist box the reference AEB would have braked for."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sitcov.av import ReferenceStack
from sitcov.av._aeb import aeb_min_box_sizes, aeb_test
from sitcov.av._protocol import PROTOCOL_VERSION, parse_hello
from sitcov.calibration._class_runs import class_hyperspace
from sitcov.errors import StackError
from sitcov.generation import make_generator
from sitcov.perception import ActorView, CameraSpec, Detection, Pose
from sitcov.perception._camera import project_box
from sitcov.sim.embedded import EmbeddedBackend

CAMERA = CameraSpec()


@given(st.floats(0.0, 1.0), st.sampled_from(["person", "bicycle"]))
def test_min_height_is_where_the_distance_test_starts_passing(distance: float, cls: str) -> None:
    """Below the declared height the AEB's distance test never passes; just above, it does."""
    _, h = aeb_min_box_sizes(distance, [cls], CAMERA)[cls]

    def passes(frac: float) -> bool:
        px = frac * CAMERA.height
        box = (380.0, 440.0 - px, 420.0, 440.0)
        return aeb_test(Detection(box, 0.9, cls), CAMERA.width, 0.5, (0.05, 0.98), distance, cls)

    if 0.002 < h < 0.97:
        assert not passes(h - 0.002)
        assert passes(h + 0.002)


def test_reference_stack_declares_person_and_bicycle_heights() -> None:
    sizes = ReferenceStack().min_box_sizes
    assert set(sizes) == {"person", "bicycle"}
    assert all(w == 0.0 and 0.15 < h < 0.25 for w, h in sizes.values()), sizes
    assert ReferenceStack(fault="f3").min_box_sizes["person"][1] > sizes["person"][1]
    assert "person" not in ReferenceStack(fault="f4").min_box_sizes  # F4 ignores persons
    assert ReferenceStack(aeb=False).min_box_sizes == {}


def _pedestrian(distance: float) -> tuple[Pose, ActorView]:
    ego = Pose(0.0, 0.0, 0.0)
    return ego, ActorView(Pose(distance, 0.5, 1.57), 0.5, 0.5, 1.75, 1.4, kind="pedestrian")


class _Declares:
    """A stand-in stack that declares only per-class sizes."""

    min_box_width = 0.1
    min_box_sizes = {"person": (0.0, 0.4)}


def test_backend_gates_a_pedestrian_on_its_declared_height() -> None:
    backend = EmbeddedBackend(perception="camera", frame_gate=0.5)
    backend._min_sizes = backend._gate_sizes(_Declares(), CAMERA)
    assert backend._min_sizes["person"] == pytest.approx((0.0, 0.5 * 0.4 * CAMERA.height))
    gate = backend._gate_px(_Declares(), CAMERA)
    heights = {}
    for d in (4.0, 8.0, 12.0, 25.0):
        ego, ped = _pedestrian(d)
        heights[d] = project_box(CAMERA, ego, ped).height
        rendered = backend._needs_frame(CAMERA, ego, (ped,), gate)
        assert rendered == (heights[d] >= 0.2 * CAMERA.height), (d, heights[d])
    assert heights[4.0] >= 0.2 * CAMERA.height > heights[25.0]
    backend._min_sizes = {}  # a stack that declares nothing: every visible pedestrian counts
    assert backend._needs_frame(CAMERA, *_pedestrian(25.0)[:1], (_pedestrian(25.0)[1],), gate)


def _rendered_heights(gate: float, kind: str, situations: int = 4) -> list[float]:
    """True box heights [px] of the actor of ``kind`` in every frame rendered.

    The blind stack never looks at a frame's pixels, so the backend's renderer is replaced
    by one that counts its calls and returns a black frame (as in test_camera_gate.py):
    which frames are drawn is decided before any pixel is, and drawing them was most of
    this test's time."""
    backend = EmbeddedBackend(perception="camera", frame_gate=gate)
    heights: list[float] = []
    rendered: list[int] = []

    def observe(camera: Any, pose: Any, actors: Any, conditions: Any) -> None:
        boxes = [project_box(camera, pose, a) for a in actors if a.kind == kind]
        heights.append(max((b.height for b in boxes if b is not None), default=0.0))

    def render(camera: Any, *_: Any) -> np.ndarray:
        rendered.append(1)
        return np.zeros((camera.height, camera.width, 3), dtype=np.uint8)

    backend.frame_observer = observe
    backend._render_frame = render  # test hook: the renderer the backend loads lazily
    gen = make_generator("random", class_hyperspace(kind))
    blind = ReferenceStack(detector=lambda image: ())  # never brakes: every frame is asked for
    blind.centre_window = (0.0, 1.0)  # the size gate alone (the window: test_camera_window.py)
    for i in range(situations):
        backend.run(gen.ask(np.random.default_rng(i)), blind, i)
    assert len(rendered) == len(heights)  # the observer sees exactly the frames drawn
    return heights


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["pedestrian", "cyclist"])
def test_gate_renders_only_frames_with_a_person_or_cyclist_near_the_minimum(kind: str) -> None:
    cls = "person" if kind == "pedestrian" else "bicycle"
    floor = 0.5 * ReferenceStack().min_box_sizes[cls][1] * CAMERA.height
    gated, every = _rendered_heights(0.5, kind), _rendered_heights(0.0, kind)
    assert gated and min(gated) >= floor - 1e-6
    assert sum(h >= floor - 1e-6 for h in every) == len(gated)  # none of those is skipped
    assert len(every) > 3 * len(gated)  # most frames hold only a small, distant actor


def test_external_stacks_declare_sizes_in_their_hello() -> None:
    hello = {"type": "hello", "protocol": PROTOCOL_VERSION}
    peer = parse_hello({**hello, "min_box_sizes": {"person": {"height": 0.2}}}, who="s")
    assert peer["min_box_sizes"] == {"person": (0.0, 0.2)}
    for bad in ({"person": {"height": 1.5}}, {"person": 0.2}, [0.2], {"car": {"width": True}}):
        with pytest.raises(StackError, match="min_box_sizes"):
            parse_hello({**hello, "min_box_sizes": bad}, who="s")
