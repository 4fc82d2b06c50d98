"""The frame model: the detector's score per road user and frame, fitted by maximum likelihood.

The PEM (:mod:`sitcov.perception._pem`) says, for one road user in one frame, what top
score the SSD gives it: ``logit(score_t) = m(x_t) + s_a * a_t + s_e * e_t`` with ``m`` the
PEM's logit of the features ``x_t`` (class, size, view, truncation, fog transmittance,
light, rain, colour), ``a_t`` a unit AR(1) process over the road user's frames (``a_t =
rho^g a_{t-g} + sqrt(1 - rho^(2g)) N(0, 1)``, ``g`` frames apart) and ``e_t`` independent
unit noise. ``s_a^2 + s_e^2 = noise_sigma^2``; ``noise_frame_share = s_e^2 / noise_sigma^2``;
``rho = exp(-frame_dt / noise_tau)``. The detector reports the road user when the score
reaches its output floor (0.3). It is the same model for every stack: no term is chosen
on any stack's verdicts.

The data are recorded frames of the real detector (:mod:`sitcov.calibration._frames`):
camera runs (consecutive frames of one road user form a *track*) and static sweep frames
(tracks of one frame). The recording kept detections down to 0.05, so a score below it is
*censored* (only ``logit(score) < logit(0.05)`` is known).

Fit (:func:`fit_kind`), by maximum likelihood:

1. *Frames as independent* (a Tobit model of the logit score, censored at 0.05): the
   coefficients ``beta`` and ``noise_sigma``, with a ridge penalty on the non-intercept
   coefficients, for each ``size_max_px`` on a grid (the best by likelihood).
2. *Tracks as sequences*: the exact likelihood of every track under the AR(1) + noise
   model (a forward filter on a grid of the AR state, :func:`track_loglik`), maximised over
   the intercept, a common scale of the other coefficients, ``noise_sigma``, the frame
   share and ``rho``. A camera run recorded with the reference stack stops calling its
   detector when its AEB fires; the sequence likelihood conditions each frame on the
   earlier ones, so that stopping rule (which depends only on earlier frames) leaves it
   valid, where step 1's independent-frames likelihood is biased by it.

Model choice (:func:`choose_model`): candidates (independent frames, AR(1) + noise; ridge
penalties) are compared by their log-likelihood on held-out tracks, run-grouped folds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from sitcov.calibration._calibrate import _LINEAR, _design, _jitter
from sitcov.calibration._frames import KindFrames
from sitcov.errors import SitcovError
from sitcov.perception._pem import FRAME_DT, PEMFeatures, PEMParams

#: Scores below this were not recorded (the recording detector's floor): censored [-].
CENSOR = 0.05
#: The detector's output floor in use: a road user is reported at this score [-].
FLOOR = 0.3
#: ``size_max_px`` candidates [px] (the best by step 1's likelihood).
SIZE_MAX_GRID = (60.0, 100.0, 150.0, 200.0, 300.0, 450.0)
#: Nodes of the AR state's grid (standard units, uniformly over +-5).
GRID_NODES = 41
#: Largest AR(1) coefficient per frame tried (the grid resolves kernels down to this).
RHO_MAX = 0.98
#: Model candidates: (name, ridge penalty, AR(1) term).
CANDIDATES = (
    ("independent ridge=1", 1.0, False),
    ("ar1 ridge=1", 1.0, True),
    ("independent ridge=10", 10.0, False),
    ("ar1 ridge=10", 10.0, True),
)


def _logit(p: np.ndarray | float) -> Any:
    return np.log(p) - np.log1p(-p)


@dataclass(frozen=True)
class Tracks:
    """Frames as arrays, grouped into tracks (one road user's consecutive frames).

    Attributes:
        feats: the frames' PEM features. score: recorded score (0 = none >= CENSOR).
        track: track number per frame (frames of a track are contiguous, in time order).
        gap: frames since the track's previous frame (0 for its first).
        group: the run (or sweep frame) a frame belongs to, for run-grouped folds.
        distance: camera to the road user [m] (-1 when not recorded).
    """

    feats: tuple[PEMFeatures, ...]
    score: np.ndarray
    track: np.ndarray
    gap: np.ndarray
    group: np.ndarray
    distance: np.ndarray

    def subset(self, groups: np.ndarray) -> Tracks:
        """The frames of the given groups."""
        keep = np.isin(self.group, groups)
        idx = np.flatnonzero(keep)
        return Tracks(
            tuple(self.feats[i] for i in idx), self.score[keep], self.track[keep],
            self.gap[keep], self.group[keep], self.distance[keep],
        )  # fmt: skip


def tracks_of(data: KindFrames) -> Tracks:
    """The tracks of one kind's frames: each sweep frame alone, each run split by actor.

    Runs recorded before frame numbers were stored (``frame`` = -1) count their frames
    as consecutive (the gated camera frames of one road user are, until its AEB fires).
    """
    feats: list[PEMFeatures] = []
    score, track, gap, group, dist = [], [], [], [], []
    n_track = 0
    for i, (f, s, d) in enumerate(data.sweep):
        if f.height_px < 1.0:
            continue
        feats.append(f)
        score.append(s), track.append(n_track), gap.append(0), group.append(-1 - i)
        dist.append(d)
        n_track += 1
    for r, run in enumerate(data.runs):
        by_actor: dict[int, list[Any]] = {}
        for k, fr in enumerate(run.frames):
            if fr.features.height_px >= 1.0:
                by_actor.setdefault(fr.actor, []).append((fr.frame if fr.frame >= 0 else k, fr))
        for frames in by_actor.values():
            prev = None
            for number, fr in frames:
                feats.append(fr.features)
                score.append(fr.score), track.append(n_track), group.append(r)
                gap.append(0 if prev is None else max(1, number - prev))
                dist.append(fr.distance)
                prev = number
            n_track += 1
    return Tracks(tuple(feats), np.asarray(score, dtype=float), np.asarray(track),
                  np.asarray(gap), np.asarray(group), np.asarray(dist, dtype=float))  # fmt: skip


# --- step 1: frames as independent (Tobit) ----------------------------------------------------


def _tobit(x: np.ndarray, y: np.ndarray, obs: np.ndarray, ridge: float) -> tuple[np.ndarray, float]:
    """Censored-normal regression of ``y`` on ``x`` (``obs`` False: ``y`` < logit(CENSOR)):
    (coefficients with ``log sigma`` last, penalised NLL)."""
    from scipy.optimize import minimize
    from scipy.special import log_ndtr

    c = float(_logit(CENSOR))
    yo = np.where(obs, y, 0.0)

    def nll(theta: np.ndarray) -> tuple[float, np.ndarray]:
        beta, ls = theta[:-1], theta[-1]
        sigma = math.exp(ls)
        m = x @ beta
        r = (yo - m) / sigma
        z = (c - m) / sigma
        lcdf = log_ndtr(z)
        value = float(np.sum(np.where(obs, 0.5 * r * r + ls, -lcdf)))
        lam = np.exp(-0.5 * z * z - 0.5 * math.log(2 * math.pi) - lcdf)
        dm = np.where(obs, -r / sigma, lam / sigma)
        dls = float(np.sum(np.where(obs, 1.0 - r * r, lam * z)))
        grad = np.r_[x.T @ dm, dls]
        value += ridge * float(np.sum(beta[1:] ** 2))
        grad[1:-1] += 2.0 * ridge * beta[1:]
        return value, grad

    start = np.zeros(x.shape[1] + 1)
    start[0] = float(np.mean(np.where(obs, y, c - 1.0)))
    res = minimize(nll, start, jac=True, method="L-BFGS-B")
    return res.x, float(res.fun)


def _design_for(t: Tracks, size_max: float, ref: float) -> np.ndarray:
    return _design(t.feats, 1.0, size_max, ref)


def _observed(t: Tracks) -> tuple[np.ndarray, np.ndarray]:
    """(logit score, observed) per frame; a score >= 1 - 1e-6 counts as 1 - 1e-6."""
    obs = t.score >= CENSOR
    y = _logit(np.clip(np.where(obs, t.score, 0.5), CENSOR, 1.0 - 1e-6))
    return y, obs


# --- step 2: tracks as sequences (AR(1) + noise, forward filter on a grid) -------------------


def _grid() -> tuple[np.ndarray, np.ndarray]:
    u = np.linspace(-5.0, 5.0, GRID_NODES)
    p = np.exp(-0.5 * u * u)
    return u, p / p.sum()


def _kernel(u: np.ndarray, rho: float) -> np.ndarray:
    """Row-stochastic transition of the unit AR(1) state over one step of coefficient rho."""
    sd = math.sqrt(max(1e-12, 1.0 - rho * rho))
    k = np.exp(-0.5 * ((u[None, :] - rho * u[:, None]) / sd) ** 2)
    return k / k.sum(axis=1, keepdims=True)


def track_loglik(
    m: np.ndarray, y: np.ndarray, obs: np.ndarray, t: Tracks, sigma: float, share: float,
    rho: float,
) -> np.ndarray:  # fmt: skip
    """Log-likelihood of each track (array over tracks, in track order).

    ``m``: the PEM logit per frame; ``y``/``obs``: the logit score and whether it was
    recorded; ``share``: the AR part's share ``s_a^2 / sigma^2`` (0 = independent frames,
    exact closed form); ``rho``: the AR coefficient per frame. Observed frames contribute
    densities of the logit score.
    """
    from scipy.special import log_ndtr

    c = float(_logit(CENSOR))
    n_tracks = int(t.track.max()) + 1 if len(t.track) else 0
    if share <= 0.0:
        r = (y - m) / sigma
        per = np.where(obs, -0.5 * r * r - math.log(sigma) - 0.5 * math.log(2 * math.pi),
                       log_ndtr((c - m) / sigma))  # fmt: skip
        return np.bincount(t.track, weights=per, minlength=n_tracks)
    s_a, s_e = sigma * math.sqrt(share), sigma * math.sqrt(1.0 - share)
    u, prior = _grid()
    starts = np.flatnonzero(np.r_[True, t.track[1:] != t.track[:-1]])
    lengths = np.diff(np.r_[starts, len(t.track)])
    order = np.argsort(-lengths, kind="stable")  # longest first: active tracks are a prefix
    starts, lengths = starts[order], lengths[order]
    ids = t.track[starts]
    out = np.zeros(n_tracks)
    alpha = np.tile(prior, (len(starts), 1))
    kernels: dict[int, np.ndarray] = {}
    for step in range(int(lengths.max())):
        active = int(np.sum(lengths > step))
        idx = starts[:active] + step
        a = alpha[:active]
        if step > 0:
            new = np.empty_like(a)
            gaps = t.gap[idx]
            for g in np.unique(gaps):
                sel = gaps == g
                if int(g) not in kernels:
                    kernels[int(g)] = _kernel(u, rho ** int(g))
                new[sel] = a[sel] @ kernels[int(g)]
            a = new
        mu = m[idx, None] + s_a * u[None, :]
        r = (y[idx, None] - mu) / s_e
        log_e = np.where(obs[idx, None], -0.5 * r * r - math.log(s_e) - 0.5 * math.log(2 * math.pi),
                         log_ndtr((c - mu) / s_e))  # fmt: skip
        top = log_e.max(axis=1, keepdims=True)
        a = a * np.exp(log_e - top)
        total = a.sum(axis=1)
        out[ids[:active]] += np.log(np.maximum(total, 1e-300)) + top[:, 0]
        alpha[:active] = a / np.maximum(total, 1e-300)[:, None]
    return out


@dataclass(frozen=True)
class FrameFit:
    """A fitted frame model: the logit's coefficients (``_LINEAR`` order), the size clamp
    and reference [px], and the noise (``noise_sigma``, AR share, rho per frame)."""

    beta: np.ndarray
    size_max: float
    size_ref: float
    sigma: float
    share: float
    rho: float

    def logit(self, t: Tracks) -> np.ndarray:
        """The PEM logit ``m`` of every frame of ``t``."""
        return _design_for(t, self.size_max, self.size_ref) @ self.beta

    def loglik(self, t: Tracks) -> float:
        """Sequence log-likelihood of ``t`` (every track)."""
        y, obs = _observed(t)
        return float(track_loglik(self.logit(t), y, obs, t, self.sigma, self.share, self.rho).sum())


def fit_tracks(t: Tracks, *, ridge: float, ar: bool, size_ref: float) -> FrameFit:
    """Steps 1 and 2 of the module docstring on ``t``."""
    from scipy.optimize import minimize

    y, obs = _observed(t)
    if int(np.sum(t.score >= FLOOR)) < 10:
        raise SitcovError(f"only {int(np.sum(t.score >= FLOOR))} frames detected at >= {FLOOR}")
    best: tuple[float, np.ndarray, float, np.ndarray] | None = None
    for size_max in SIZE_MAX_GRID:
        x = _design_for(t, size_max, size_ref)
        theta, value = _tobit(x, y, obs, ridge)
        if best is None or value < best[0]:
            best = (value, theta, size_max, x)
    assert best is not None
    _, theta, size_max, x = best
    beta, sigma0 = theta[:-1], math.exp(theta[-1])
    rest = x[:, 1:] @ beta[1:]

    def unpack(p: np.ndarray) -> tuple[float, float, float, float, float]:
        b0, kappa, sigma = p[0], p[1], math.exp(p[2])
        share = 1.0 / (1.0 + math.exp(-p[3])) if ar else 0.0
        rho = RHO_MAX / (1.0 + math.exp(-p[4])) if ar else 0.0
        return b0, kappa, sigma, share, rho

    def nll(p: np.ndarray) -> float:
        b0, kappa, sigma, share, rho = unpack(p)
        m = b0 + kappa * rest
        return -float(track_loglik(m, y, obs, t, sigma, share, rho).sum())

    start = np.array([beta[0], 1.0, math.log(sigma0), 1.0, 1.5])
    if not ar:
        start = start[:3]
    res = minimize(nll, start, method="L-BFGS-B", options={"maxiter": 200})
    b0, kappa, sigma, share, rho = unpack(np.r_[res.x, 0.0, 0.0] if not ar else res.x)
    coef = np.r_[b0, kappa * beta[1:]]
    return FrameFit(coef, size_max, size_ref, sigma, share, rho)


def _folds(groups: np.ndarray, k: int, seed: int = 0) -> list[np.ndarray]:
    """``k`` run-grouped folds of the runs (sweep frames, groups < 0, stay in training)."""
    runs = np.unique(groups[groups >= 0])
    perm = np.random.default_rng(seed).permutation(runs)
    return [perm[i::k] for i in range(k)]


def choose_model(
    t: Tracks,
    *,
    folds: int,
    size_ref: float,
    candidates: Sequence[tuple[str, float, bool]] = CANDIDATES,
) -> tuple[str, dict[str, Any]]:
    """The candidate with the best held-out sequence log-likelihood (per held-out frame),
    over run-grouped folds: each fold's runs are left out of the fit and scored."""
    table: dict[str, Any] = {}
    parts = _folds(t.group, folds)
    all_groups = np.unique(t.group)
    for name, ridge, ar in candidates:
        total, frames = 0.0, 0
        for held in parts:
            train = t.subset(np.setdiff1d(all_groups, held))
            test = t.subset(held)
            fit = fit_tracks(train, ridge=ridge, ar=ar, size_ref=size_ref)
            total += fit.loglik(test)
            frames += len(test.score)
        table[name] = {"heldout_loglik_per_frame": round(total / max(1, frames), 4),
                       "heldout_frames": frames}  # fmt: skip
    chosen = max(table, key=lambda k: table[k]["heldout_loglik_per_frame"])
    return chosen, table


def to_params(fit: FrameFit, base: PEMParams, t: Tracks, runs: Sequence[Any]) -> PEMParams:
    """The fit as PEM parameters (other fields from ``base``; jitter from the runs'
    matched boxes; ``size_min_px`` the 2nd percentile of the box heights reported)."""
    values = {name: round(float(v), 4) for name, v in zip(_LINEAR, fit.beta, strict=True)}
    heights = np.asarray([f.height_px for f in t.feats])
    seen = heights[t.score >= FLOOR]
    size_min = float(np.percentile(seen, 2)) if seen.size else base.size_min_px
    jitter = _jitter([f for r in runs for f in r.frames])
    tau = -FRAME_DT / math.log(fit.rho) if fit.share > 0.0 and fit.rho > 0.0 else 0.0
    return replace(
        base,
        **values,
        size_ref_px=round(fit.size_ref, 4),
        size_min_px=round(max(1.0, size_min), 2),
        size_max_px=fit.size_max,
        noise_sigma=round(fit.sigma, 4),
        noise_tau=round(tau, 4),
        noise_run_share=0.0,
        noise_frame_share=round(1.0 - fit.share, 4) if fit.share > 0.0 else 0.0,
        rain_sigma=0.0,
        rain_miss=0.0,
        rain_jitter=0.0,
        jitter=round(jitter, 4) if jitter is not None else base.jitter,
        floor=FLOOR,
    )


def fit_kind(
    data: KindFrames, base: PEMParams, *, folds: int = 5
) -> tuple[PEMParams, dict[str, Any]]:
    """Choose the model on held-out runs, refit it on every frame of the kind; the
    parameters and a summary (frames, tracks, the choice table, the fitted noise)."""
    t = tracks_of(data)
    size_ref = base.size_ref_px
    chosen, table = choose_model(t, folds=folds, size_ref=size_ref)
    _, ridge, ar = next(c for c in CANDIDATES if c[0] == chosen)
    fit = fit_tracks(t, ridge=ridge, ar=ar, size_ref=size_ref)
    params = to_params(fit, base, t, data.runs)
    lag1 = fit.share * fit.rho
    summary = {
        "frames": len(t.score),
        "sweep_frames": len(data.sweep),
        "runs": len(data.runs),
        "tracks": int(t.track.max()) + 1 if len(t.track) else 0,
        "detected_ge_floor": round(float(np.mean(t.score >= FLOOR)), 4),
        "model_choice": {"folds": folds, "chosen": chosen, "table": table},
        "rho_per_frame": round(fit.rho, 4),
        "ar_share": round(fit.share, 4),
        "lag1_autocorrelation_of_logit_noise": round(lag1, 4),
        "loglik_per_frame": round(fit.loglik(t) / max(1, len(t.score)), 4),
    }
    return params, summary


def fit_files(
    paths: Sequence[Any], *, folds: int = 5
) -> dict[str, tuple[PEMParams, dict[str, Any]]]:
    """:func:`fit_kind` for every kind in the frames files ``paths`` (merged per kind):
    kind -> (parameters, summary). Cars start from the shipped car parameters, the other
    kinds from the shipped per-class ones (their size reference [px] is kept)."""
    from sitcov.calibration._frames import read_frames
    from sitcov.perception._pem_classes import load_class_params
    from sitcov.perception._pem_params import load_pem_params

    merged: dict[str, KindFrames] = {}
    for path in paths:
        for kind, data in read_frames(path).items():
            into = merged.setdefault(kind, KindFrames())
            into.sweep.extend(data.sweep)
            into.runs.extend(data.runs)
    classes = load_class_params()
    out = {}
    for kind, data in merged.items():
        base = load_pem_params() if kind == "car" else classes[kind][1]
        out[kind] = fit_kind(data, base, folds=folds)
    return out


def frame_yaml(
    results: dict[str, tuple[PEMParams, dict[str, Any]]], command: str, seeds: Sequence[int],
    *, classes: bool,
) -> str:  # fmt: skip
    """The text of ``pem.yaml`` (cars, ``classes`` False) or ``pem_classes.yaml``
    (pedestrians and cyclists), headed by the command, with provenance in ``meta``."""
    import datetime

    import yaml

    from sitcov.calibration._frames import KIND_LABEL

    date = datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%d")
    meta: dict[str, Any] = {
        "source": "sitcov calibrate --frames-from (frame model, maximum likelihood)",
        "command": command,
        "date": date,
        "calibration_seeds": sorted(set(seeds)),
    }
    if classes:
        head = "# Per-class PEM parameters (pedestrians, cyclists): the frame model of\n"
        head += "# sitcov/calibration/_frame_model.py (docs/pem.md). Made by:\n"
        meta.update({k: s for k, (_, s) in results.items() if k != "car"})
        body = {k: {"label": KIND_LABEL[k], "params": p.to_dict()}
                for k, (p, _) in results.items() if k != "car"}  # fmt: skip
        doc = {"meta": meta, "classes": body}
    else:
        head = "# Perception error model (PEM) parameters: the frame model of\n"
        head += "# sitcov/calibration/_frame_model.py, documented in docs/pem.md. Made by:\n"
        params, summary = results["car"]
        meta["frames"] = summary["frames"]
        meta["car"] = summary
        doc = {"meta": meta, "params": params.to_dict()}
    return head + f"#   {command}\n" + yaml.safe_dump(doc, sort_keys=False)
