"""Which box of a cyclist the reference AEB brakes on, in camera mode and in PEM mode.

The PEM gives a cyclist one detection (label ``bicycle``, the whole cyclist's projected
3-D box, 1.8 x 0.6 x 1.7 m). The SSD gives up to two: the bicycle and the rider
(``person``). This script re-simulates situations ``0..N-1`` of the cyclist-only
hyperspace (``sitcov experiment agreement --kind cyclist``: situation ``ask_rng(s, i)``,
run seed A ``run_seed(s, i)``) with the reference stack, once in camera mode and once in
PEM mode, and records per frame of the cyclist:

- the true (PEM) box's height [px, unclipped] and the distance [m];
- camera: the detections labelled ``person`` and ``bicycle`` overlapping the true box
  (IoU >= ``MATCH_IOU``, the SSD with a 0.05 floor), each label's top score and its box
  height, which label holds the top score (what the PEM's score law is fitted to), and
  which labels' boxes pass the reference AEB's single-frame test (``aeb_test``);
- PEM: the same for the PEM's own detection;
- per run: the verdict, when the AEB first fired, and the label, score, box height and
  the cyclist's distance of the first detection that passed.

    PYTHONPATH=. python benchmarks/pem_cyclist_boxes.py --seed 6 --situations 60 \\
        --out docs/data/pem-cyclist-boxes-seed6.json

``--fault f4`` runs the stack with the seeded fault F4 (it ignores ``person`` boxes);
``--pem-classes FILE`` another per-class PEM.

Camera runs cost 1-3 CPU-s each (one process); PEM runs about 0.03 s. docs/pem.md,
"The cyclist's two boxes", quotes the summary.
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sitcov.calibration._camera_runs import MATCH_IOU
from sitcov.perception._base import Detection
from sitcov.perception._camera import project_box
from sitcov.perception._nms import iou
from sitcov.perception._recording import FrameTruth, RecordingDetector, RecordingPEM

#: The SSD's reporting floor while recording (the stack still gets only its usual >= 0.3).
RECORD_FLOOR = 0.05
#: The labels a cyclist's boxes carry.
LABELS = ("person", "bicycle")


class Log(FrameTruth):
    """One run's frames (filled by the instrumented stack, detector and PEM; ``truth``,
    ``views`` and ``raw`` as :class:`FrameTruth`'s)."""

    def __init__(self) -> None:
        super().__init__()
        self.frames: list[dict[str, Any]] = []
        self.first: dict[str, Any] | None = None


def frame_record(
    truth_box: Sequence[float],
    height_px: float,
    distance: float,
    dets: Sequence[Detection],
    passes: Any,
) -> dict[str, Any]:
    """One frame of the cyclist: per label the top-scoring detection overlapping the true
    box (IoU >= MATCH_IOU; score, box height, whether it passes the AEB's single-frame
    test ``passes(detection)``), the label holding the top score, and the labels of every
    overlapping detection that passes."""
    out: dict[str, Any] = {"h": round(float(height_px), 1), "dist": round(float(distance), 2)}
    top_label, top_score = None, 0.0
    passing: set[str] = set()
    if dets:
        ov = iou(np.asarray(truth_box, np.float64), np.asarray([d.box for d in dets], np.float64))
        for d, o in zip(dets, np.atleast_1d(ov), strict=True):
            if o < MATCH_IOU or d.label not in LABELS:
                continue
            ok = bool(passes(d))
            if ok:
                passing.add(d.label)
            held = out.get(d.label)
            if held is None or d.score > held["score"]:
                out[d.label] = {
                    "score": round(float(d.score), 4),
                    "h": round(float(d.box[3] - d.box[1]), 1),
                    "iou": round(float(o), 3),
                    "pass": ok,
                }
            if d.score > top_score:
                top_label, top_score = d.label, float(d.score)
    out["top"] = top_label
    out["top_score"] = round(top_score, 4)
    out["passing"] = sorted(passing)
    return out


def first_firing(dets: Sequence[Detection], passes: Any) -> Detection | None:
    """The detection that makes the AEB fire: the first in the list that passes (the
    stack tests them in order and fires on the first)."""
    for d in dets:
        if passes(d):
            return d
    return None


def summarise(runs: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per mode: frames with an overlapping box, the label holding the top score, the
    median ratio of each label's box height to the true (PEM) box height, frames with a
    passing box per label; per run the label of the first firing detection, its box
    height over the true box's, and the distance at which each mode fired first."""
    out: dict[str, Any] = {"runs": len(runs)}
    for mode in ("camera", "pem"):
        frames = [f for r in runs for f in r[mode]["frames"]]
        seen = [f for f in frames if f["top"] is not None]
        ratios = {
            label: [f[label]["h"] / f["h"] for f in frames if label in f and f["h"] > 0]
            for label in LABELS
        }
        fired = [r[mode]["first"] for r in runs if r[mode]["first"] is not None]
        out[mode] = {
            "frames": len(frames),
            "frames_with_box": len(seen),
            "top_label": dict(Counter(f["top"] for f in seen)),
            "top_label_at_05": dict(Counter(f["top"] for f in seen if f["top_score"] >= 0.5)),
            "height_ratio_median": {
                k: (round(float(np.median(v)), 3) if v else None) for k, v in ratios.items()
            },
            "height_ratio_n": {k: len(v) for k, v in ratios.items()},
            "frames_passing": {k: sum(k in f["passing"] for f in frames) for k in LABELS},
            "failed": sum(bool(r[mode]["failed"]) for r in runs),
            "fired": len(fired),
            "first_label": dict(Counter(f["label"] for f in fired)),
            "first_height_ratio_median": (
                round(float(np.median([f["h"] / f["true_h"] for f in fired])), 3) if fired else None
            ),
            "first_distance_median": (
                round(float(np.median([f["dist"] for f in fired])), 2) if fired else None
            ),
        }
    both = [r for r in runs if r["camera"]["first"] and r["pem"]["first"]]
    out["both_fired"] = len(both)
    out["pem_fired_farther"] = sum(
        r["pem"]["first"]["dist"] > r["camera"]["first"]["dist"] + 0.05 for r in both
    )
    out["camera_fired_farther"] = sum(
        r["camera"]["first"]["dist"] > r["pem"]["first"]["dist"] + 0.05 for r in both
    )
    return out


class Simulator:
    """Camera and PEM backends and an instrumented reference stack, built once."""

    def __init__(self, seed: int, pem_classes: str | None = None, fault: str | None = None) -> None:
        from sitcov.av import ReferenceStack
        from sitcov.av._aeb import aeb_test
        from sitcov.calibration._class_runs import class_hyperspace
        from sitcov.generation import make_generator
        from sitcov.sim.embedded import EmbeddedBackend

        self.seed = seed
        self.log = Log()
        self.generator = make_generator("random", class_hyperspace("cyclist"))
        pem = RecordingPEM(classes=pem_classes, log_of=lambda: self.log)
        self.pem_backend = EmbeddedBackend(perception="pem", sensor=pem)
        self.camera_backend = EmbeddedBackend(perception="camera")
        self.camera_backend.frame_observer = self._observe
        sim = self

        class Instrumented(ReferenceStack):
            _t = 0.0

            def _step_values(self, t, *args):  # type: ignore[no-untyped-def]
                self._t = t
                return super()._step_values(t, *args)

            def _passes(self, d: Detection) -> bool:
                return aeb_test(
                    d, self.camera.width, self._threshold, self._centering, self._distance,
                    self._classes,
                )  # fmt: skip

            def _perceive(self, detections, image):  # type: ignore[no-untyped-def]
                if detections is None and image is None:
                    return False
                if detections is None:
                    detections = self._detect(image)
                fire = super()._perceive(detections, None)
                sim._record(self, detections, fire)
                return fire

        detector = RecordingDetector(lambda: self.log, floor=RECORD_FLOOR)
        self.stack = Instrumented(detector=detector, fault=fault)

    def _observe(self, camera: Any, pose: Any, actors: Any, conditions: Any) -> None:
        self.log.truth = (pose, actors, conditions)

    def _record(self, stack: Any, given: Sequence[Detection], fire: bool) -> None:
        log = self.log
        truth, log.truth = log.truth, None
        if truth is None:
            return
        pose, views, _ = truth
        cyclists = [v for v in views if v.kind == "cyclist"]
        if not cyclists:
            return
        proj = project_box(stack.camera, pose, cyclists[0])
        if proj is None or not proj.visible:
            return
        height = proj.raw_box[3] - proj.raw_box[1]
        log.frames.append(
            {"t": round(stack._t, 2)}
            | frame_record(proj.box, height, proj.distance, log.raw, stack._passes)
        )
        if fire and log.first is None:
            d = first_firing(given, stack._passes)
            if d is not None:
                log.first = {
                    "t": round(stack._t, 2),
                    "label": d.label,
                    "score": round(float(d.score), 4),
                    "h": round(float(d.box[3] - d.box[1]), 1),
                    "true_h": round(float(height), 1),
                    "dist": round(float(proj.distance), 2),
                }

    def run(self, index: int, mode: str) -> dict[str, Any]:
        """Situation ``index`` at run seed A in ``mode``: verdict, frames, first firing."""
        from sitcov._seeding import ask_rng, run_seed

        self.log = Log()
        backend = self.camera_backend if mode == "camera" else self.pem_backend
        situation = self.generator.ask(ask_rng(self.seed, index))
        cpu = time.process_time()
        outcome = backend.run(situation, self.stack, run_seed(self.seed, index))
        return {
            "failed": bool(outcome.failed),
            "aeb_time": outcome.aeb_time,
            "first": self.log.first,
            "frames": self.log.frames,
            "cpu_s": round(time.process_time() - cpu, 3),
        }


def main(argv: Sequence[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=6)
    ap.add_argument("--situations", type=int, default=60)
    ap.add_argument("--pem-classes", default=None, help="per-class PEM file (default: shipped)")
    ap.add_argument("--modes", default="camera,pem")
    ap.add_argument("--fault", default=None, help="the reference stack's seeded fault (f4 ...)")
    ap.add_argument("--out", type=Path, default=None)
    args = ap.parse_args(argv)
    sim = Simulator(args.seed, args.pem_classes, args.fault)
    modes = args.modes.split(",")
    runs = []
    t0 = time.perf_counter()
    for i in range(args.situations):
        runs.append({"index": i} | {m: sim.run(i, m) for m in modes})
    summary = summarise(runs) if set(modes) == {"camera", "pem"} else {}
    summary["wall_s"] = round(time.perf_counter() - t0, 1)
    print(json.dumps(summary, indent=1))
    if args.out is not None:
        kept = [{"index": r["index"]} | {m: _without_frames(r[m]) for m in modes} for r in runs]
        args.out.write_text(json.dumps({"summary": summary, "runs": kept}, indent=1) + "\n")


def _without_frames(run: dict[str, Any]) -> dict[str, Any]:
    """A run's record without its frames (the file keeps the verdicts and first firings)."""
    return {k: v for k, v in run.items() if k != "frames"}


if __name__ == "__main__":
    main()
