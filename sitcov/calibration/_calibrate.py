"""Calibrate the perception error model (PEM) against the renderer and the SSD detector.

Two kinds of frames go through the renderer and the detector:

- ``sweep``: static scenes with the OV at random distance (4-80 m), bearing and heading,
  under clear weather or one weather element at a time. They cover every size and
  weather value, and give the detection-rate checks.
- :func:`sitcov.calibration._camera_runs.camera_runs`: camera-mode runs of the reference
  stack through random situations, recorded frame by frame. They hold the geometries and
  weather combinations campaigns meet, in the frames where the AEB decides, and each
  run's verdict.

``fit_pem`` fits the PEM at the decision threshold, on the runs' frames and the sweep's frames
with boxes narrower than any the runs rendered: a probit model of the event "the
detector reports the OV with a score >= threshold" (0.5, the reference AEB's) gives the
logit's shape ``z / noise_sigma``; ``noise_sigma`` then sets how scores spread around the
threshold, fitted to how often they fall below the reporting floor (0.3) and above 0.95
(fault f1). The probability that a frame passes the AEB's score test is thus matched
directly, not inferred from a normal law of the score, whose tails the detector does not
follow. Box jitter comes from the matched boxes' horizontal errors in frames where the
box is at least 60 px wide. ``choose_noise`` picks the noise's correlation time, scales
the noise down and shifts the intercept, jointly, by agreement of PEM-mode verdicts with
the camera-mode verdicts of the same situations (the PEM under run seeds of its own).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace
from typing import Any

import numpy as np

from sitcov.calibration._camera_runs import CameraRun, match
from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._camera import project_box
from sitcov.perception._colors import PALETTE as COLOR_PALETTE
from sitcov.perception._pem import COEFFICIENTS, CUT_TENT_PX, PEMFeatures, PEMParams, PEMSensor
from sitcov.perception._renderer import render_frame
from sitcov.weather._conditions import WEATHER_ELEMENTS  # swept one at a time (CARLA units, 0..100)

#: Bin values a swept element takes.
WEATHER_VALUES = (20.0, 40.0, 60.0, 80.0, 100.0)
#: Fraction of frames in clear weather.
CLEAR_FRACTION = 0.35
#: Distance range [m] (log-uniform) and bearing half-range [deg] of the OV.
DISTANCE_RANGE = (4.0, 80.0)
BEARING_DEG = 45.0
#: Body colours the OV is drawn in (one per frame, uniformly: every palette colour is
#: covered, the rare ones too; the camera runs meet them by their real-world shares).
PALETTE = tuple(rgb for rgb, _ in COLOR_PALETTE.values())
#: Detector threshold while calibrating (lower than in use, to see the censored tail).
SWEEP_MIN_SCORE = 0.05
#: Reporting threshold of the detector in use, which becomes the PEM's floor.
USE_FLOOR = 0.3
#: Camera-mode runs recorded for the fit and the choice of the noise's correlation time.
DEFAULT_RUNS = 200
#: The reference AEB's score threshold: the event the PEM is fitted to reproduce.
THRESHOLD = 0.5
#: Score cut-offs whose frequencies fit the noise scale (reporting floor, fault f1).
SIGMA_CUTS = (USE_FLOOR, THRESHOLD, 0.95)
#: Correlation times [s] tried for the PEM's noise by :func:`choose_tau`.
TAU_GRID = (0.0, 0.1, 0.2, 0.4, 0.8)
#: Correlation times [s], noise scales [-] and intercept shifts [logit] tried together by
#: :func:`choose_noise` (longer times lost 6-9 points of agreement in every earlier fit,
#: 0.1 s never beat independent frames by more than one run in 300; a scale shrinks
#: ``noise_sigma``, largest first so that ties keep the fitted noise).
NOISE_TAUS = (0.0,)
NOISE_SCALES = (1.0, 0.5, 0.25)
BIAS_SHIFTS = (0.0, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4)
#: Boxes at least this wide [px] give the box jitter.
JITTER_MIN_WIDTH = 60.0


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
    color: tuple[int, int, int] | None = None


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
    from sitcov.weather import conditions_from_values

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
        actor = ActorView(pose, vp.length, vp.width, vp.height, 0.0, color)
        frame_rng = np.random.default_rng([seed, i])
        image = render_frame(camera, ego, (actor,), cond, geometry, frame_rng)
        if progress is not None:
            progress(i + 1)
        feats = sensor.features(ego, actor, cond)
        proj = project_box(camera, ego, actor)
        if feats is None or proj is None or not proj.visible:
            continue
        score, err = match(proj.box, detector(image))
        out.append(
            Sample(element, value, dist, bearing, view, proj.width, feats, score, err, color)
        )
    return out


def _design(features: Sequence[PEMFeatures], size_min: float, size_max: float, ref: float):
    """Columns of the PEM's logit, in the order of ``_LINEAR`` (see ``_pem._logit``)."""
    f = np.asarray(features, dtype=np.float64)
    size = np.log(np.clip(f[:, 0], size_min, size_max) / ref)
    side = np.sin(f[:, 1])
    shape = np.where(
        (f[:, 6] > 0) & (f[:, 0] > 0),
        np.log(np.clip(f[:, 6] / np.maximum(f[:, 0], 1e-9), 0.25, 4.0)),
        0.0,
    )
    facing = f[:, 8]
    cols = [
        np.ones(len(f)),
        size,
        size * size,
        side * size,
        -side,
        np.sin(2.0 * f[:, 1]),
        facing,
        2.0 * facing * facing - 1.0,
        -f[:, 2],
        np.log(np.maximum(f[:, 3], 1e-9)),
        np.log(np.maximum(f[:, 4], 1e-9)),
        -f[:, 5],
        shape,
        -f[:, 7],
        f[:, 9],
        f[:, 10],
        f[:, 11],
        f[:, 12],
        f[:, 13],
    ]
    return np.stack(cols, axis=1)


#: The frame model's extra terms (:data:`sitcov.calibration._frame_model.EXTRA_TERMS`) that
#: have a PEM parameter, and that parameter: the cube of the log size, the size term's
#: bends at 40 and 80 px, the side-on bend at 40 px, the step of a box cut by the image
#: edge and that step's tent at 220 px (``CUT_TENT_PX``), the close car seen head-on
#: from the front (``head_on``).
EXTRA_TERM_PARAMS = {
    "size3": "size3_gain",
    "hinge40": "size_hinge40_gain",
    "hinge80": "size_hinge80_gain",
    "view_hinge40": "view_hinge40_gain",
    "cut": "cut_gain",
    f"cut_tent{CUT_TENT_PX:.0f}": "cut_tent_gain",
    "head_on": "head_on_gain",
}
#: The gains of the frame model's candidate terms (:mod:`sitcov.calibration._frame_model`):
#: the side's and the extra terms'.
_CANDIDATE_GAINS = ("side_gain", *EXTRA_TERM_PARAMS.values())
#: The coefficients the probit fit estimates: the logit's (``COEFFICIENTS``) but the size
#: normalisation and clamps in pixels, which the fit keeps as given, and the candidate
#: terms' gains.
_LINEAR = tuple(
    name for name in COEFFICIENTS if not name.endswith("_px") and name not in _CANDIDATE_GAINS
)
#: Ridge penalty on the probit coefficients (not the intercept).
_RIDGE = 1.0


def _probit(x: np.ndarray, event: np.ndarray, ridge: float = _RIDGE) -> tuple[np.ndarray, float]:
    """Ridge-penalised probit fit of ``P(event) = Phi(x @ g)``: (g, penalised NLL).

    ``ridge`` multiplies the sum of the squared coefficients (the intercept is free).
    """
    from scipy.optimize import minimize
    from scipy.special import log_ndtr, ndtr

    def nll(g: np.ndarray) -> tuple[float, np.ndarray]:
        z = x @ g
        lp, lq = log_ndtr(z), log_ndtr(-z)
        value = -float(np.sum(np.where(event, lp, lq))) + ridge * float(np.sum(g[1:] ** 2))
        pdf = np.exp(-0.5 * z * z) / np.sqrt(2.0 * np.pi)
        p = np.clip(ndtr(z), 1e-12, 1 - 1e-12)
        dz = np.where(event, -pdf / p, pdf / (1.0 - p))
        grad = x.T @ dz + 2.0 * ridge * np.r_[0.0, g[1:]]
        return value, grad

    res = minimize(nll, np.zeros(x.shape[1]), jac=True, method="L-BFGS-B")
    return res.x, float(res.fun)


def _fit_sigma(zg: np.ndarray, scores: np.ndarray, threshold: float) -> float:
    """Noise scale s of ``logit(score) = s * zg + logit(threshold) + s * N(0, 1)``.

    Fitted to the frequencies of the score intervals cut at ``SIGMA_CUTS``; any s keeps
    ``P(score >= threshold) = Phi(zg)``.
    """
    from scipy.optimize import minimize_scalar
    from scipy.special import ndtr

    cuts = np.asarray(SIGMA_CUTS)
    edges = np.r_[-np.inf, np.log(cuts / (1 - cuts)) - math.log(threshold / (1 - threshold)),
                  np.inf]  # fmt: skip
    idx = np.searchsorted(cuts, scores, side="right")
    lo, hi = edges[idx], edges[idx + 1]

    def nll(s: float) -> float:
        p = ndtr(hi / s - zg) - ndtr(lo / s - zg)
        return -float(np.sum(np.log(np.maximum(p, 1e-300))))

    return float(minimize_scalar(nll, bounds=(0.05, 5.0), method="bounded").x)


def _jitter(frames: Sequence[Any]) -> float | None:
    """Box-corner noise over the box width, from the horizontal errors of matched boxes."""
    usable = [
        f.box_error
        for f in frames
        if f.box_error is not None and f.width_px >= JITTER_MIN_WIDTH
        and f.features.truncation < 0.05
    ]  # fmt: skip
    errs = [abs(e) for err in usable for e in (err[0], err[2])]
    if len(errs) < 20:
        return None
    return float(np.median(errs)) / 0.6745  # median |N(0, s)| = 0.6745 s


def fit_pem(
    samples: Sequence[Sample],
    *,
    runs: Sequence[CameraRun] = (),
    threshold: float = THRESHOLD,
    floor: float = USE_FLOOR,
    base: PEMParams | None = None,
    ridge: float = _RIDGE,
    drop: Sequence[str] = (),
) -> PEMParams:
    """Fit the PEM parameters to sweep samples and recorded camera runs (module docstring).

    With ``runs``, sweep samples count only below the narrowest box the runs rendered: above
    it the runs' frames are the ones campaigns meet (the sweep's colours, poses and
    one-element weather are not). The correlation time is not fitted here (``noise_tau``
    = 0): see :func:`choose_noise`. ``ridge``: the probit's L2 penalty; ``drop``: names
    of ``_LINEAR`` coefficients left out of the fit (their gains are 0).
    """
    unknown = sorted(set(drop) - set(_LINEAR[1:]))
    if unknown:
        raise ValueError(f"drop: unknown or undroppable coefficients {unknown}")
    keep = [i for i, name in enumerate(_LINEAR) if name not in drop]
    base = base or PEMParams()
    run_frames = [f for run in runs for f in run.frames if f.features.height_px >= 1.0]
    # Where camera runs render frames (boxes at least as wide as the frame gate) they are
    # the frames campaigns meet; the static sweep fills in only the narrower boxes.
    narrowest = min((f.width_px for f in run_frames), default=math.inf)
    frames: list[Any] = [
        s for s in samples if s.features.height_px >= 1.0 and s.width_px < narrowest
    ]
    frames += run_frames
    if len(frames) < 20:
        from sitcov.errors import SitcovError

        raise SitcovError(f"too few calibration frames with the OV in view ({len(frames)})")
    feats = [f.features for f in frames]
    scores = np.asarray([f.score for f in frames])
    event = scores >= threshold
    heights = np.asarray([f.height_px for f in feats])
    seen = heights[scores >= floor]
    size_min = float(np.percentile(seen, 2)) if seen.size else base.size_min_px
    best: tuple[float, np.ndarray, float, np.ndarray] | None = None
    for size_max in (60.0, 100.0, 150.0, 200.0, 300.0, 450.0):
        x = _design(feats, 1.0, size_max, base.size_ref_px)
        g_kept, value = _probit(x[:, keep], event, ridge)
        g = np.zeros(x.shape[1])
        g[keep] = g_kept
        if best is None or value < best[0]:
            best = (value, g, size_max, x)
    assert best is not None
    _, g, size_max, x = best
    sigma = _fit_sigma(x @ g, scores, threshold)
    fitted = {name: sigma * float(v) for name, v in zip(_LINEAR, g, strict=True)}
    fitted["bias"] += math.log(threshold / (1 - threshold))
    jitter = _jitter(frames)
    return PEMParams(
        **{k: round(v, 4) for k, v in fitted.items()},
        size_ref_px=base.size_ref_px,
        size_min_px=round(max(1.0, size_min), 2),
        size_max_px=size_max,
        noise_sigma=round(sigma, 4),
        rain_sigma=0.0,
        rain_miss=0.0,
        jitter=round(jitter if jitter is not None else base.jitter, 4),
        rain_jitter=0.0,
        floor=floor,
        noise_tau=0.0,
    )


def cross_seed(run: CameraRun) -> int:
    """A run seed of its own for a PEM run of ``run``'s situation (not the camera run's).

    Drawn from a separate seed-sequence stream of the camera run's seed, so the PEM's noise,
    the wind and the OV's colour are independent of the camera run's, as they are in the
    agreement experiment's ``pem-camera`` pair.
    """
    return int(np.random.SeedSequence([3, run.seed]).generate_state(1, dtype=np.uint32)[0])


def pem_agreement(
    params: PEMParams, runs: Sequence[CameraRun], *, cross: bool = False
) -> tuple[float, float]:
    """(agreement with the camera verdicts, PEM failure rate) on the same situations.

    The PEM runs with the camera run's seed, or with ``cross``, with :func:`cross_seed`.
    """
    from sitcov.av import ReferenceStack
    from sitcov.hyperspace import Situation
    from sitcov.perception._pem import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    backend = EmbeddedBackend(perception="pem", sensor=PEMSensor(params))
    stack = ReferenceStack()
    agree = fails = 0
    for run in runs:
        seed = cross_seed(run) if cross else run.seed
        failed = backend.run(Situation.from_dict(run.situation), stack, seed).failed
        agree += failed == run.failed
        fails += failed
    n = max(1, len(runs))
    return agree / n, fails / n


def choose_tau(params: PEMParams, runs: Sequence[CameraRun]) -> tuple[float, dict[str, Any]]:
    """The noise correlation time in ``TAU_GRID`` whose PEM verdicts agree best with ``runs``
    (PEM and camera on the same run seeds).

    Ties go to the shorter time. Returns it and the agreement of every candidate.
    """
    table: dict[str, Any] = {}
    best_tau, best = 0.0, -1.0
    for tau in TAU_GRID:
        agree, fail_rate = pem_agreement(replace(params, noise_tau=tau), runs)
        table[f"{tau:g}"] = {"agreement": round(agree, 3), "failure_rate": round(fail_rate, 3)}
        if agree > best + 1e-12:
            best_tau, best = tau, agree
    return best_tau, table


def choose_noise(
    params: PEMParams,
    runs: Sequence[CameraRun],
    *,
    taus: Sequence[float] = NOISE_TAUS,
    scales: Sequence[float] = NOISE_SCALES,
    shifts: Sequence[float] = BIAS_SHIFTS,
) -> tuple[PEMParams, dict[str, Any]]:
    """Correlation time, noise scale and intercept chosen jointly on the runs' verdicts.

    The frame-level fit (:func:`fit_pem`) matches how often a frame passes θ = 0.5, but a
    run's verdict hangs on the first frame that passes, and the frames a camera run
    records are those before its AEB fired: cars the detector finds early leave no late
    frames, so late frames are fitted on the hard cars and a PEM, which forgets that
    selection, can fire too seldom (the previous fit failed 41 % of its 600 calibration
    runs where the camera failed 36 %). The fit also treats frames as independent, so
    everything its features do not explain becomes noise, drawn afresh each frame; the
    detector, though, is a deterministic function of the image, whose score drifts
    smoothly from frame to frame (lag-1 correlation of the logit 0.82 in the runs): its
    misfit repeats, it does not average out over a run's frames. A PEM carrying the full
    misfit as fresh noise reaches a different verdict in one situation run to run far
    more often than the camera does. A ``scale`` < 1 multiplies ``noise_sigma`` (the
    frame's probability of passing becomes ``Phi(x g / scale)``), and the shift moves the
    intercept to keep the PEM firing as readily. Each (``noise_tau``, scale, shift)
    candidate drives the reference stack through the runs' situations under a run seed
    of its own (:func:`cross_seed`, as the agreement experiment's ``pem-camera`` pair
    does); :func:`pick_noise` keeps, among the candidates within one standard error of
    the best agreement, the one whose failure rate is closest to the camera's. Returns
    the chosen parameters and every candidate's agreement and failure rate, keyed
    ``"tau=.. scale=.. shift=.."``.
    """
    table: dict[str, Any] = {}
    candidates: list[tuple[str, PEMParams]] = []
    for tau in taus:
        for scale in scales:
            for shift in shifts:
                cand = replace(
                    params,
                    noise_tau=tau,
                    noise_sigma=round(params.noise_sigma * scale, 4),
                    bias=round(params.bias + shift, 4),
                )
                agree, rate = pem_agreement(cand, runs, cross=True)
                key = noise_key(tau, scale, shift)
                table[key] = {"agreement": round(agree, 3), "failure_rate": round(rate, 3)}
                candidates.append((key, cand))
    camera_rate = sum(r.failed for r in runs) / max(1, len(runs))
    chosen = pick_noise(table, camera_rate, len(runs))
    return dict(candidates)[chosen], table


def pick_noise(table: dict[str, Any], camera_rate: float, runs: int) -> str:
    """The :func:`choose_noise` candidate to keep: within one standard error of the best
    agreement, the one whose failure rate is closest to the camera's.

    Candidates whose agreements differ by less than the sampling error of one agreement
    (``sqrt(a (1 - a) / runs)``, 1.9 points at 88 % over 300 runs) are not told apart by
    the runs; among them the failure rate, which the runs do measure, decides. Ties keep
    the first in the table's order (shorter time, larger scale, smaller shift).
    """
    best = max(row["agreement"] for row in table.values())
    band = best - math.sqrt(best * (1.0 - best) / max(1, runs)) - 1e-9
    near = [k for k, row in table.items() if row["agreement"] >= band]
    return min(near, key=lambda k: abs(table[k]["failure_rate"] - camera_rate))


def noise_key(tau: float, scale: float, shift: float) -> str:
    """The key of one :func:`choose_noise` candidate in its table."""
    return f"tau={tau:g} scale={scale:g} shift={shift:g}"


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
    names = {rgb: name for name, (rgb, _) in COLOR_PALETTE.items()}
    by_color: dict[str, Any] = {}
    for rgb, name in names.items():
        sel = [s for s in big if s.color == rgb]
        if sel:
            by_color[name] = {
                "n": len(sel),
                "rate_floor": round(sum(s.score >= floor for s in sel) / len(sel), 3),
                "rate_0.5": round(sum(s.score >= 0.5 for s in sel) / len(sel), 3),
            }
    out["clear_box_ge_10pct_by_color"] = by_color
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
        # Run seeds of the sweep and the camera runs: evaluations must use other seeds.
        "calibration_seeds": [summary["seed"]] if "seed" in summary else [],
        "clear_detection_rate_box_ge_10pct": {k: v["rate_floor"] for k, v in views.items()},
        "clear_detection_rate_box_ge_10pct_by_color": {
            k: v["rate_floor"] for k, v in summary.get("clear_box_ge_10pct_by_color", {}).items()
        },
    }
    if "camera_runs" in summary:
        meta["camera_runs"] = summary["camera_runs"]
    body = yaml.safe_dump({"meta": meta, "params": asdict(params)}, sort_keys=False)
    return head + body
