"""Camera-mode frame gating: frames whose vehicles are too small to matter to the stack are
not rendered, and that never hides a box the stack would have acted on."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sitcov.av import ReferenceStack
from sitcov.av._aeb import aeb_min_box_width, aeb_test
from sitcov.errors import ConfigError
from sitcov.generation import make_generator
from sitcov.hyperspace import load_hyperspace
from sitcov.perception import Detection
from sitcov.perception._camera import project_box
from sitcov.sim.embedded import EmbeddedBackend

WIDTH = 800.0


@given(st.floats(0.0, 1.0))
def test_min_box_width_is_where_the_distance_test_starts_passing(distance: float) -> None:
    r = aeb_min_box_width(distance)

    def passes(ratio: float) -> bool:
        box = (400.0 - 0.5 * ratio * WIDTH, 100.0, 400.0 + 0.5 * ratio * WIDTH, 300.0)
        return aeb_test(Detection(box, 0.9), WIDTH, 0.5, (0.05, 0.98), distance)

    if r > 0.001:
        assert not passes(r - 0.001)  # narrower than the declared minimum: never acted on
    assert passes(min(1.0, r + 0.001))


def test_reference_stack_declares_its_minimum_box() -> None:
    assert ReferenceStack().min_box_width == pytest.approx(1 - 0.65**0.25)
    # fault f3 (distance 0.35) only brakes for wider boxes
    assert ReferenceStack(fault="f3").min_box_width > ReferenceStack().min_box_width
    assert ReferenceStack(aeb=False).min_box_width == math.inf


def _frames_seen(gate: float, situations: int = 6) -> list[float]:
    """True OV box widths [px] of every frame rendered, over a few random situations.

    The blind stack never looks at a frame's pixels, so the backend's renderer is replaced
    by one that counts its calls and returns a black frame: the gating decides which frames
    are asked for before any pixel is drawn, and rendering itself is the camera tests'
    (test_detector_checks.py, test_renderer.py). Drawing the ~thousand ungated frames cost
    most of this test's time."""
    backend = EmbeddedBackend(perception="camera", frame_gate=gate)
    widths: list[float] = []
    rendered: list[int] = []

    def observe(camera: Any, pose: Any, actors: Any, conditions: Any) -> None:
        widths.append(max(p.width for a in actors if (p := project_box(camera, pose, a))))

    def render(camera: Any, *_: Any) -> np.ndarray:
        rendered.append(1)
        return np.zeros((camera.height, camera.width, 3), dtype=np.uint8)

    backend.frame_observer = observe
    backend._render_frame = render  # test hook: the renderer the backend loads lazily
    gen = make_generator("random", load_hyperspace())
    blind = ReferenceStack(detector=lambda image: ())  # never brakes: every frame is asked for
    for i in range(situations):
        backend.run(gen.ask(np.random.default_rng(i)), blind, i)
    assert len(rendered) == len(widths)  # the observer sees exactly the frames drawn
    return widths


def test_gate_renders_only_frames_with_a_box_near_the_stacks_minimum() -> None:
    floor = 0.5 * ReferenceStack().min_box_width * WIDTH
    gated, every = _frames_seen(0.5), _frames_seen(0.0)
    assert gated and min(gated) >= floor
    assert len(every) > 2 * len(gated)  # most frames hold only a small, distant OV
    assert sum(w >= floor for w in every) == len(gated)


def test_gate_must_be_a_fraction() -> None:
    with pytest.raises(ConfigError, match="frame_gate"):
        EmbeddedBackend(perception="camera", frame_gate=1.5)
