"""Camera mode stops rendering once the stack's emergency brake has latched (not while an
AEB that releases brakes)."""

from __future__ import annotations

from typing import Any

from sitcov.av import LatchedReferenceStack, ReferenceStack
from sitcov.hyperspace import Situation
from sitcov.perception import Detection
from sitcov.sim.embedded import EmbeddedBackend


def _counting_backend() -> tuple[EmbeddedBackend, dict[str, int]]:
    backend = EmbeddedBackend(perception="camera")
    count = {"frames": 0}

    def observe(*args: Any) -> None:
        count["frames"] += 1

    backend.frame_observer = observe
    return backend, count


SIT = Situation({"intsit": "IntSit-1"}, {"intsit": {"ego": "L-B", "ov": "R-B", "conflict": "c4"}})


def test_no_frame_is_rendered_after_the_brake_latched() -> None:
    backend, count = _counting_backend()
    # a detector that sees a close, centred car in every frame: the AEB fires at once
    seen = (Detection((200, 100, 600, 400), 0.99),)
    brake_now = LatchedReferenceStack(detector=lambda image: seen)
    out = backend.run(SIT, brake_now, 3)
    assert out.aeb_fired and count["frames"] == 1

    # the releasing AEB keeps perceiving: it needs frames to know when to hand back
    backend, count = _counting_backend()
    releasing = ReferenceStack(detector=lambda image: seen)
    short = EmbeddedBackend(perception="camera", sim_timeout=12.0)  # fires at 8.5 s
    short.frame_observer = backend.frame_observer
    outcome = short.run(SIT, releasing, 3)
    assert outcome.aeb_fired and count["frames"] > 10  # frames while it brakes

    backend, count = _counting_backend()
    blind = ReferenceStack(detector=lambda image: ())  # never brakes: frames all along
    out = backend.run(SIT, blind, 3)
    assert not out.aeb_fired and count["frames"] > 20
