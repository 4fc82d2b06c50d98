"""The frame model's check on held-out frames: P(score >= θ), PEM vs detector.

For each kind (car, person, bicycle), distance band and threshold θ, the detector's share
of frames whose recorded score reaches θ is compared with the PEM's probability of it,
averaged over the same frames: ``P(score >= θ) = Φ((m(x) - logit θ) / noise_sigma)`` for a
box at least ``size_min_px`` high (0 below it, as the sensor never reports it), with
``m`` the PEM's own logit (:func:`sitcov.perception.pem_logit`) of the frame's features.
The frames should be held out (recorded with another seed than the fit's) and recorded
with ``--record-frames`` (the stack given no detections), so that no frame was kept or
dropped because of a score: the marginal probability is then the right prediction.

A band can hide where the PEM is off: its frames mix road users seen head-on and side-on,
from the left and from the right, in rain and in the dry, and misses of opposite sign
cancel in the band's mean while a stack's verdicts depend on which situations carry
them. ``split`` (``sitcov calibrate --check FILE --check-by NAME``, :data:`SPLITS`) cuts
each (class, band) cell further by one such property of the frame or of its run.

A cell's frames are not independent: one road user's consecutive frames share its
colour, model, path and the detector's bursts. So each difference carries a 95 %
interval from a bootstrap over the recorded runs (:func:`run_interval`, resampled whole),
and a cell whose interval lies wholly outside ±:data:`TOLERANCE` is a *significant*
miss: the frames show the PEM off there, not only the sample's scatter.

A frame's law is not yet a verdict's: a stack brakes on the first frame that passes its
test, so what decides a run is whether *some* frame of the road user's track reaches θ,
which depends on how the noise runs from frame to frame (its AR(1) state, ``noise_tau``).
``tracks`` (:func:`check_tracks`, ``--check-tracks``) judges that law: per (class, band,
θ), the share of tracks (one road user's frames in one run) with a frame in the band at or
above θ, against the PEM's chance of it (:func:`track_pass_probability`, a filter over the
AR state on the same frames).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from typing import Any

import numpy as np

from sitcov.calibration._camera_runs import FRAME_PERIOD
from sitcov.calibration._frames import KIND_LABEL, KindFrames
from sitcov.errors import SitcovError
from sitcov.hyperspace._situation import approach_side
from sitcov.perception._pem import PEMParams, pass_given_state, tau_steps
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
#: Bootstrap resamples of the runs for a cell's interval.
RESAMPLES = 2000


#: Facing (cosine of the road user's heading to the line of sight) beyond which the
#: ``view`` split counts it as seen end-on: within 45 degrees of its front or its rear.
END_ON = math.sqrt(0.5)
#: Truncation above which the ``cut`` split counts a box as cut by the image edge [-].
CUT = 0.05
#: The situation's precipitation (the hyperspace element, 0-100) from which the ``rain``
#: split counts a run as heavy rain.
HEAVY_RAIN = 50.0
#: View angle [rad] within which the ``angle`` split counts a road user as seen head-on
#: (front or rear), and three times which as seen from the side: 22.5 and 67.5 degrees.
HEAD_ON = math.pi / 8.0
#: The situation's wind intensity (the hyperspace element, 0-100) from which the
#: ``wind`` split counts a rainy run as windy.
WINDY = 50.0


def _approach(feats: Any, situation: Mapping[str, Any]) -> str:
    side = approach_side(situation.get("bins", {}), situation.get("values", {}))
    return "ahead/other" if side in ("ahead", "other") else f"from {side}"


def _view(feats: Any, situation: Mapping[str, Any]) -> str:
    if feats.facing <= -END_ON:
        return "front"
    return "rear" if feats.facing >= END_ON else "side"


def _rain(feats: Any, situation: Mapping[str, Any]) -> str:
    rain = situation.get("values", {}).get("precipitation")
    if not isinstance(rain, (int, float)):
        return "unknown"
    return "dry" if rain <= 0.0 else ("heavy rain" if rain >= HEAVY_RAIN else "light rain")


def _angle(feats: Any, situation: Mapping[str, Any]) -> str:
    if feats.view_angle >= 3.0 * HEAD_ON:
        return "side"
    end = "front" if feats.facing < 0.0 else "rear"
    return f"head-on {end}" if feats.view_angle < HEAD_ON else f"oblique {end}"


def _wind(feats: Any, situation: Mapping[str, Any]) -> str:
    values = situation.get("values", {})
    rain, wind = values.get("precipitation"), values.get("wind_intensity")
    if not all(isinstance(v, (int, float)) for v in (rain, wind)):
        return "unknown"
    if rain <= 0.0:
        return "dry"
    return "windy rain" if wind >= WINDY else "calm rain"


def _cut(feats: Any, situation: Mapping[str, Any]) -> str:
    return "cut" if feats.truncation > CUT else "whole"


#: The ``size`` split's bins of the box height [px]: lower edges (the last open above).
SIZE_EDGES = (0.0, 60.0, 80.0, 100.0, 150.0, 300.0)


def _size_labels() -> tuple[str, ...]:
    pairs = zip(SIZE_EDGES, (*SIZE_EDGES[1:], None), strict=True)
    return tuple(f"{lo:.0f}-{hi:.0f} px" if hi else f">= {lo:.0f} px" for lo, hi in pairs)


def _size(feats: Any, situation: Mapping[str, Any]) -> str:
    k = sum(feats.height_px >= edge for edge in SIZE_EDGES[1:])
    return _size_labels()[k]


#: The ways :func:`check_frames` can split each (class, band) cell: name -> (the group of
#: a frame from its features and its run's situation, the groups in print order).
#: ``approach``: where the run's road user comes from, seen by the ego (left, right, or
#: ahead and any other, :func:`sitcov.hyperspace._situation.approach_side`); ``view``: the
#: road user seen within 45 degrees of its front or of its rear, else from the side;
#: ``angle``: finer, within :data:`HEAD_ON` of its front or rear, oblique, or within
#: :data:`HEAD_ON` of side-on (the detector scores a close car seen head-on lower and one
#: seen obliquely higher than the PEM does: docs/pem.md, "The check split by view
#: angle");
#: ``rain``: the situation's precipitation 0, below :data:`HEAVY_RAIN`, or from it
#: (``unknown`` without that element); ``wind``: a dry run, or a rainy one with a wind
#: intensity below :data:`WINDY` or from it (in camera mode the wind slants the rain
#: streaks: docs/pem.md, "The wind in the rain"); ``cut``: the box cut by the image edge
#: or whole; ``size``: the box height's bin of :data:`SIZE_EDGES` (the detector's scores
#: have a ceiling that rises with the box: docs/pem.md, "The score's ceiling").
SPLITS: dict[str, tuple[Callable[[Any, Mapping[str, Any]], str], tuple[str, ...]]] = {
    "approach": (_approach, ("from left", "from right", "ahead/other")),
    "view": (_view, ("front", "side", "rear")),
    "angle": (_angle, ("head-on front", "oblique front", "side", "oblique rear", "head-on rear")),
    "rain": (_rain, ("dry", "light rain", "heavy rain", "unknown")),
    "wind": (_wind, ("dry", "calm rain", "windy rain", "unknown")),
    "cut": (_cut, ("whole", "cut")),
    "size": (_size, _size_labels()),
}
#: A split by the run's bin of one hyperspace element: ``bin:`` and the element's name
#: (``bin:intsit``, ``bin:wind_intensity``); its groups are the bins found, in natural
#: order (``unknown`` for a run without that element).
BIN_SPLIT = "bin:"
#: The splits whose group is the run's, the same for every frame of a track (the only
#: ones :func:`check_tracks` can use; besides :data:`BIN_SPLIT`).
RUN_SPLITS = ("approach", "rain", "wind")


def pass_probability(params: PEMParams, feats: Any, theta: float) -> float:
    """The PEM's P(score >= theta) for one frame's features
    (:func:`sitcov.perception._pem.pass_probability`)."""
    return _pass(feats, params, theta)


def frames_of(
    data: KindFrames, split: str | None = None
) -> list[tuple[Any, float, float, int, str]]:
    """(features, score, distance, run number, group) of every run frame with a recorded
    distance (the run number counts the file's runs from 0; the group is the frame's in
    :data:`SPLITS` ``[split]``, "" without a split)."""
    group = _split(split)[0] if split else None
    out = []
    for i, r in enumerate(data.runs):
        for f in r.frames:
            if f.distance >= 0.0 and f.features.height_px >= 1.0:
                g = group(f.features, r.situation or {}) if group else ""
                out.append((f.features, f.score, f.distance, i, g))
    return out


def _split(name: str) -> tuple[Callable[[Any, Mapping[str, Any]], str], tuple[str, ...]]:
    """:data:`SPLITS` ``[name]`` or a :data:`BIN_SPLIT` (its groups empty: found in the
    data), or an error naming the splits there are."""
    if _is_bin_split(name):
        element = name[len(BIN_SPLIT) :]
        return (lambda feats, situation: str(situation.get("bins", {}).get(element, "unknown"))), ()
    try:
        return SPLITS[name]
    except KeyError:
        raise SitcovError(
            f"unknown split {name!r} of the check; expected one of {', '.join(SPLITS)} or "
            f"{BIN_SPLIT}ELEMENT (a hyperspace element, e.g. {BIN_SPLIT}intsit)"
        ) from None


def _is_bin_split(name: str) -> bool:
    """Whether ``name`` is a :data:`BIN_SPLIT` with an element named."""
    return name.startswith(BIN_SPLIT) and len(name) > len(BIN_SPLIT)


def known_split(name: str, tracks: bool = False) -> bool:
    """Whether ``name`` is a split of the frame check (:data:`SPLITS`) or, with
    ``tracks``, of the track check (:data:`RUN_SPLITS`: a track's frames share the run's
    group), or a bin split (both)."""
    return name in (RUN_SPLITS if tracks else SPLITS) or _is_bin_split(name)


def split_names(tracks: bool = False) -> str:
    """The splits the frame check (or, with ``tracks``, the track check) takes, for
    messages."""
    return " | ".join((*(RUN_SPLITS if tracks else SPLITS), f"{BIN_SPLIT}ELEMENT"))


def _natural(label: str) -> tuple[Any, ...]:
    """Sort key of a bin label: its runs of digits as numbers (``IntSit-2`` before
    ``IntSit-10``, ``20`` before ``100``)."""
    import re

    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", label))


def _groups(split: str | None, found: Sequence[str]) -> tuple[str, ...]:
    """The groups of ``split`` in print order (those found in the data for a bin split;
    ``("",)`` without a split)."""
    if not split:
        return ("",)
    return _split(split)[1] or tuple(sorted(set(found), key=_natural))


def run_interval(
    pem: np.ndarray, hit: np.ndarray, run: np.ndarray, rng: np.random.Generator,
    resamples: int = RESAMPLES,
) -> tuple[float, float]:  # fmt: skip
    """95 % interval of ``mean(pem) - mean(hit)`` over a cell's frames (the PEM's
    probability and whether the detector's score reached θ, per frame), the runs
    (``run``, one number per frame) resampled with replacement, whole."""
    runs, at = np.unique(run, return_inverse=True)
    n = np.bincount(at, minlength=len(runs)).astype(float)
    p_sum = np.bincount(at, weights=pem, minlength=len(runs))
    h_sum = np.bincount(at, weights=hit.astype(float), minlength=len(runs))
    w = rng.multinomial(len(runs), np.full(len(runs), 1.0 / len(runs)), size=resamples)
    frames = w @ n
    diff = (w @ p_sum - w @ h_sum) / np.maximum(frames, 1.0)
    lo, hi = np.quantile(diff, [0.025, 0.975])
    return float(lo), float(hi)


def check_frames(
    frames: Mapping[str, KindFrames], params: Mapping[str, PEMParams],
    thetas: Sequence[float] = THETAS, bands: Sequence[tuple[float, float]] = BANDS,
    rng: np.random.Generator | None = None, split: str | None = None,
) -> list[dict[str, Any]]:  # fmt: skip
    """One row per (kind, band, θ): frames, runs, detector and PEM rates, difference,
    within :data:`TOLERANCE`; ``params`` per kind. With ``rng``, each judged row also
    holds the difference's run-bootstrap interval (``low``, ``high``,
    :func:`run_interval`) and whether it lies wholly outside the tolerance
    (``significant``). With ``split`` (a name of :data:`SPLITS`) one row per (kind, band,
    group, θ) instead, ``group`` naming the group (a group with no frames in the band is
    left out)."""
    rows = []
    for kind, data in frames.items():
        got = frames_of(data, split)
        groups = _groups(split, [g for *_, g in got])
        for lo, hi in bands:
            for group in groups:
                sel = [(f, s, r) for f, s, d, r, g in got if lo <= d < hi and g == group]
                if split and not sel:
                    continue
                head = _cell_head(kind, (lo, hi), group if split else None)
                rows += _cell_rows(head, sel, params[kind], thetas, rng)
    return rows


def _cell_head(kind: str, band: tuple[float, float], group: str | None) -> dict[str, Any]:
    """The leading fields of a cell's rows: its kind, label, band and (split) group."""
    head = {"kind": kind, "label": KIND_LABEL[kind], "band": f"{band[0]:g}-{band[1]:g} m"}
    return head | ({"group": group} if group is not None else {})


def _cell_rows(
    head: Mapping[str, Any], sel: Sequence[tuple[Any, float, int]], p: PEMParams,
    thetas: Sequence[float], rng: np.random.Generator | None,
) -> list[dict[str, Any]]:  # fmt: skip
    """:func:`check_frames`' rows of one cell's frames ``sel`` (features, score, run), one
    per θ, each starting with ``head``."""

    def outcome(theta: float) -> tuple[np.ndarray, np.ndarray]:
        hit = np.asarray([s >= theta for _, s, _ in sel])
        return hit, np.asarray([pass_probability(p, f, theta) for f, _, _ in sel])

    return _judged_rows(head, np.asarray([r for _, _, r in sel], dtype=int), thetas, outcome, rng)


def _judged_rows(
    head: Mapping[str, Any], run: np.ndarray, thetas: Sequence[float],
    outcome: Callable[[float], tuple[np.ndarray, np.ndarray]], rng: np.random.Generator | None,
) -> list[dict[str, Any]]:  # fmt: skip
    """One row per θ for a cell of ``len(run)`` items (frames or tracks; ``run`` the run
    of each): ``outcome(θ)`` gives whether each item's recorded score reached θ and the
    PEM's probability of it; a cell of at least :data:`MIN_FRAMES` items is judged
    (rates, difference, within :data:`TOLERANCE`; with ``rng`` the run-bootstrap interval
    and whether it lies wholly outside the tolerance)."""
    rows = []
    for theta in thetas:
        row: dict[str, Any] = {**head, "theta": theta, "n": len(run), "runs": len(np.unique(run))}
        if len(run) >= MIN_FRAMES:
            hit, prob = outcome(theta)
            det, pem = float(np.mean(hit)), float(np.mean(prob))
            row.update(detector=round(det, 4), pem=round(pem, 4),
                       difference=round(pem - det, 4),
                       ok=abs(pem - det) <= TOLERANCE)  # fmt: skip
            if rng is not None:
                low, high = run_interval(prob, hit, run, rng)
                row.update(low=round(low, 4), high=round(high, 4),
                           significant=low > TOLERANCE or high < -TOLERANCE)  # fmt: skip
        rows.append(row)
    return rows


#: Nodes of the AR(1) state's grid in :func:`track_pass_probability`, over
#: ±:data:`TRACK_GRID_HALF` standard units (41 give the car's track chances within 0.002
#: of 161's on recorded tracks: ``tests/calibration/test_frame_check_tracks.py``).
TRACK_GRID = 41
TRACK_GRID_HALF = 5.0


def track_pass_probability(
    params: PEMParams, frames: Sequence[tuple[int, Any]], theta: float,
    frame_dt: float = FRAME_PERIOD, nodes: int = TRACK_GRID,
) -> float:  # fmt: skip
    """The PEM's chance that some frame of one road user's track reaches ``theta``:
    ``frames`` its (frame number, features) in time order, frames ``frame_dt`` [s] apart.

    The frames share the noise's AR(1) state ``u`` (coefficient ``phi = exp(-frame_dt /
    noise_tau)`` per frame, ``phi ** (gap * tau_steps)`` across a gap into a frame,
    :func:`sitcov.perception._pem.tau_steps` of its box); given it, each frame passes
    independently (:func:`sitcov.perception._pem.pass_given_state`: its detection, its
    fresh noise, its outlier draw). So P(no frame passes) is a forward filter over ``u``
    on a grid of ``nodes`` points, each frame's step multiplying by P(it does not pass |
    u). A file with a noise part constant over a run (``noise_run_share`` > 0) is refused:
    the filter would need that part too (every shipped class has none)."""
    from sitcov.calibration._frame_model import _kernel

    _need_no_run_share(params)
    u = np.linspace(-TRACK_GRID_HALF, TRACK_GRID_HALF, nodes)
    alpha = np.exp(-0.5 * u * u)
    alpha /= alpha.sum()
    phi = math.exp(-frame_dt / params.noise_tau) if params.noise_tau > 0.0 else 0.0
    kernels: dict[float, np.ndarray] = {}
    prev = None
    for number, feats in frames:
        if prev is not None:
            steps = max(1, int(number) - prev) * tau_steps(params, feats.height_px)
            if steps not in kernels:
                kernels[steps] = _kernel(u, phi**steps)
            alpha = alpha @ kernels[steps]
        alpha = alpha * (1.0 - np.asarray(pass_given_state(feats, params, theta, u)))
        prev = int(number)
    return float(1.0 - alpha.sum())


def _need_no_run_share(params: PEMParams) -> None:
    """Refuse parameters with a noise part constant over a run (the filter has no state
    for it)."""
    if params.noise_run_share > 0.0:
        raise SitcovError(
            f"the track check needs noise_run_share 0 (a noise part constant over a run is "
            f"not filtered); these parameters have {params.noise_run_share}"
        )


def tracks_of_runs(
    data: KindFrames, band: tuple[float, float], split: str | None = None
) -> list[tuple[list[tuple[int, Any, float]], int, str]]:
    """Each road user's track in each run, cut to its frames in the distance ``band``
    (``lo <= d < hi``): ((frame number, features, score) in time order, run number, group
    of :data:`RUN_SPLITS` or a bin split, "" without one); a track with no frame there is
    left out. Frames without a recorded number (-1) count as consecutive."""
    if split and not known_split(split, tracks=True):
        raise SitcovError(
            f"the track check splits by the run only ({', '.join(RUN_SPLITS)} or "
            f"{BIN_SPLIT}ELEMENT); {split!r} changes from frame to frame"
        )
    group = _split(split)[0] if split else None
    lo, hi = band
    out = []
    for i, run in enumerate(data.runs):
        situation = run.situation or {}
        by_actor: dict[int, list[tuple[int, Any, float]]] = {}
        for k, f in enumerate(run.frames):
            if f.features.height_px >= 1.0 and f.distance >= 0.0 and lo <= f.distance < hi:
                number = f.frame if f.frame >= 0 else k
                by_actor.setdefault(f.actor, []).append((number, f.features, f.score))
        g = group(None, situation) if group else ""
        out += [(sorted(t, key=lambda x: x[0]), i, g) for t in by_actor.values()]
    return out


def check_tracks(
    frames: Mapping[str, KindFrames], params: Mapping[str, PEMParams],
    thetas: Sequence[float] = THETAS, bands: Sequence[tuple[float, float]] = BANDS,
    rng: np.random.Generator | None = None, split: str | None = None,
) -> list[dict[str, Any]]:  # fmt: skip
    """:func:`check_frames` per track: one row per (kind, band, [group,] θ) whose ``n``
    counts tracks, ``detector`` the share of them with a frame in the band whose
    recorded score reaches θ and ``pem`` the mean of :func:`track_pass_probability` over
    them; the interval (with ``rng``) resamples the runs, whole. ``split``: one of
    :data:`RUN_SPLITS` or a bin split."""
    for p in params.values():
        _need_no_run_share(p)
    rows = []
    for kind, data in frames.items():
        for lo, hi in bands:
            got = tracks_of_runs(data, (lo, hi), split)
            for group in _groups(split, [g for *_, g in got]):
                sel = [(t, r) for t, r, g in got if g == group]
                if split and not sel:
                    continue
                head = _cell_head(kind, (lo, hi), group if split else None)
                rows += _track_rows(head, sel, params[kind], thetas, rng)
    return rows


def _track_rows(
    head: Mapping[str, Any], sel: Sequence[tuple[Sequence[tuple[int, Any, float]], int]],
    p: PEMParams, thetas: Sequence[float], rng: np.random.Generator | None,
) -> list[dict[str, Any]]:  # fmt: skip
    """:func:`check_tracks`' rows of one cell's tracks ``sel`` (frames, run), one per θ."""

    def outcome(theta: float) -> tuple[np.ndarray, np.ndarray]:
        hit = np.asarray([any(s >= theta for _, _, s in t) for t, _ in sel])
        prob = [track_pass_probability(p, [(n, f) for n, f, _ in t], theta) for t, _ in sel]
        return hit, np.asarray(prob)

    return _judged_rows(head, np.asarray([r for _, r in sel], dtype=int), thetas, outcome, rng)


def table_lines(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The check as a printed table (with the intervals when the rows have them, a group
    column when they are split), then the count of cells within the tolerance (and of
    significant misses)."""
    ci = any("low" in r for r in rows)
    width = max((len(r["group"]) for r in rows if "group" in r), default=0)
    group = (lambda r: f" {r['group']:<{width}}") if width else (lambda r: "")
    head = f"{'class':<8} {'band':<9}" + (f" {'group':<{width}}" if width else "")
    head += f" {'theta':>5} {'n':>6} {'detector':>9} {'PEM':>7} {'diff':>7}"
    head += f"  {'95% (runs)':<17}" if ci else ""
    lines = [head + f"  within ±{TOLERANCE:g}"]
    for r in rows:
        cell = f"{r['label']:<8} {r['band']:<9}{group(r)} {r['theta']:>5.1f} {r['n']:>6}"
        if "detector" not in r:
            lines.append(f"{cell}  (fewer than {MIN_FRAMES} frames: not judged)")
            continue
        line = f"{cell} {r['detector']:>9.3f} {r['pem']:>7.3f} {r['difference']:>+7.3f}"
        verdict = "yes" if r["ok"] else "NO"
        if "low" in r:
            line += f"  [{r['low']:+.3f}, {r['high']:+.3f}]"
            verdict += " (significant)" if r["significant"] else ""
        lines.append(f"{line}  {verdict}")
    judged = [r for r in rows if "ok" in r]
    tail = f"{sum(r['ok'] for r in judged)}/{len(judged)} cells within ±{TOLERANCE:g}"
    if ci:
        sig = sum(bool(r.get("significant")) for r in judged)
        tail += f"; {sig} off significantly (the 95 % interval over runs wholly outside)"
    lines.append(tail)
    return lines
