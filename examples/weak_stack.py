"""A deliberately weak stack: the reference stack, blind to its left half of the image.

It ignores every detection whose box centre lies left of the image centre, so it does not
brake for cars approaching from its left until they are already in front of it. Use it to
check that a campaign exposes a known weakness: in the report, the intersection situations
in which the OV comes from the ego's left (IntSit-5, -8, -9, -10 of the default hyperspace)
have clearly higher failure rates than those in which it comes from the right (IntSit-3,
-4, -6, -7)::

    PYTHONPATH=. sitcov run --runs 400 --db weak.db --av examples.weak_stack:WeakStack
    sitcov summary --db weak.db     # compare the intsit bins' failure rates and ci95

Works in PEM mode (detections) and camera mode (it filters its detector's output).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import replace
from typing import Any, ClassVar

from sitcov.av import Observation, ReferenceStack
from sitcov.av._base import Control
from sitcov.perception import Detection


class WeakStack(ReferenceStack):
    """The reference stack that never sees cars in the left half of its camera image.

    Args:
        fault: a seeded fault of the reference stack, as for ``ReferenceStack``.
        params: parameter overrides, as for ``ReferenceStack``.
    """

    name: ClassVar[str] = "weak"

    def __init__(self, fault: str | None = None, params: Mapping[str, Any] | None = None) -> None:
        self._detector: Any = None
        super().__init__(fault=fault, params=params, detector=self._detect_right_half)

    def _right_half(self, detections: Sequence[Detection]) -> tuple[Detection, ...]:
        half = 0.5 * self.camera.width
        return tuple(d for d in detections if 0.5 * (d.box[0] + d.box[2]) >= half)

    def _detect_right_half(self, image: Any) -> tuple[Detection, ...]:
        if self._detector is None:
            from sitcov.perception import SSDDetector  # the camera extra, loaded on first use

            self._detector = SSDDetector()
        return self._right_half(self._detector(image))

    def step(self, observation: Observation) -> Control:
        """The reference stack's step on the right half of the detections."""
        if observation.detections is not None:
            observation = replace(observation, detections=self._right_half(observation.detections))
        return super().step(observation)
