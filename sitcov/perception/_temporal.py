"""Measure how the detector's errors are correlated in time, for the PEM's noise model.

A real detector's error on one car is not redrawn every frame: the same car, in the same
light, seen from nearly the same pose, is scored alike from frame to frame, and some cars
are harder to see than others for a whole run. ``trajectory_sweep`` re-simulates embedded
runs (PEM mode, the reference stack) with their trajectories recorded, renders the dash-cam
at 10 Hz along them, runs the detector and records the OV's score next to its PEM features.
``fit_temporal`` takes the residuals ``logit(score) - z(features)`` of a fitted PEM,
standardised by its noise scale, and fits the pooled autocorrelation

    r(k) = noise_run_share + (1 - noise_run_share) * exp(-k * frame_dt / noise_tau)

over lags k = 1..MAX_LAG frames (pairs of frames in the same run; the residuals are centred
on their global mean, so a per-run offset shows as correlation that does not decay).
Frames whose score fell below the sweep's reporting threshold have no residual and are left
out: the fit describes the reported part of the score distribution.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._camera import project_box
from sitcov.perception._nms import iou
from sitcov.perception._pem import PEMFeatures, PEMParams, PEMSensor, pem_logit

#: Lags fitted [frames] and the frame period of the sweep [s] (the backend's 10 Hz).
MAX_LAG = 15
FRAME_DT = 0.1
#: OV boxes lower than this are not rendered (nothing to measure) [px].
MIN_HEIGHT_PX = 8.0
#: Grids searched for the fit: run share [-] and correlation time [s].
SHARE_GRID = tuple(i / 100 for i in range(0, 96))
TAU_GRID = tuple(0.02 * 1.08**i for i in range(90))


@dataclass(frozen=True)
class TrackSample:
    """One frame along a re-simulated run.

    Attributes:
        run: run number in the sweep. frame: frame number in the run (10 Hz).
        features: the PEM's features of the OV. score: matched detection's score, 0 if none.
    """

    run: int
    frame: int
    features: PEMFeatures
    score: float


def trajectory_sweep(
    runs: int,
    detector: Callable[[np.ndarray], Sequence[Any]],
    *,
    seed: int = 0,
    match_iou: float = 0.3,
    progress: Callable[[int], None] | None = None,
) -> list[TrackSample]:
    """Render and detect the OV along ``runs`` re-simulated embedded runs (random situations)."""
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception._renderer import render_frame
    from sitcov.sim import conditions_from_values
    from sitcov.sim.embedded import EmbeddedBackend

    gen = make_generator("random", load_hyperspace())
    backend = EmbeddedBackend(perception="pem")
    stack = ReferenceStack()
    camera = CameraSpec()
    sensor = PEMSensor(camera=camera)
    geometry = backend.map.render_geometry()
    vp = backend.vehicle
    every = max(1, round(FRAME_DT / backend.dt))
    out: list[TrackSample] = []
    for r in range(runs):
        sit = gen.ask(np.random.default_rng([seed, 1, r]))
        outcome = backend.run(sit, stack, int(np.random.default_rng([seed, 2, r]).integers(2**31)),
                              record=True)  # fmt: skip
        trace = outcome.trace
        assert trace is not None
        cond = conditions_from_values(sit.values, wind_direction=outcome.metrics["wind_direction"])
        ovs = {round(row[0] / backend.dt): row for row in trace.ov}
        for erow in trace.ego:
            k = round(erow[0] / backend.dt)
            if k % every or k not in ovs:
                continue
            orow = ovs[k]
            ego = Pose(erow[1], erow[2], erow[3])
            actor = ActorView(Pose(orow[1], orow[2], orow[3]), vp.length, vp.width, vp.height,
                              orow[4])  # fmt: skip
            feats = sensor.features(ego, actor, cond)
            proj = project_box(camera, ego, actor)
            if feats is None or proj is None or feats.height_px < MIN_HEIGHT_PX:
                continue
            rng = np.random.default_rng([seed, 3, r, k])
            image = render_frame(camera, ego, (actor,), cond, geometry, rng)
            dets = detector(image)
            score = 0.0
            if dets:
                boxes = np.asarray([d.box for d in dets], dtype=np.float64)
                overlaps = iou(np.asarray(proj.box, dtype=np.float64), boxes)
                best = int(np.argmax(overlaps))
                if overlaps[best] >= match_iou:
                    score = float(dets[best].score)
            out.append(TrackSample(r, k // every, feats, score))
        if progress is not None:
            progress(r + 1)
    return out


def residuals(
    samples: Sequence[TrackSample], params: PEMParams, censor: float
) -> dict[int, dict[int, float]]:
    """Standardised residuals ``(logit(score) - z) / sigma`` per run and frame.

    Only frames whose score reached ``censor`` (and boxes of at least ``size_min_px``) count.
    """
    out: dict[int, dict[int, float]] = {}
    for s in samples:
        if s.score < censor or s.features.height_px < params.size_min_px:
            continue
        y = min(max(s.score, 1e-4), 1 - 1e-4)
        sigma = max(params.noise_sigma + params.rain_sigma * s.features.rain_noise, 1e-3)
        e = (math.log(y / (1 - y)) - pem_logit(s.features, params)) / sigma
        out.setdefault(s.run, {})[s.frame] = e
    return out


def autocorrelation(res: dict[int, dict[int, float]], max_lag: int = MAX_LAG):
    """Pooled autocorrelation r(1..max_lag) of the residuals and the pair count of each lag."""
    values = [e for run in res.values() for e in run.values()]
    if len(values) < 2:
        return np.zeros(max_lag), np.zeros(max_lag, dtype=int)
    mean = float(np.mean(values))
    var = float(np.var(values)) or 1.0
    acc = np.zeros(max_lag)
    cnt = np.zeros(max_lag, dtype=int)
    for run in res.values():
        for f, e in run.items():
            for lag in range(1, max_lag + 1):
                other = run.get(f + lag)
                if other is not None:
                    acc[lag - 1] += (e - mean) * (other - mean)
                    cnt[lag - 1] += 1
    r = np.divide(acc, np.maximum(cnt, 1)) / var
    return r, cnt


def fit_correlation(
    r: np.ndarray, counts: np.ndarray, frame_dt: float = FRAME_DT
) -> tuple[float, float]:
    """Least-squares ``(noise_run_share, noise_tau)`` of ``r(k) = s + (1-s) exp(-k dt / tau)``."""
    lags = np.arange(1, len(r) + 1) * frame_dt
    w = counts.astype(float)
    best = (math.inf, 0.0, 0.0)
    for tau in TAU_GRID:
        decay = np.exp(-lags / tau)
        for share in SHARE_GRID:
            model = share + (1.0 - share) * decay
            err = float(np.sum(w * (r - model) ** 2))
            if err < best[0]:
                best = (err, share, tau)
    return best[1], best[2]


def fit_temporal(
    samples: Sequence[TrackSample], params: PEMParams, censor: float
) -> tuple[float, float, dict[str, Any]]:
    """Fit ``noise_run_share`` and ``noise_tau``; also return what was measured (for ``meta``)."""
    res = residuals(samples, params, censor)
    r, counts = autocorrelation(res)
    share, tau = fit_correlation(r, counts)
    means = [float(np.mean(list(run.values()))) for run in res.values() if len(run) >= 5]
    values = [e for run in res.values() for e in run.values()]
    within = [float(np.var(list(run.values()))) for run in res.values() if len(run) >= 5]
    stats = {
        "runs": len(res),
        "frames": len(values),
        "frames_rendered": len(samples),
        "lag1_autocorrelation": round(float(r[0]), 3),
        "lag10_autocorrelation": round(float(r[9]), 3) if len(r) >= 10 else None,
        "residual_variance": round(float(np.var(values)), 3) if values else None,
        "between_run_variance_of_run_means": round(float(np.var(means)), 3) if means else None,
        "mean_within_run_variance": round(float(np.mean(within)), 3) if within else None,
    }
    return share, tau, stats
