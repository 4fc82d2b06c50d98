"""Four decision rules besides the reference AEB, for measuring how PEM verdicts carry over.

Each is the reference stack (route following, the paper's three AEB tests on a detection)
with one change in how it decides to brake:

- :class:`Threshold07`: the score test at θ = 0.7 instead of 0.5;
- :class:`ThreeFrames`: brakes only when the tests pass in three consecutive camera frames;
- :class:`RightBlind`: ignores every detection whose box centre is right of 40 % of the
  image width (blind in the right 60 % of its image), so it brakes late or not at all for
  road users coming from its right;
- :class:`NoPersons`: ignores ``person`` boxes (fault f4's classes), so it brakes for a
  cyclist only on its bicycle's box and never for a pedestrian.

They work in PEM mode (they read the detections) and in camera mode (the reference stack's
detector, :class:`sitcov.perception.SSDDetector`, unless one is given). The agreement
experiment runs them by name (from the repository root, so ``examples`` imports)::

    PYTHONPATH=. sitcov experiment agreement --seeds 8 --situations 40 \\
        --stack reference --stack examples.aeb_stacks:Threshold07 \\
        --stack examples.aeb_stacks:ThreeFrames --stack examples.aeb_stacks:RightBlind \\
        --out agreement-stacks.csv
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, ClassVar

from sitcov.av import ReferenceStack
from sitcov.perception import Detection


class Threshold07(ReferenceStack):
    """The reference stack with the AEB's score threshold at 0.7 (``params`` may override)."""

    name: ClassVar[str] = "threshold-0.7"

    def __init__(self, fault: str | None = None, params: Mapping[str, Any] | None = None) -> None:
        super().__init__(fault=fault, params={"threshold": 0.7, **(params or {})})


class ThreeFrames(ReferenceStack):
    """The reference stack that brakes only after ``frames`` (3) consecutive camera frames
    in which some detection passes the three tests; a frame without one starts over."""

    name: ClassVar[str] = "three-frames"
    frames: ClassVar[int] = 3

    def _reset_state(self) -> None:
        super()._reset_state()
        self._streak = 0

    def _perceive(self, detections: Sequence[Detection] | None, image: Any) -> bool:
        hit = super()._perceive(detections, image)
        self._streak = self._streak + 1 if hit else 0
        return self._streak >= self.frames


class RightBlind(ReferenceStack):
    """The reference stack blind in the right part of its camera image: a detection whose
    box centre is at or right of ``blind_from`` (0.4) of the image width is dropped before
    the AEB's tests.

    Why 0.4 and not the image centre: a road user on a collision course from the ego's
    right is braked for (the reference AEB's first firing detection) with its box centre
    at 0.48-0.65 of the image width (10th-90th percentile; one from the left at
    0.11-0.34, one ahead at 0.42-0.53). Blind from the centre, the stack still brakes for
    most of them a frame or two later, once the box centre has crossed to the left half,
    and fails no more often from the right than from the left (34/103 vs 31/105, p =
    0.35): no weakness for the agreement experiment to find. Blind from 0.4 it covers
    where those decisive boxes are: 88/103 vs 40/105. (PEM runs of situations 0-299 of
    seed 8: ``python benchmarks/bench_blind_side.py --seed 8 --situations 300``;
    docs/pem.md, "Agreement across stacks".)

    It declares what it looks at (``centre_window``: its centering interval cut at
    ``blind_from``), so camera mode does not render frames in which no road user comes
    near the left part of its image (docs/camera.md, frame skipping).
    """

    name: ClassVar[str] = "right-blind"
    blind_from: ClassVar[float] = 0.4

    def __init__(self, fault: str | None = None, params: Mapping[str, Any] | None = None) -> None:
        super().__init__(fault=fault, params=params)
        # declared for camera mode's frame gate: what it drops never reaches its AEB
        lo, hi = self.centre_window
        self.centre_window = (lo, min(hi, self.blind_from))

    def _perceive(self, detections: Sequence[Detection] | None, image: Any) -> bool:
        if detections is None:
            if image is None:
                return False
            detections = self._detect(image)
        edge = self.blind_from * self.camera.width
        left = tuple(d for d in detections if 0.5 * (d.box[0] + d.box[2]) < edge)
        return super()._perceive(left, None)


class NoPersons(ReferenceStack):
    """The reference stack that ignores ``person`` boxes (its ``classes`` are ``car`` and
    ``bicycle``, as with fault f4): blind to pedestrians and to a cyclist's rider, it
    brakes for a cyclist on the bicycle's box alone, which the detector scores lower and
    draws shorter than the rider's (docs/pem.md, "The cyclist's two detections"). The
    PEM serves it only since it gives a cyclist its bicycle's detection too."""

    name: ClassVar[str] = "no-persons"

    def __init__(self, fault: str | None = None, params: Mapping[str, Any] | None = None) -> None:
        super().__init__(fault=fault, params={"classes": ("car", "bicycle"), **(params or {})})
