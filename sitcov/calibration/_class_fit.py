"""Per-class PEM calibration: the static-frame sweep of one road-user kind and the fit.

The sweep: random frames of one actor of the kind (distance log-uniform 4-40 m, bearing
within +-40 deg, any heading, a random shirt colour and height; clear weather in 35 % of
frames, otherwise one weather element at a random level) are rendered and run through the
SSD; the score of the best detection of an accepted class (pedestrian: person; cyclist:
bicycle or person) overlapping the true box (IoU >= 0.3) is the frame's outcome. The
score's logit is ``z(features) + noise_sigma * N(0, 1)``; the fit works at the decision
threshold, as the car PEM's does: a probit model of "score >= 0.5" (the reference AEB's
threshold) gives ``z / noise_sigma``, then ``noise_sigma`` is the maximum-likelihood scale
for the event "score >= 0.3" (the reporting floor) given that shape. ``size_min_px`` is the
1st percentile of the box heights detected at >= 0.3.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from sitcov.errors import SitcovError
from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._pem import PEMFeatures, PEMParams

#: Kind -> (length, width, heights, speed) of the calibration frames [m, m, m, m/s].
SHAPES = {
    "pedestrian": (0.5, 0.5, (1.55, 1.65, 1.75, 1.85), 1.4),
    "cyclist": (1.8, 0.6, (1.6, 1.7, 1.8), 5.0),
}
DISTANCE_RANGE = (4.0, 40.0)
BEARING_DEG = 40.0
CLEAR_FRACTION = 0.35
WEATHER_VALUES = (20.0, 40.0, 60.0, 80.0, 100.0)
SWEEP_MIN_SCORE = 0.05
USE_FLOOR = 0.3
#: The reference AEB's score threshold: the event the fit reproduces first.
THRESHOLD = 0.5
#: Fitted coefficients: design column -> (parameter, sign).
_COLUMNS = (
    ("bias", 1.0), ("size_gain", 1.0), ("size2_gain", 1.0), ("view_gain", -1.0),
    ("view2_gain", 1.0), ("facing_gain", 1.0), ("facing2_gain", 1.0), ("trunc_gain", -1.0),
    ("fog_gain", 1.0), ("illum_gain", 1.0), ("rain_gain", -1.0), ("edge_gain", -1.0),
)  # fmt: skip


def _frame(kind: str, rng: np.random.Generator, ego: Pose, camera: CameraSpec):
    """One random actor of ``kind`` and weather values (see the module doc)."""
    from sitcov.perception._person import SHIRTS
    from sitcov.weather._conditions import WEATHER_ELEMENTS

    length, width, heights, speed = SHAPES[kind]
    lo, hi = (math.log(d) for d in DISTANCE_RANGE)
    dist = math.exp(rng.uniform(lo, hi))
    los = ego.yaw + math.radians(rng.uniform(-BEARING_DEG, BEARING_DEG))
    cx = ego.x + camera.mount_x * math.cos(ego.yaw)
    cy = ego.y + camera.mount_x * math.sin(ego.yaw)
    pose = Pose(
        cx + dist * math.cos(los), cy + dist * math.sin(los), rng.uniform(-math.pi, math.pi)
    )
    shirt = SHIRTS[int(rng.integers(len(SHIRTS)))]
    height = float(heights[int(rng.integers(len(heights)))])
    values: dict[str, float] = {}
    if rng.random() >= CLEAR_FRACTION:
        element = WEATHER_ELEMENTS[int(rng.integers(len(WEATHER_ELEMENTS)))]
        values[element] = float(WEATHER_VALUES[int(rng.integers(len(WEATHER_VALUES)))])
        if element == "fog_distance":
            values["fog_density"] = 60.0
    return ActorView(pose, length, width, height, speed, shirt, kind), values


def class_sweep(
    kind: str,
    frames: int,
    detector: Callable[[np.ndarray], Sequence[Any]],
    *,
    seed: int = 0,
    camera: CameraSpec | None = None,
) -> list[tuple[PEMFeatures, float]]:
    """(PEM features, matched score or 0) of ``frames`` random frames of ``kind`` in view
    (the score as recorded runs take it: :func:`sitcov.calibration._camera_runs.match`)."""
    from sitcov.calibration._camera_runs import match
    from sitcov.perception._camera import project_box
    from sitcov.perception._detector import PART_KIND, PEM_LABELS
    from sitcov.perception._pem import PEMSensor
    from sitcov.perception._renderer import render_frame
    from sitcov.sim.embedded._map import load_map
    from sitcov.weather import conditions_from_values

    camera = camera or CameraSpec()
    jmap = load_map("t-junction")
    x, y, h = jmap.route("B", "L").point_at(0.0)
    ego, geometry = Pose(x, y, h), jmap.render_geometry()
    sensor = PEMSensor(camera=camera)
    rng = np.random.default_rng([seed, len(kind)])
    out = []
    for i in range(frames):
        actor, values = _frame(PART_KIND.get(kind, kind), rng, ego, camera)  # a road user
        cond = conditions_from_values(values)
        feats = sensor.features(ego, actor, cond)
        if feats is None:
            continue
        img = render_frame(camera, ego, (actor,), cond, geometry, np.random.default_rng([seed, i]))
        dets = [d for d in detector(img) if d.label in PEM_LABELS[kind]]
        score, _ = match(project_box(camera, ego, actor).box, dets)
        out.append((feats, score))
    return out


def _design(feats: Sequence[PEMFeatures], ref: float, lo: float, hi: float) -> np.ndarray:
    rows = []
    for f in feats:
        size = math.log(min(max(f.height_px, lo), hi) / ref)
        side = math.sin(f.view_angle)
        rows.append((
            1.0, size, size * size, side, math.sin(2 * f.view_angle), f.facing,
            2 * f.facing**2 - 1, f.truncation, math.log(max(f.transmittance, 1e-6)),
            math.log(max(f.illumination, 1e-6)), f.rain_noise, f.offset,
        ))  # fmt: skip
    return np.asarray(rows, dtype=np.float64)


def _probit(x: np.ndarray, event: np.ndarray) -> np.ndarray:
    """Probit coefficients of ``event`` on ``x`` (P = Phi(x @ g)), by maximum likelihood
    with a tiny ridge on the non-constant terms."""
    from scipy.optimize import minimize
    from scipy.stats import norm

    sign = np.where(event, 1.0, -1.0)

    def nll(g: np.ndarray) -> tuple[float, np.ndarray]:
        m = sign * (x @ g)
        ll = norm.logcdf(m)
        ratio = np.exp(norm.logpdf(m) - ll)  # d log Phi(m) / dm
        ridge = 1e-3 * float(g[1:] @ g[1:])
        grad = -(x.T @ (sign * ratio)) + 2e-3 * np.concatenate(([0.0], g[1:]))
        return -float(ll.sum()) + ridge, grad

    return minimize(nll, np.zeros(x.shape[1]), jac=True, method="L-BFGS-B").x


def fit_class(samples: Sequence[tuple[PEMFeatures, float]], base: PEMParams) -> PEMParams:
    """Fit the PEM at the decision threshold (module doc); other fields from ``base``.

    A probit of "score >= THRESHOLD" gives ``z / noise_sigma``; ``noise_sigma`` then makes
    "score >= floor" as frequent as the detector's reports (1-D maximum likelihood), so the
    PEM reproduces both the AEB's event and the reporting rate.
    """
    from scipy.optimize import minimize_scalar
    from scipy.stats import norm

    feats = [f for f, _ in samples]
    scores = np.asarray([s for _, s in samples])
    hit = scores >= USE_FLOOR
    if hit.sum() < 10 or (scores >= THRESHOLD).sum() < 10:
        raise SitcovError(
            f"only {int(hit.sum())} frames detected at >= {USE_FLOOR}: too few to fit the PEM"
        )
    heights = np.asarray([f.height_px for f in feats])
    lo = float(np.percentile(heights[hit], 1))
    hi = float(np.percentile(heights[hit], 98))
    ref = float(np.exp(np.mean(np.log(heights[hit]))))
    keep = heights >= lo
    x = _design([f for f, k in zip(feats, keep, strict=True) if k], ref, lo, hi)
    s = scores[keep]
    g = _probit(x, s >= THRESHOLD)
    zg, gap = x @ g, _logit(THRESHOLD) - _logit(USE_FLOOR)
    reported = np.where(s >= USE_FLOOR, 1.0, -1.0)

    def nll(sigma: float) -> float:
        return -float(norm.logcdf(reported * (zg + gap / sigma)).sum())

    sigma = float(minimize_scalar(nll, bounds=(0.05, 5.0), method="bounded").x)
    beta = sigma * g
    beta[0] += _logit(THRESHOLD)
    fitted = {name: float(sign * b) for (name, sign), b in zip(_COLUMNS, beta, strict=True)}
    fitted.update(size_ref_px=ref, size_min_px=lo, size_max_px=hi, noise_sigma=sigma,
                  rain_sigma=0.0, rain_miss=0.0, floor=USE_FLOOR, side_size_gain=0.0,
                  aspect_gain=0.0, contrast_gain=0.0, detail_gain=0.0, chroma_gain=0.0,
                  red_green_gain=0.0, yellow_blue_gain=0.0)  # fmt: skip
    return PEMParams.from_mapping({**base.to_dict(), **{k: round(v, 4) for k, v in fitted.items()}})


def _logit(p: float) -> float:
    return math.log(p / (1.0 - p))


def summary(samples: Sequence[tuple[PEMFeatures, float]], camera: CameraSpec) -> dict[str, Any]:
    """Frames and the clear-weather detection rate of boxes >= 10 % of the image height."""
    clear = [
        s for f, s in samples
        if f.transmittance >= 0.999 and f.rain_noise == 0 and f.height_px >= 0.1 * camera.height
    ]  # fmt: skip
    return {
        "frames": len(samples),
        "detected_ge_0.3": round(float(np.mean([s >= USE_FLOOR for _, s in samples])), 3),
        "clear_box_ge_10pct_frames": len(clear),
        "clear_box_ge_10pct_rate": round(float(np.mean([s >= USE_FLOOR for s in clear])), 3)
        if clear
        else None,
    }
