"""Calibrate the perception error model (PEM) against the renderer and the SSD detector.

``sweep`` renders frames with the OV at random distance, bearing and view angle, under clear
weather or one weather element at a time, runs the detector and records the score of the
detection matching the OV's projected box (IoU >= 0.3), next to the PEM's features of the
same geometry (:meth:`sitcov.perception.PEMSensor.features`).

``fit_pem`` fits the PEM's functional form (``sitcov.perception._pem``) by maximum
likelihood: the logit of the detector's score is modelled as ``z(features) + e`` with
``e ~ N(0, (noise_sigma + rain_sigma * rain_noise)^2)``. Scores below the calibration
detector's reporting threshold are censored (a Tobit likelihood), and a frame may be lost
outright with probability ``rain_miss * rain_noise``. ``size_ref_px`` is fixed (it is
collinear with ``bias``); ``size_max_px`` is chosen on a grid; ``size_min_px`` is the
smallest box height at which the detector still reports the car; ``floor`` is the
detector's reporting threshold; box jitter comes from the matched boxes' corner errors.
Frames rendered along re-simulated runs (:mod:`sitcov.perception._temporal`) join the fit,
so the geometries and weather combinations that campaigns meet are represented; their
residuals give the noise's correlation time ``noise_tau``. The between-run share of the
residual variance is treated as systematic (the detector is deterministic on a frame) and
removed from ``noise_sigma``, leaving ``noise_run_share`` at 0.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._camera import project_box
from sitcov.perception._nms import iou
from sitcov.perception._pem import PEMFeatures, PEMParams, PEMSensor
from sitcov.perception._renderer import render_frame
from sitcov.sim._conditions import WEATHER_ELEMENTS  # swept one at a time (CARLA units, 0..100)

#: Bin values a swept element takes.
WEATHER_VALUES = (20.0, 40.0, 60.0, 80.0, 100.0)
#: Fraction of frames in clear weather.
CLEAR_FRACTION = 0.35
#: Distance range [m] (log-uniform) and bearing half-range [deg] of the OV.
DISTANCE_RANGE = (4.0, 80.0)
BEARING_DEG = 45.0
#: Body colours the OV is drawn in (one per frame, at random).
PALETTE = ((150, 30, 35), (200, 200, 205), (30, 30, 35), (40, 70, 140), (120, 120, 125))
#: A detection matches the OV when its IoU with the projected box reaches this.
MATCH_IOU = 0.3
#: Detector threshold while calibrating (lower than in use, to see the censored tail).
SWEEP_MIN_SCORE = 0.05
#: Reporting threshold of the detector in use, which becomes the PEM's floor.
USE_FLOOR = 0.3
#: Re-simulated runs rendered along their trajectories for the noise's time correlation.
DEFAULT_RUNS = 24


@dataclass(frozen=True)
class Sample:
    """One calibration frame.

    Attributes:
        element, value: the weather element varied (``"clear"``) and its value.
        distance: camera to OV centre [m]. bearing: [rad], left positive.
        view: OV heading relative to the line of sight [rad] (0 rear, pi front).
        width_px: width of the OV's clipped box [px].
        features: the PEM's features (height, view angle, truncation, fog, light, rain).
        score: the matched detection's score, 0 if none.
        box_error: (dx0, dy0, dx1, dy1) of the matched box over the box size, or None.
    """

    element: str
    value: float
    distance: float
    bearing: float
    view: float
    width_px: float
    features: PEMFeatures
    score: float
    box_error: tuple[float, float, float, float] | None


def _ego_pose() -> tuple[Pose, Any]:
    from sitcov.sim.embedded._map import load_map

    jmap = load_map("t-junction")
    route = jmap.route("B", "L")
    x, y, h = route.point_at(0.0)
    return Pose(x, y, h), jmap.render_geometry()


def sweep(
    frames: int,
    detector: Callable[[np.ndarray], Sequence[Any]],
    *,
    seed: int = 0,
    camera: CameraSpec | None = None,
    progress: Callable[[int], None] | None = None,
) -> list[Sample]:
    """Render and detect ``frames`` random scenes; return one Sample per frame in view."""
    from sitcov.sim import conditions_from_values

    camera = camera or CameraSpec()
    rng = np.random.default_rng(seed)
    ego, geometry = _ego_pose()
    sensor = PEMSensor(camera=camera)
    cam_x = ego.x + camera.mount_x * math.cos(ego.yaw)
    cam_y = ego.y + camera.mount_x * math.sin(ego.yaw)
    from sitcov.sim.embedded._dynamics import default_params

    vp = default_params()
    out: list[Sample] = []
    for i in range(frames):
        lo, hi = math.log(DISTANCE_RANGE[0]), math.log(DISTANCE_RANGE[1])
        dist = math.exp(rng.uniform(lo, hi))
        bearing = math.radians(rng.uniform(-BEARING_DEG, BEARING_DEG))
        view = rng.uniform(-math.pi, math.pi)
        values: dict[str, float] = {e: 0.0 for e in WEATHER_ELEMENTS}
        values["friction"] = 1.0
        element, value = "clear", 0.0
        if rng.random() >= CLEAR_FRACTION:
            element = WEATHER_ELEMENTS[int(rng.integers(len(WEATHER_ELEMENTS)))]
            value = float(WEATHER_VALUES[int(rng.integers(len(WEATHER_VALUES)))])
            values[element] = value
            if element == "fog_distance":
                values["fog_density"] = 60.0  # fog_distance only matters with fog
        color = PALETTE[int(rng.integers(len(PALETTE)))]
        cond = conditions_from_values(values, wind_direction=float(rng.uniform(-math.pi, math.pi)))
        los = ego.yaw + bearing
        pose = Pose(cam_x + dist * math.cos(los), cam_y + dist * math.sin(los), los + view)
        actor = ActorView(pose, vp.length, vp.width, vp.height, 0.0)
        frame_rng = np.random.default_rng([seed, i])
        image = render_frame(camera, ego, (actor,), cond, geometry, frame_rng, body_colors=[color])
        if progress is not None:
            progress(i + 1)
        feats = sensor.features(ego, actor, cond)
        proj = project_box(camera, ego, actor)
        if feats is None or proj is None or not proj.visible:
            continue
        dets = detector(image)
        truth = np.asarray(proj.box, dtype=np.float64)
        score, err = 0.0, None
        if dets:
            boxes = np.asarray([d.box for d in dets], dtype=np.float64)
            overlaps = iou(truth, boxes)
            best = int(np.argmax(overlaps))
            if overlaps[best] >= MATCH_IOU:
                score = float(dets[best].score)
                bw, bh = max(proj.width, 1.0), max(proj.height, 1.0)
                d = boxes[best] - truth
                err = (d[0] / bw, d[1] / bh, d[2] / bw, d[3] / bh)
        out.append(Sample(element, value, dist, bearing, view, proj.width, feats, score, err))
    return out


def _design(features: Sequence[PEMFeatures], size_min: float, size_max: float, ref: float):
    f = np.asarray(features, dtype=np.float64)
    h = np.clip(f[:, 0], size_min, size_max)
    shape = np.where(
        (f[:, 6] > 0) & (f[:, 0] > 0),
        np.log(np.clip(f[:, 6] / np.maximum(f[:, 0], 1e-9), 0.25, 4.0)),
        0.0,
    )
    cols = [
        np.ones(len(f)),
        np.log(h / ref),
        -np.sin(f[:, 1]),
        -f[:, 2],
        np.log(np.maximum(f[:, 3], 1e-9)),
        np.log(np.maximum(f[:, 4], 1e-9)),
        -f[:, 5],
        shape,
        np.sin(2.0 * f[:, 1]),
        -f[:, 7],
    ]
    return np.stack(cols, axis=1), f[:, 5]


_LINEAR = (
    "bias",
    "size_gain",
    "view_gain",
    "trunc_gain",
    "fog_gain",
    "illum_gain",
    "rain_gain",
    "aspect_gain",
    "view2_gain",
    "edge_gain",
)


def _nll(theta: np.ndarray, x: np.ndarray, rain: np.ndarray, y: np.ndarray, cens: np.ndarray,
         cut: float) -> float:  # fmt: skip
    from scipy.special import log_ndtr

    beta = theta[: x.shape[1]]
    sig0, sig_r, miss = theta[x.shape[1] :]
    sigma = np.maximum(sig0 + sig_r * rain, 1e-3)
    m = np.clip(miss * rain, 0.0, 0.999)
    z = x @ beta
    ll_obs = (
        np.log1p(-m) - 0.5 * ((y - z) / sigma) ** 2 - np.log(sigma) - 0.5 * math.log(2 * math.pi)
    )
    p_cens = np.exp(log_ndtr((cut - z) / sigma))
    ll_cens = np.log(m + (1 - m) * p_cens + 1e-300)
    return float(-np.sum(np.where(cens, ll_cens, ll_obs)))


def fit_pem(
    samples: Sequence[Sample],
    *,
    tracks: Sequence[Any] = (),
    floor: float = USE_FLOOR,
    censor: float = SWEEP_MIN_SCORE,
    base: PEMParams | None = None,
) -> PEMParams:
    """Fit the PEM parameters to calibration samples (see the module docstring).

    ``tracks`` (:class:`sitcov.perception._temporal.TrackSample`, frames along re-simulated
    runs) join the static sweep in the score fit: they hold the geometries and weather
    combinations the campaigns actually meet. Box jitter comes from the sweep only.
    """
    from scipy.optimize import minimize

    base = base or PEMParams()
    usable = [s for s in samples if s.features.height_px >= 1.0]
    pairs = [(s.features, s.score) for s in usable]
    pairs += [(t.features, t.score) for t in tracks if t.features.height_px >= 1.0]
    if len(pairs) < 20:
        from sitcov.errors import SitcovError

        raise SitcovError(f"too few calibration frames with the OV in view ({len(pairs)})")
    feats = [f for f, _ in pairs]
    scores = np.asarray([sc for _, sc in pairs])
    cut = math.log(censor / (1 - censor))
    cens = scores < censor
    y = np.log(np.clip(scores, 1e-4, 1 - 1e-4) / (1 - np.clip(scores, 1e-4, 1 - 1e-4)))
    heights = np.asarray([f.height_px for f in feats])
    seen = heights[scores >= floor]
    size_min = float(np.percentile(seen, 2)) if seen.size else base.size_min_px
    best: tuple[float, np.ndarray, float] | None = None
    for size_max in (60.0, 100.0, 150.0, 200.0, 300.0, 450.0):
        x, rain = _design(feats, 1.0, size_max, base.size_ref_px)
        theta0 = np.concatenate([np.zeros(x.shape[1]), [0.8, 0.5, 0.1]])
        bounds = [(None, None)] * x.shape[1] + [(0.05, 5.0), (0.0, 5.0), (0.0, 1.0)]
        res = minimize(_nll, theta0, args=(x, rain, y, cens, cut), method="L-BFGS-B",
                       bounds=bounds)  # fmt: skip
        if best is None or res.fun < best[0]:
            best = (float(res.fun), res.x, size_max)
    assert best is not None
    _, theta, size_max = best
    fitted = dict(zip(_LINEAR, (float(v) for v in theta[: len(_LINEAR)]), strict=True))
    errs = np.asarray([s.box_error for s in usable if s.box_error is not None])
    rains = np.asarray([s.features.rain_noise for s in usable if s.box_error is not None])
    jitter, rain_jitter = base.jitter, base.rain_jitter
    if len(errs) >= 10:
        mag = np.abs(errs).mean(axis=1) * math.sqrt(math.pi / 2)  # mean |N(0,s)| -> s
        clear = rains < 0.05
        jitter = float(np.median(mag[clear])) if clear.any() else float(np.median(mag))
        if (rains > 0.05).sum() >= 5:
            slope = np.polyfit(rains, mag, 1)[0]
            rain_jitter = float(max(0.0, slope))
    return PEMParams(
        **{k: round(v, 4) for k, v in fitted.items()},
        size_ref_px=base.size_ref_px,
        size_min_px=round(max(1.0, size_min), 2),
        size_max_px=size_max,
        noise_sigma=round(float(theta[-3]), 4),
        rain_sigma=round(float(theta[-2]), 4),
        rain_miss=round(float(theta[-1]), 4),
        jitter=round(jitter, 4),
        rain_jitter=round(rain_jitter, 4),
        floor=floor,
    )


def _view_class(view: float) -> str:
    a = abs(math.remainder(view, math.tau))
    if a < math.radians(30):
        return "rear"
    if a > math.radians(150):
        return "front"
    if math.radians(60) < a < math.radians(120):
        return "side"
    return "oblique"


def summarize_samples(samples: Sequence[Sample], floor: float = USE_FLOOR) -> dict[str, Any]:
    """Detection rates used by the checks: clear frames with a box >= 10% of the image width,
    per view (at the reporting floor and at the AEB's 0.5), and per weather element/value."""
    out: dict[str, Any] = {"frames": len(samples)}
    big = [s for s in samples if s.element == "clear" and s.width_px >= 80.0]
    views: dict[str, Any] = {}
    for name in ("rear", "front", "side", "oblique"):
        sel = [s for s in big if _view_class(s.view) == name]
        if sel:
            views[name] = {
                "n": len(sel),
                "rate_floor": round(sum(s.score >= floor for s in sel) / len(sel), 3),
                "rate_0.5": round(sum(s.score >= 0.5 for s in sel) / len(sel), 3),
                "mean_score": round(float(np.mean([s.score for s in sel])), 3),
            }
    out["clear_box_ge_10pct"] = views
    weather: dict[str, Any] = {}
    near = [s for s in samples if s.width_px >= 40.0]
    for el in ("clear", *WEATHER_ELEMENTS):
        for val in sorted({s.value for s in near if s.element == el}):
            sel = [s for s in near if s.element == el and s.value == val]
            weather[f"{el}={val:g}"] = {
                "n": len(sel),
                "rate_floor": round(sum(s.score >= floor for s in sel) / len(sel), 3),
            }
    out["box_ge_5pct_by_weather"] = weather
    return out


def calibrate(
    frames: int = 1500,
    *,
    runs: int = DEFAULT_RUNS,
    seed: int = 0,
    model: str | None = None,
    progress: Callable[[int], None] | None = None,
) -> tuple[PEMParams, dict[str, Any], list[Sample]]:
    """Sweep with the SSD detector and fit the PEM; returns (params, summary, samples).

    ``frames`` random static scenes and the frames of ``runs`` re-simulated runs rendered
    along their trajectories fit the score model (:func:`fit_pem`); the runs' residuals
    then fit the noise's correlation in time (:func:`sitcov.perception._temporal.fit_temporal`).
    The share of the residual variance that is constant over a run is not kept as noise
    (``noise_run_share`` = 0, ``noise_sigma`` scaled by ``sqrt(1 - share)``): the detector
    is deterministic, so that share is systematic error of the features; it is recorded
    in the summary's ``temporal.between_run_share``. ``progress`` receives the
    number of steps done out of ``frames + runs``.
    """
    from sitcov.perception._detector import SSDDetector
    from sitcov.perception._temporal import fit_temporal, trajectory_sweep

    detector = SSDDetector(model, min_score=SWEEP_MIN_SCORE)
    samples = sweep(frames, detector, seed=seed, progress=progress)
    summary = summarize_samples(samples)
    if runs <= 0:
        return fit_pem(samples), summary, samples
    tracks = trajectory_sweep(
        runs,
        detector,
        seed=seed,
        match_iou=MATCH_IOU,
        progress=None if progress is None else (lambda r: progress(frames + r)),
    )
    params = fit_pem(samples, tracks=tracks)
    share, tau, stats = fit_temporal(tracks, params, SWEEP_MIN_SCORE)
    # The detector is deterministic on a frame: a residual offset that persists over a
    # run is geometry or weather the features do not explain, not chance. Only the
    # within-run part of the residual variance becomes random noise.
    stats["between_run_share"] = share
    params = replace(
        params,
        noise_sigma=round(params.noise_sigma * math.sqrt(1.0 - share), 4),
        noise_run_share=0.0,
        noise_tau=round(tau, 3),
    )
    summary["temporal"] = stats
    return params, summary, samples


def pem_yaml(params: PEMParams, command: str, summary: dict[str, Any]) -> str:
    """The text of a ``pem.yaml`` holding ``params``, headed by the command that made it."""
    import yaml

    head = (
        "# Perception error model (PEM) parameters: the coefficients of the logistic score model\n"
        "# in sitcov/perception/_pem.py, documented in docs/pem.md.\n"
        "# Fitted against the SSD-MobileNetV2 (OIDv4) detector on rendered frames by:\n"
        f"#   {command}\n"
    )
    views = summary.get("clear_box_ge_10pct", {})
    meta = {
        "source": "sitcov calibrate",
        "command": command,
        "frames": summary.get("frames"),
        "clear_detection_rate_box_ge_10pct": {k: v["rate_floor"] for k, v in views.items()},
    }
    if "temporal" in summary:
        meta["temporal"] = summary["temporal"]
    body = yaml.safe_dump({"meta": meta, "params": asdict(params)}, sort_keys=False)
    return head + body
