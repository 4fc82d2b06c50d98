"""Car calibration end to end: record the sweep and the camera runs, then fit the PEM.

The fitting pieces are in :mod:`sitcov.calibration._calibrate` (in-sample noise choice)
and :mod:`sitcov.calibration._cv` (run-grouped cross-validation); the measurements are a
:class:`~sitcov.calibration._recording.Recording`. ``sitcov calibrate`` calls
:func:`record` and :func:`fit_recording`.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from sitcov.calibration import _cv
from sitcov.calibration._calibrate import (
    DEFAULT_RUNS,
    SWEEP_MIN_SCORE,
    THRESHOLD,
    choose_noise,
    fit_pem,
    summarize_samples,
    sweep,
)
from sitcov.calibration._camera_runs import CameraRun, camera_runs
from sitcov.calibration._recording import Recording
from sitcov.perception._pem import PEMParams


def record(
    frames: int = 1500,
    *,
    runs: int = DEFAULT_RUNS,
    seed: int = 0,
    model: str | None = None,
    workers: int = 1,
    progress: Callable[[int], None] | None = None,
) -> Recording:
    """Render and detect ``frames`` sweep scenes and record ``runs`` camera-mode runs.

    ``progress`` receives the number of steps done out of ``frames + runs``.
    """
    from sitcov.perception._detector import SSDDetector

    detector = SSDDetector(model, min_score=SWEEP_MIN_SCORE)
    samples = sweep(frames, detector, seed=seed, progress=progress)
    recorded: list[CameraRun] = []
    if runs > 0:
        recorded = camera_runs(
            runs,
            seed=seed,
            model=model,
            workers=workers,
            progress=None if progress is None else (lambda r: progress(frames + r)),
        )
    return Recording(seed, frames, tuple(samples), tuple(recorded))


def fit_recording(
    recording: Recording, *, cv_folds: int | None = None
) -> tuple[PEMParams, dict[str, Any]]:
    """Fit the PEM to a :class:`Recording`; returns the parameters and the summary
    ``pem_yaml`` stores.

    Without ``cv_folds``: :func:`fit_pem`, then :func:`choose_noise` on the runs' verdicts
    (in-sample). With ``cv_folds``: the fit option (ridge penalty) and the noise (scale,
    shift) are chosen together by held-out agreement over that many run-grouped folds
    (:mod:`sitcov.calibration._cv`); the chosen option is then fitted on every run.
    """
    samples, recorded = list(recording.samples), list(recording.runs)
    summary = summarize_samples(samples)
    summary["seed"] = recording.seed
    if not recorded:
        return fit_pem(samples), summary
    if cv_folds is None:
        fitted = fit_pem(samples, runs=recorded)
        params, table = choose_noise(fitted, recorded)
    else:
        fitted, params, table = _fit_cv(recording, cv_folds)
    run_frames = [f for r in recorded for f in r.frames]
    summary["camera_runs"] = {
        "runs": len(recorded),
        "seed": recording.seed,
        "frames": len(run_frames),
        "frames_per_run": round(len(run_frames) / max(1, len(recorded)), 1),
        "events_score_ge_0.5": sum(f.score >= THRESHOLD for f in run_frames),
        "failure_rate_camera": round(sum(r.failed for r in recorded) / len(recorded), 3),
        "bias_shift": round(params.bias - fitted.bias, 4),
        "noise_sigma_fitted": fitted.noise_sigma,
        "noise_scale": round(params.noise_sigma / fitted.noise_sigma, 2),
    }
    key = "pem_agreement_by_noise" if cv_folds is None else "cross_validation"
    summary["camera_runs"][key] = table
    return params, summary


def _fit_cv(recording: Recording, folds: int) -> tuple[PEMParams, PEMParams, dict[str, Any]]:
    """(fitted, chosen, CV record) of :func:`fit_recording` with ``cv_folds``."""
    result = _cv.cross_validate(
        recording, _cv.FIT_OPTIONS, scales=_cv.CV_SCALES, shifts=_cv.CV_SHIFTS, folds=folds
    )
    chosen = _cv.pick(result)
    option, scale, shift = _cv.parse_key(chosen)
    fitted = option.fit(recording, recording.runs)
    record = {k: v for k, v in result.items() if k != "table"}
    record.update(chosen=chosen, table=result["table"])
    return fitted, _cv.noisy(fitted, scale, shift), record
