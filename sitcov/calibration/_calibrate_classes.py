"""``sitcov calibrate --classes``: the per-class PEM fitted on rendered frames and on runs.

For each kind (pedestrian, cyclist), as ``sitcov calibrate`` does for cars:

1. :func:`sitcov.calibration._class_fit.class_sweep`: static frames of one actor of the
   kind at random distance, bearing, heading, appearance and weather, rendered and run
   through the SSD (every size and weather value);
2. :func:`sitcov.calibration._class_runs.class_camera_runs`: camera-mode runs of the
   reference stack through random situations of the kind (the derived t-junction
   hyperspace restricted to it), recorded frame by frame: the geometries and weather
   combinations campaigns meet, in the frames the AEB decides on, and each run's verdict;
3. :func:`sitcov.calibration._class_fit.fit_class` on the sweep's frames and the runs'
   frames together;
4. :func:`choose_shift`: the intercept shift, in units of the fitted ``noise_sigma``,
   whose PEM-mode verdicts (under run seeds of their own) agree with the runs' camera
   verdicts. A run's verdict hangs on the first frame that passes the AEB's test, and the
   frames a camera run records are those before its AEB fired, so the frame-level fit
   alone may be biased towards the hard frames. The shift is in ``noise_sigma`` units
   because a frame's P(score >= 0.5) is ``Phi(z / noise_sigma)``: a fixed shift in logit
   units moves classes with a small noise_sigma by many standard deviations. Shifts whose
   agreement is within :data:`AGREEMENT_TOLERANCE` of the best go to the smallest
   ``|shift|``: verdict agreement is flat near its best (the AEB acts on one frame), and
   a larger shift buys a run or two of agreement with a frame-level over-report.

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

#: Intercept shifts [in units of the fitted noise_sigma] tried by :func:`choose_shift`.
BIAS_SHIFTS = (-2.0, -1.5, -1.0, -0.5, 0.0, 0.5, 1.0, 1.5, 2.0)
#: Agreement within this of the best counts as a tie, which goes to the smallest |shift|
#: (3 runs in 150: about half the Wilson half-width of a 97 % agreement on 150 runs).
AGREEMENT_TOLERANCE = 0.02
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
    """The frames the fit uses: every sweep frame and every run frame (a box of >= 1 px).

    The sweep covers every size and weather value evenly; the runs add the geometries the
    AEB decides on. Fitting on the runs alone (with only the sweep's frames below them)
    left the PEM 19 points under the SSD at >= 0.5 on static cyclist boxes >= 70 px."""
    run_frames = [
        (f.features, f.score) for r in runs for f in r.frames if f.features.height_px >= 1
    ]
    return list(sweep) + run_frames


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
    """The intercept shift (``shift * noise_sigma``) chosen from the verdicts (module doc).

    Returns the shifted parameters and every candidate's agreement and failure rate.
    """
    from dataclasses import replace

    table: dict[str, Any] = {}
    cands: list[tuple[float, float, PEMParams]] = []
    for shift in shifts:
        cand = replace(params, bias=round(params.bias + shift * params.noise_sigma, 4))
        agree, rate = class_agreement(kind, label, cand, runs)
        table[f"shift={shift:g}"] = {"agreement": round(agree, 3), "failure_rate": round(rate, 3)}
        cands.append((agree, shift, cand))
    return pick_shift(cands), table


def pick_shift(cands: Sequence[tuple[float, float, PEMParams]]) -> PEMParams:
    """Of (agreement, shift, params) candidates, the smallest ``|shift|`` whose agreement is
    within :data:`AGREEMENT_TOLERANCE` of the best (ties: the negative shift)."""
    if not cands:
        raise ValueError("pick_shift needs at least one candidate")
    best = max(a for a, _, _ in cands)
    near = [c for c in cands if c[0] >= best - AGREEMENT_TOLERANCE - 1e-12]
    return min(near, key=lambda c: (abs(c[1]), c[1]))[2]


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
    from sitcov.calibration._class_fit import class_sweep
    from sitcov.calibration._class_runs import class_camera_runs

    sweep = class_sweep(kind, frames, detector, seed=seed)
    if progress is not None:
        progress(kind, frames)
    recorded = class_camera_runs(
        kind, runs, seed=seed, model=model, workers=workers,
        progress=None if progress is None else (lambda r: progress(kind, frames + r)),
    )  # fmt: skip
    return fit_kind(kind, sweep, recorded)


def fit_kind(
    kind: str,
    sweep: Sequence[tuple[PEMFeatures, float]],
    recorded: Sequence[CameraRun],
    *,
    shift: bool = True,
) -> ClassCalibration:
    """Fit one kind on its sweep and recorded runs (step 3) and choose the shift (step 4).

    Without ``shift`` the frame fit is kept and the agreement by shift is only recorded:
    a refit from stored runs re-simulates their situations under today's simulator, whose
    verdicts may no longer be comparable with the stored camera verdicts.
    """
    from sitcov.calibration._class_fit import fit_class, summary
    from sitcov.perception._base import CameraSpec
    from sitcov.perception._pem import load_pem_params
    from sitcov.perception._renderer import KIND_CLASS

    label = KIND_CLASS[kind]
    fitted = fit_class(fit_frames(sweep, recorded), load_pem_params())
    params, table = (fitted, {}) if not recorded else choose_shift(kind, label, fitted, recorded)
    params = params if shift else fitted
    info = summary(sweep, CameraSpec())
    if recorded:
        chosen = (params.bias - fitted.bias) / fitted.noise_sigma
        info["camera_runs"] = _runs_summary(recorded, chosen, table)
        info["camera_runs"]["shift_applied"] = shift
    return ClassCalibration(kind, label, params, list(sweep), list(recorded), info)


def _runs_summary(runs: Sequence[CameraRun], shift: float, table: dict[str, Any]) -> dict:
    frames = [f for r in runs for f in r.frames]
    return {
        "runs": len(runs),
        "frames": len(frames),
        "events_score_ge_0.5": sum(f.score >= 0.5 for f in frames),
        "failure_rate_camera": round(sum(r.failed for r in runs) / len(runs), 3),
        "cpu_s_per_run": round(sum(r.cpu_s for r in runs) / len(runs), 3),
        "bias_shift_sigmas": round(shift, 4),
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
    from sitcov.calibration._class_fit import SWEEP_MIN_SCORE
    from sitcov.perception._detector import SSDDetector

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


def read_samples(
    path: Any,
) -> dict[str, tuple[list[tuple[PEMFeatures, float]], list[CameraRun]]]:
    """What :func:`write_samples` wrote: per kind, the sweep frames and the recorded runs."""
    import json

    from sitcov.calibration._camera_runs import RunFrame, stored_features

    out: dict[str, tuple[list[tuple[PEMFeatures, float]], list[CameraRun]]] = {}
    import gzip

    opener = gzip.open if str(path).endswith(".gz") else open
    try:
        fh = opener(path, "rt")
    except OSError as exc:
        raise ConfigError(file=str(path), expected="a readable --samples file") from exc
    with fh:
        for n, line in enumerate(fh, 1):
            try:
                row = json.loads(line)
                sweep, runs = out.setdefault(row["kind"], ([], []))
                if "sweep" in row:
                    sweep.append((PEMFeatures(*row["sweep"]), float(row["score"])))
                    continue
                run = dict(row["run"])
                where = run.get("situation")
                run["frames"] = tuple(
                    RunFrame(**{**f, "features": stored_features(f["features"], where),
                                "box_error": None if f["box_error"] is None
                                else tuple(f["box_error"])})
                    for f in run["frames"]
                )  # fmt: skip
                runs.append(CameraRun(**run))
            except (ValueError, KeyError, TypeError) as exc:
                raise ConfigError(
                    file=str(path), field=f"line {n}", value=line[:60],
                    expected="a sweep or run row written by --samples",
                ) from exc  # fmt: skip
    return out


def refit_from_samples(kinds: Sequence[str], path: Any) -> list[ClassCalibration]:
    """:func:`fit_kind` for every kind on a :func:`write_samples` file (no rendering), the
    frame fit without the verdict-chosen shift (see :func:`fit_kind`)."""
    data = read_samples(path)
    missing = [k for k in kinds if k not in data or not data[k][0]]
    if missing:
        raise ConfigError(file=str(path), field="kind", value=",".join(missing),
                          expected="sweep frames of every kind asked for")  # fmt: skip
    return [fit_kind(kind, *data[kind], shift=False) for kind in kinds]
