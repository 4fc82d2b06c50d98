"""The frame model's check on held-out frames: P(score >= θ), PEM vs detector.

For each kind (car, person, bicycle), distance band and threshold θ, the detector's share
of frames whose recorded score reaches θ is compared with the PEM's probability of it,
averaged over the same frames: ``P(score >= θ) = Φ((m(x) - logit θ) / noise_sigma)`` for a
box at least ``size_min_px`` high (0 below it, as the sensor never reports it), with
``m`` the PEM's own logit (:func:`sitcov.perception.pem_logit`) of the frame's features.
The frames should be held out (recorded with another seed than the fit's) and recorded
with ``--record-frames`` (the stack given no detections), so that no frame was kept or
dropped because of a score: the marginal probability is then the right prediction.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from sitcov.calibration._frames import KIND_LABEL, KindFrames
from sitcov.perception._pem import PEMParams
from sitcov.perception._pem import pass_probability as _pass

#: Distance bands [m] of the check (lower bound inclusive).
BANDS: tuple[tuple[float, float], ...] = ((0.0, 10.0), (10.0, 20.0), (20.0, 40.0))
#: Score thresholds of the check.
THETAS = (0.3, 0.4, 0.5, 0.6, 0.7)
#: Largest allowed |PEM - detector| difference of P(score >= θ) [-].
TOLERANCE = 0.05
#: Fewest frames in a cell for it to be judged (the binomial standard error of a rate
#: from 30 frames is up to 0.09, more than the tolerance: smaller cells say nothing).
MIN_FRAMES = 30


def pass_probability(params: PEMParams, feats: Any, theta: float) -> float:
    """The PEM's P(score >= theta) for one frame's features
    (:func:`sitcov.perception._pem.pass_probability`)."""
    return _pass(feats, params, theta)


def frames_of(data: KindFrames) -> list[tuple[Any, float, float]]:
    """(features, score, distance) of every run frame with a recorded distance."""
    return [
        (f.features, f.score, f.distance)
        for r in data.runs
        for f in r.frames
        if f.distance >= 0.0 and f.features.height_px >= 1.0
    ]


def check_frames(
    frames: Mapping[str, KindFrames], params: Mapping[str, PEMParams],
    thetas: Sequence[float] = THETAS, bands: Sequence[tuple[float, float]] = BANDS,
) -> list[dict[str, Any]]:  # fmt: skip
    """One row per (kind, band, θ): frames, detector and PEM rates, difference, within
    :data:`TOLERANCE`; ``params`` per kind."""
    rows = []
    for kind, data in frames.items():
        p = params[kind]
        got = frames_of(data)
        for lo, hi in bands:
            sel = [(f, s) for f, s, d in got if lo <= d < hi]
            for theta in thetas:
                row: dict[str, Any] = {"kind": kind, "label": KIND_LABEL[kind], "theta": theta}
                row.update(band=f"{lo:g}-{hi:g} m", n=len(sel))
                if len(sel) >= MIN_FRAMES:
                    det = float(np.mean([s >= theta for _, s in sel]))
                    pem = float(np.mean([pass_probability(p, f, theta) for f, _ in sel]))
                    row.update(detector=round(det, 4), pem=round(pem, 4),
                               difference=round(pem - det, 4),
                               ok=abs(pem - det) <= TOLERANCE)  # fmt: skip
                rows.append(row)
    return rows


def table_lines(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The check as a printed table, then the count of cells within the tolerance."""
    lines = [f"{'class':<8} {'band':<9} {'theta':>5} {'n':>6} {'detector':>9} {'PEM':>7} "
             f"{'diff':>7}  within ±{TOLERANCE:g}"]  # fmt: skip
    for r in rows:
        if "detector" not in r:
            lines.append(
                f"{r['label']:<8} {r['band']:<9} {r['theta']:>5.1f} {r['n']:>6}  "
                f"(fewer than {MIN_FRAMES} frames: not judged)"
            )
            continue
        lines.append(
            f"{r['label']:<8} {r['band']:<9} {r['theta']:>5.1f} {r['n']:>6} {r['detector']:>9.3f} "
            f"{r['pem']:>7.3f} {r['difference']:>+7.3f}  {'yes' if r['ok'] else 'NO'}"
        )
    judged = [r for r in rows if "ok" in r]
    lines.append(f"{sum(r['ok'] for r in judged)}/{len(judged)} cells within ±{TOLERANCE:g}")
    return lines
