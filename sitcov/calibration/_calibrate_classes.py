"""``sitcov calibrate --classes``: the per-class PEM fitted on rendered frames and on runs.

For each kind (pedestrian, cyclist), as ``sitcov calibrate`` does for cars:

1. :func:`sitcov.perception._pem_classes.class_sweep`: static frames of one actor of the
   kind at random distance, bearing, heading, appearance and weather, rendered and run
   through the SSD (every size and weather value);
2. :func:`sitcov.calibration._class_runs.class_camera_runs`: camera-mode runs of the
   reference stack through random situations of the kind (the derived t-junction
   hyperspace restricted to it), recorded frame by frame: the geometries and weather
   combinations campaigns meet, in the frames the AEB decides on, and each run's verdict;
3. :func:`sitcov.perception._pem_classes.fit_class` on the runs' frames plus the sweep's
   frames with boxes lower than any the runs rendered (below the frame gate);
4. :func:`choose_shift`: the intercept shift whose PEM-mode verdicts (under run seeds of
   their own) agree most with the runs' camera verdicts. A run's verdict hangs on the
   first frame that passes the AEB's test, and the frames a camera run records are those
   before its AEB fired, so the frame-level fit alone is biased towards the hard frames.

Everything goes into one file (``data/pem_classes.yaml``), headed by the command.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sitcov.calibration._camera_runs import CameraRun
from sitcov.errors import ConfigError
from sitcov.perception._pem import PEMFeatures, PEMParams

#: Intercept shifts [logit] tried by :func:`choose_shift`.
BIAS_SHIFTS = (-0.6, -0.4, -0.2, 0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
#: Camera-mode runs per kind by default.
DEFAULT_RUNS = 150


@dataclass(frozen=True)
class ClassCalibration:
    """What calibrating one kind produced: the fitted parameters, the frames and runs."""

    kind: str
    label: str
    params: PEMParams
    sweep: list[tuple[PEMFeatures, float]]
    runs: list[CameraRun]
    summary: dict[str, Any]


def fit_frames(
    sweep: Sequence[tuple[PEMFeatures, float]], runs: Sequence[CameraRun]
) -> list[tuple[PEMFeatures, float]]:
    """The frames the fit uses: every run frame, and sweep frames lower than the lowest
    box the runs rendered (where the runs say nothing)."""
    run_frames = [
        (f.features, f.score) for r in runs for f in r.frames if f.features.height_px >= 1
    ]
    lowest = min((f.height_px for f, _ in run_frames), default=float("inf"))
    return [s for s in sweep if s[0].height_px < lowest] + run_frames


def class_agreement(
    kind: str, label: str, params: PEMParams, runs: Sequence[CameraRun]
) -> tuple[float, float]:
    """(agreement with the runs' camera verdicts, PEM failure rate) of PEM-mode runs of the
    same situations, each under a run seed of its own (:func:`_calibrate.cross_seed`)."""
    from sitcov.av import ReferenceStack
    from sitcov.calibration._calibrate import cross_seed
    from sitcov.hyperspace import Situation
    from sitcov.perception._pem import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    sensor = PEMSensor(classes={kind: (label, params)})
    backend, stack = EmbeddedBackend(perception="pem", sensor=sensor), ReferenceStack()
    agree = fails = 0
    for run in runs:
        failed = backend.run(Situation.from_dict(run.situation), stack, cross_seed(run)).failed
        agree += failed == run.failed
        fails += failed
    n = max(1, len(runs))
    return agree / n, fails / n


def choose_shift(
    kind: str,
    label: str,
    params: PEMParams,
    runs: Sequence[CameraRun],
    shifts: Sequence[float] = BIAS_SHIFTS,
) -> tuple[PEMParams, dict[str, Any]]:
    """The intercept shift whose verdicts agree most with the camera's (module doc).

    Ties go to the smaller failure-rate gap, then to the smaller shift. Returns the shifted
    parameters and every candidate's agreement and failure rate.
    """
    from dataclasses import replace

    camera_rate = sum(r.failed for r in runs) / max(1, len(runs))
    table: dict[str, Any] = {}
    best: tuple[tuple[float, float, float], PEMParams] | None = None
    for shift in shifts:
        cand = replace(params, bias=round(params.bias + shift, 4))
        agree, rate = class_agreement(kind, label, cand, runs)
        table[f"shift={shift:g}"] = {"agreement": round(agree, 3), "failure_rate": round(rate, 3)}
        key = (round(agree, 9), -round(abs(rate - camera_rate), 9), -abs(shift))
        if best is None or key > best[0]:
            best = (key, cand)
    assert best is not None
    return best[1], table


def calibrate_kind(
    kind: str,
    frames: int,
    runs: int,
    *,
    seed: int,
    detector: Callable[[np.ndarray], Sequence[Any]],
    model: str | None = None,
    workers: int = 1,
    progress: Callable[[str, int], None] | None = None,
) -> ClassCalibration:
    """Sweep, record the runs and fit one kind (module doc)."""
    from sitcov.calibration._class_runs import class_camera_runs
    from sitcov.perception._base import CameraSpec
    from sitcov.perception._pem import load_pem_params
    from sitcov.perception._pem_classes import class_sweep, fit_class, summary
    from sitcov.perception._renderer import KIND_CLASS

    label = KIND_CLASS[kind]
    sweep = class_sweep(kind, frames, detector, seed=seed)
    if progress is not None:
        progress(kind, frames)
    recorded = class_camera_runs(
        kind, runs, seed=seed, model=model, workers=workers,
        progress=None if progress is None else (lambda r: progress(kind, frames + r)),
    )  # fmt: skip
    fitted = fit_class(fit_frames(sweep, recorded), load_pem_params())
    params, table = (fitted, {}) if not recorded else choose_shift(kind, label, fitted, recorded)
    info = summary(sweep, CameraSpec())
    if recorded:
        info["camera_runs"] = _runs_summary(recorded, params.bias - fitted.bias, table)
    return ClassCalibration(kind, label, params, sweep, recorded, info)


def _runs_summary(runs: Sequence[CameraRun], shift: float, table: dict[str, Any]) -> dict:
    frames = [f for r in runs for f in r.frames]
    return {
        "runs": len(runs),
        "frames": len(frames),
        "events_score_ge_0.5": sum(f.score >= 0.5 for f in frames),
        "failure_rate_camera": round(sum(r.failed for r in runs) / len(runs), 3),
        "cpu_s_per_run": round(sum(r.cpu_s for r in runs) / len(runs), 3),
        "bias_shift": round(shift, 4),
        "pem_agreement_by_shift": table,
    }


def parse_classes(text: str) -> list[str]:
    """``--classes``: comma-separated kinds, each pedestrian or cyclist."""
    from sitcov.calibration._class_runs import CLASS_KINDS

    kinds = [k.strip() for k in text.split(",") if k.strip()]
    if not kinds or any(k not in CLASS_KINDS for k in kinds) or len(set(kinds)) != len(kinds):
        raise ConfigError(field="--classes", value=text, expected="pedestrian and/or cyclist")
    return kinds


def calibrate_classes(
    kinds: Sequence[str],
    frames: int,
    runs: int = DEFAULT_RUNS,
    *,
    seed: int = 1,
    model: str | None = None,
    workers: int = 1,
    progress: Callable[[str, int], None] | None = None,
) -> list[ClassCalibration]:
    """:func:`calibrate_kind` for every kind, with one detector."""
    from sitcov.perception._detector import SSDDetector
    from sitcov.perception._pem_classes import SWEEP_MIN_SCORE

    detector = SSDDetector(model, min_score=SWEEP_MIN_SCORE)
    return [
        calibrate_kind(kind, frames, runs, seed=seed, detector=detector, model=model,
                       workers=workers, progress=progress)
        for kind in kinds
    ]  # fmt: skip


def classes_yaml(results: Sequence[ClassCalibration], command: str, seed: int) -> str:
    """The text of ``pem_classes.yaml``: header with ``command``, meta, the classes."""
    import yaml

    head = (
        "# Per-class PEM parameters (pedestrians, cyclists): sitcov/perception/_pem_classes.py,\n"
        "# docs/camera.md#per-class-pem. Missing names take the car PEM's (pem.yaml). Made by:\n"
        f"#   {command}\n"
    )
    meta: dict[str, Any] = {"source": "sitcov calibrate --classes", "command": command,
                            "calibration_seeds": [seed]}  # fmt: skip
    meta.update({r.kind: r.summary for r in results})
    classes = {r.kind: {"label": r.label, "params": r.params.to_dict()} for r in results}
    return head + yaml.safe_dump({"meta": meta, "classes": classes}, sort_keys=False)


def write_samples(path: Any, results: Sequence[ClassCalibration]) -> None:
    """Every sweep frame and run (with its frames) as JSON lines, for re-fitting offline."""
    import json
    from dataclasses import asdict

    with open(path, "w") as fh:
        for r in results:
            for feats, score in r.sweep:
                row = {"kind": r.kind, "sweep": list(feats), "score": score}
                fh.write(json.dumps(row) + "\n")
            for run in r.runs:
                fh.write(json.dumps({"kind": r.kind, "run": asdict(run)}) + "\n")
