"""Perception that also records what it saw, for diagnoses that compare the camera's
detector with the PEM frame by frame (``benchmarks/pem_flip_diagnosis.py``,
``benchmarks/pem_cyclist_boxes.py``): the stack's decisions are those of the plain
detector or PEM, the record holds what the stack was not given."""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np

from sitcov.perception._base import Detection, Pose
from sitcov.perception._detector import Detector, SSDDetector
from sitcov.perception._pem import PEMSensor


class FrameTruth:
    """One run's record, filled frame by frame: ``truth`` (ego pose, the road users' views
    at this frame, the conditions; taken and cleared by the consumer), ``views`` (the
    PEM's prepared actors, in order, each by its first detection) and ``raw`` (the
    frame's detections below the usual floor too, camera; the PEM's detections, PEM)."""

    def __init__(self) -> None:
        self.truth: tuple[Any, ...] | None = None
        self.views: list[tuple[Any, Any]] = []
        self.firsts: set[int] = set()  # ids of the views' looks (each road user's first)
        self.raw: tuple[Detection, ...] = ()


class RecordingDetector(Detector):
    """The SSD run with a low output floor, every detection kept in ``log_of().raw``,
    those at or above the usual floor returned: a stack sees what the plain SSD would give
    it (a lower floor adds candidates below every kept one, so the kept set and the
    stack's decisions are unchanged)."""

    def __init__(self, log_of: Callable[[], FrameTruth], floor: float = 0.05) -> None:
        self.usual = SSDDetector().min_score
        self.ssd = SSDDetector(min_score=floor)
        self.log_of = log_of

    def __call__(self, image: np.ndarray) -> tuple[Detection, ...]:
        dets = self.ssd(image)
        self.log_of().raw = dets
        return tuple(d for d in dets if d.score >= self.usual)


class RecordingPEM(PEMSensor):
    """The PEM (its compiled per-frame path, the same draws) noting each frame's truth in
    ``log_of()``: the prepared actors as they are prepared, then per frame the ego pose,
    each road user's view at its pose of that frame, the conditions, and the detections."""

    def __init__(self, *args: Any, log_of: Callable[[], FrameTruth], **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.log_of = log_of

    def prepare_parts(self, actor, conditions):  # type: ignore[no-untyped-def]
        out = super().prepare_parts(actor, conditions)
        log = self.log_of()
        log.views.append((actor, out[0]))  # a road user's first detection
        log.firsts.add(id(out[0]))
        return out

    def frame_detector(self, conditions, rng):  # type: ignore[no-untyped-def]
        inner = super().frame_detector(conditions, rng)

        def detect(ex, ey, eyaw, actors):  # type: ignore[no-untyped-def]
            log = self.log_of()
            out = inner(ex, ey, eyaw, actors)
            views, k = [], 0
            for look, body in actors:  # the active actors' parts, in prepare's order
                if id(look) not in log.firsts:
                    continue  # a road user's second detection (a cyclist's bicycle)
                while log.views[k][1] is not look:
                    k += 1
                pose = Pose(float(body.x), float(body.y), float(body.yaw))
                views.append(dataclasses.replace(log.views[k][0], pose=pose))
                k += 1
            log.truth = (Pose(ex, ey, eyaw), tuple(views), conditions)
            log.raw = out
            return out

        return detect
