"""Model choice for the car PEM by cross-validation over the calibration runs.

The PEM's score model (:func:`sitcov.calibration._calibrate.fit_pem`) and its run-level
noise scale and intercept shift (:func:`~sitcov.calibration._calibrate.choose_noise`) are
both fitted on the same camera runs; judging a fit option (a ridge penalty, features left
out) by the agreement it reaches on those runs rewards over-fitting (19 coefficients on
~260 frames with a score >= 0.5). Here every option is judged on runs its coefficients
never saw:

- the calibration runs are split into ``folds`` groups (by run: all frames of a run go to
  the same fold, drawn by a seeded permutation);
- for each fold, the score model is fitted on the sweep and the other folds' runs, and
  PEM-mode runs of the held-out fold's situations, under run seeds of their own
  (:func:`~sitcov.calibration._calibrate.cross_seed`, as the agreement experiment's
  ``pem-camera`` pair), are compared with the camera verdicts, for every noise candidate
  (scale, shift);
- the held-out verdicts of all folds are pooled: one agreement and failure rate per
  (option, scale, shift) over every calibration run.

:func:`pick` keeps, among the candidates within one standard error of the best pooled
agreement, the one whose failure rate is closest to the camera's (the rule of
:func:`~sitcov.calibration._calibrate.pick_noise`). Nothing here looks at evaluation seeds.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from sitcov.calibration._calibrate import cross_seed, fit_pem, noise_key
from sitcov.calibration._camera_runs import CameraRun
from sitcov.calibration._recording import Recording
from sitcov.perception._pem import PEMParams

#: Noise scales and intercept shifts [logit] tried with every fit option (a scale
#: multiplies the fitted ``noise_sigma``; the in-sample grid's largest scale, 1, never won).
CV_SCALES = (0.5, 0.25, 0.1, 0.05)
CV_SHIFTS = (0.0, 0.1, 0.2, 0.3, 0.4, 0.5, 0.6)


@dataclass(frozen=True)
class FitOption:
    """One way of fitting the score model: the probit's ridge penalty and the
    coefficients left out (see :func:`fit_pem`)."""

    ridge: float = 1.0
    drop: tuple[str, ...] = field(default_factory=tuple)

    @property
    def name(self) -> str:
        """Short label, e.g. ``ridge=10 drop=chroma_gain``."""
        text = f"ridge={self.ridge:g}"
        return text + (f" drop={','.join(self.drop)}" if self.drop else "")

    def fit(self, recording: Recording, runs: Sequence[CameraRun]) -> PEMParams:
        """The score model fitted on the recording's sweep and ``runs``."""
        return fit_pem(list(recording.samples), runs=runs, ridge=self.ridge, drop=self.drop)


#: The fit options compared (ridge penalty on the probit's coefficients; 1 is the
#: in-sample fit's).
FIT_OPTIONS = (FitOption(1.0), FitOption(10.0), FitOption(100.0))


def parse_key(key: str) -> tuple[FitOption, float, float]:
    """(option, scale, shift) of a :func:`cross_validate` table key."""
    name, noise = (part.strip() for part in key.split("|"))
    fields = dict(item.split("=", 1) for item in name.split())
    drop = tuple(fields["drop"].split(",")) if "drop" in fields else ()
    nf = dict(item.split("=", 1) for item in noise.split())
    return FitOption(float(fields["ridge"]), drop), float(nf["scale"]), float(nf["shift"])


def fold_of(runs: int, folds: int, seed: int) -> np.ndarray:
    """Fold index (0..folds-1) of each run: a seeded permutation cut into equal parts."""
    if folds < 2 or folds > runs:
        raise ValueError(f"folds must be in [2, {runs}], got {folds}")
    order = np.random.default_rng(seed).permutation(runs)
    out = np.empty(runs, dtype=np.int64)
    out[order] = np.arange(runs) % folds
    return out


def noisy(params: PEMParams, scale: float, shift: float) -> PEMParams:
    """``params`` with ``noise_sigma`` scaled and the intercept shifted (as choose_noise)."""
    return replace(
        params,
        noise_tau=0.0,
        noise_sigma=round(params.noise_sigma * scale, 4),
        bias=round(params.bias + shift, 4),
    )


def verdicts(params: PEMParams, runs: Sequence[CameraRun]) -> list[bool]:
    """PEM-mode verdicts (failed) of the runs' situations, each under :func:`cross_seed`."""
    from sitcov.av import ReferenceStack
    from sitcov.hyperspace import Situation
    from sitcov.perception._pem import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    backend = EmbeddedBackend(perception="pem", sensor=PEMSensor(params))
    stack = ReferenceStack()
    return [
        bool(backend.run(Situation.from_dict(r.situation), stack, cross_seed(r)).failed)
        for r in runs
    ]


def cross_validate(
    recording: Recording,
    options: Sequence[FitOption],
    *,
    scales: Sequence[float],
    shifts: Sequence[float],
    folds: int = 5,
    seed: int = 0,
    progress: Callable[[str], None] | None = None,
) -> dict[str, Any]:
    """Pooled held-out agreement of every (option, scale, shift) (module docstring).

    Returns ``{"table": {key: {agreement, failure_rate, n}}, "camera_failure_rate",
    "runs", "folds", "seed"}`` with keys ``"<option name> | tau=0 scale=.. shift=.."``.
    """
    runs = list(recording.runs)
    fold = fold_of(len(runs), folds, seed)
    camera = np.asarray([r.failed for r in runs])
    table: dict[str, Any] = {}
    for option in options:
        pem: dict[tuple[float, float], np.ndarray] = {
            (sc, sh): np.zeros(len(runs), dtype=bool) for sc in scales for sh in shifts
        }
        for k in range(folds):
            train = [r for r, f in zip(runs, fold, strict=True) if f != k]
            test_idx = np.flatnonzero(fold == k)
            test = [runs[i] for i in test_idx]
            fitted = option.fit(recording, train)
            for sc in scales:
                for sh in shifts:
                    pem[(sc, sh)][test_idx] = verdicts(noisy(fitted, sc, sh), test)
            if progress is not None:
                progress(f"{option.name}: fold {k + 1}/{folds}")
        for (sc, sh), failed in pem.items():
            table[f"{option.name} | {noise_key(0.0, sc, sh)}"] = {
                "agreement": round(float(np.mean(failed == camera)), 4),
                "failure_rate": round(float(np.mean(failed)), 4),
                "n": len(runs),
            }
    return {
        "table": table,
        "camera_failure_rate": round(float(np.mean(camera)), 4),
        "runs": len(runs),
        "folds": folds,
        "seed": seed,
    }


def pick(result: dict[str, Any]) -> str:
    """The key to keep: within one standard error of the best pooled agreement, the
    failure rate closest to the camera's (ties: the first in the table's order)."""
    table = result["table"]
    best = max(row["agreement"] for row in table.values())
    band = best - math.sqrt(best * (1.0 - best) / max(1, result["runs"])) - 1e-9
    near = [k for k, row in table.items() if row["agreement"] >= band]
    return min(near, key=lambda k: abs(table[k]["failure_rate"] - result["camera_failure_rate"]))
