"""The frame model: the detector's score per road user and frame, fitted by maximum likelihood.

The PEM (:mod:`sitcov.perception._pem`) says, for one road user in one frame, whether the
SSD outputs it and with which top score. With ``m(x_t)`` the PEM's logit of the frame's
features ``x_t`` (class, size, view, truncation, fog transmittance, light, rain, colour):

- a latent unit noise ``n_t = sqrt(s) a_t + sqrt(1 - s) e_t``, ``a_t`` an AR(1) process
  over the road user's frames (``a_t = rho^g a_{t-g} + sqrt(1 - rho^(2g)) N(0, 1)``, ``g``
  frames apart), ``e_t`` fresh every frame;
- the score ``logit(score_t) = m(x_t) + g(n_t)``, ``g(n) = sigma_t n`` below 0 and
  ``sigma_t * up * n`` above (a split normal: the detector's scores spread less upwards),
  ``sigma_t = sigma (h_t / size_ref) ** k`` with the box height ``h_t`` capped at ``cap``
  (the scores on a large, close box spread more than on a small one; ``k`` = 0 without
  the term), its gain changing by ``kb`` above a fixed knot (``Noise.kb``: the rider's
  and the person's scores narrow up to 150 px and spread on the larger, mostly cut
  boxes); optionally the upper scale with a size gain of its own (``ku``), and a
  share ``po`` of *outlier frames* whose logit score is ``m(x_t)`` plus ``ro`` times the
  frame's scale times a fresh N(0, 1), independent of the AR state (:class:`Noise`),
  and a *lower tail*: below one standard unit under the median, ``g`` stretches the
  latent noise to ``n - tl (n + 1) ** 2`` (``Noise.tl``: the detector's scores pile up
  under a ceiling with a long tail of weak frames below it);
- the detector outputs the road user with probability ``Phi(d0 + d1 m(x_t) - dt trunc_t -
  df fill_t + lam a_t)`` (its misses, which come in bursts with the same AR state), with
  ``trunc_t`` the share of the box outside the image and ``fill_t`` the box's width over
  the image's (:func:`sitcov.perception._pem.fill_of`): the SSD gives no box to most road
  users that fill the image or are cut by its edge, which no term of ``m`` (fitted on the
  frames it does score) describes.

In ``pem.yaml``: ``noise_sigma`` = sigma, ``noise_up_ratio`` = up, ``noise_frame_share`` =
1 - s, ``noise_tau`` = -frame_dt / ln(rho), ``detect_bias/gain/ar`` = d0, d1, lam,
``detect_trunc_gain``/``detect_fill_gain`` = dt, df, ``noise_size_gain`` = k,
``noise_size_max_px`` = cap, ``noise_low_tail`` = tl, ``noise_bend_gain`` = kb,
``noise_bend_px`` = the knot, ``noise_up_rain_wind_gain``/``_px`` = uw and its knot
(a held term, ``up_rain_wind``), ``noise_tau_size_gain`` = kt (``tau_size``),
``noise_ceiling_logit``/``_size_gain``/``_slope`` = cl, cg, cs (``ceiling``). It is
the same model for every stack: no term is chosen on any stack's verdicts.

The data are recorded frames of the real detector (:mod:`sitcov.calibration._frames`):
camera runs (consecutive frames of one road user form a *track*) and static sweep frames
(tracks of one frame). A score below :data:`CENSOR` counts as censored (only "below" is
used): the recording kept boxes down to 0.05, but those weak boxes are the frames the
detector all but misses, which the detection term covers.

Fit (:func:`fit_tracks`), by maximum likelihood:

1. the coefficients of ``m`` and a starting scale, by ridge least squares of the logit
   scores above :data:`CENSOR`, for each ``size_max_px`` on a grid (the best by likelihood);
2. the exact likelihood of every track (a forward filter on a grid of the AR state,
   :func:`track_loglik`), maximised over the intercept, a common scale of the other
   coefficients, sigma, up, s, rho, d0, d1, lam (and dt, df; and k). A camera run recorded with the
   reference stack stops calling its detector when its AEB fires; the sequence
   likelihood conditions each frame on the earlier ones, which in principle leaves that
   stopping rule ignorable, but with the detection term it does not undo the selection
   (tests/calibration/test_frame_model.py: runs cut at the first score >= 0.5 fit an
   intercept too low): runs recorded to their end (``--record-frames``) are the data
   to fit on. That is ``stages=1``; ``sitcov calibrate`` fits in two stages (``stages=2``,
   :func:`_two_stage`): the marginal terms (the logit, sigma, up, k, d0, d1, dt, df, lam)
   by the frames-alone likelihood (:meth:`FrameFit.marginal_loglik`), then s and rho by
   the sequence likelihood with every frame's law held, and chooses among the candidates
   by the frames-alone held-out likelihood (docs/pem.md, "How it is fitted").

Model choice (:func:`choose_model`, :func:`held_out_choice`): independent frames
(``s = 0``), the AR(1) model, the AR(1) model with the detection term's geometry (dt,
df; without it they are 0), or that with the noise's size gain k (the height capped at
the score's ``size_max_px`` or at the image height), with the size terms free, and that
with the side's term (``side_gain``: the road user seen from its left or its right), by
the log-likelihood of held-out tracks. :data:`EXTRA_SETS` are further terms (the side by
distance band or offset, the lane, close-range terms, a cubic size term, bends of the size
term at fixed heights, the size in the detection term alone) that
``benchmarks/pem_cell_candidates.py`` measures on each class's chosen model; of them only
the cube of the log size, the outlier frames, the upper spread's size gain and the lower
tail (:data:`CLASS_CANDIDATES`) and the bends at 40 and 80 px, the side-on bend and the
lower tail (:data:`CAR_CANDIDATES`) are candidates of ``sitcov calibrate``, with PEM
parameters (docs/pem.md, "Terms tried for the per-cell check", "Outlier frames", "The
lower tail"). The lower tail is fitted from the optimum without it (:func:`_with_tail`).
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from sitcov.calibration._calibrate import _LINEAR, EXTRA_TERM_PARAMS, _design, _jitter
from sitcov.calibration._frames import KindFrames
from sitcov.errors import SitcovError
from sitcov.perception._pem import (
    CUT_RAMP,
    FRAME_DT,
    HEAD_ON_DEG,
    HEAD_ON_PX,
    LOW_TAIL_KNEE,
    PEMFeatures,
    PEMParams,
)

#: Scores below this count as censored (only "below" is used) [-]: the recording kept
#: scores down to 0.05, but below ~0.2 the detector's box is a stray weak one (the frames
#: it all but misses); the model's detection term covers them, its score law the scores
#: that matter to any stack (>= the output floor 0.3) without being widened by them.
CENSOR = 0.2
#: The detector's output floor in use: a road user is reported at this score [-].
FLOOR = 0.3
#: ``size_max_px`` candidates [px] (the best by step 1's likelihood).
SIZE_MAX_GRID = (60.0, 100.0, 150.0, 200.0, 300.0, 450.0)
#: Nodes of the AR state's grid (standard units, uniformly over +-4).
GRID_NODES = 17
#: Largest AR share of the latent noise (the frame part keeps the grid's emissions smooth).
SHARE_MAX = 0.97
#: Largest AR(1) coefficient per frame tried (the grid resolves kernels down to this).
RHO_MAX = 0.98
#: Step of stage 1's first pass's finite-difference gradient (the two-stage fit,
#: :func:`fit_tracks`) [parameter units]: the split normal's density jumps by ``ln up``
#: where the mean crosses a frame's score, so the frames-alone likelihood is piecewise
#: smooth with thousands of small steps, and L-BFGS-B with the default 1e-8 differences
#: stops on them (synthetic runs drawn with sigma 0.8: 0.65, up 1.21 for 1.0, 24 log-
#: likelihood units short); differences this wide step over them (a second pass with
#: the default ones from there gained 3.4 units on the 18,000 car frames, 0.0002 per
#: frame, in 70 s: not made).
SMOOTH_EPS = 1e-3
#: Largest share of outlier frames (``Noise.po``) the fit may take: beyond a half the
#: "outliers" would be the usual law.
OUTLIER_MAX = 0.5
#: The default camera's image height [px]: a cap of the score noise's size term.
IMAGE_HEIGHT = 450.0
#: Percentile of the reported boxes' heights below which the PEM reports nothing [%]
#: (low: the logit, fitted on every size, already makes small boxes rare).
MIN_PX_PERCENTILE = 0.5
#: Model candidates: (name, ridge penalty, AR(1) term, detection geometry terms[, the score
#: noise's size gain with its height cap: 0 = the score's own ``size_max_px``, else that
#: many px[, the size terms free in step 2[, the side's term ``side_gain * side``]]]); a
#: 4-tuple has no size gain. The side term (the one feature that tells a road user seen
#: from its left from one seen from its right, :class:`~sitcov.perception.PEMFeatures`)
#: needs frames recorded since it exists: on older files ``side`` is 0 and the candidate
#: ties with the one without it (the first of equals is chosen). An 8th value names extra
#: terms (:data:`EXTRA_TERMS`; of them only ``size3``, the cube of the log size, has a PEM
#: parameter, ``size3_gain``): :data:`CLASS_CANDIDATES`.
CANDIDATES = (
    ("independent", 1.0, False, False),
    ("ar1", 1.0, True, False),
    ("ar1_edge", 1.0, True, True),
    ("ar1_edge_scale", 1.0, True, True, 0.0),
    ("ar1_edge_scale_image", 1.0, True, True, IMAGE_HEIGHT),
    ("ar1_edge_scale_size", 1.0, True, True, 0.0, True),
    ("ar1_edge_scale_image_size", 1.0, True, True, IMAGE_HEIGHT, True),
    ("ar1_edge_scale_image_size_side", 1.0, True, True, IMAGE_HEIGHT, True, True),
)
#: Candidates tried for pedestrians and cyclists besides :data:`CANDIDATES`: the models
#: the two classes chose before it with the cube of the log size (``size3_gain``), a size
#: term of their own (docs/pem.md, "Terms tried for the per-cell check"), and with a share
#: of outlier frames (``noise_outlier_share``/``_ratio``) or the upper spread's own size
#: gain (``noise_up_size_gain``; docs/pem.md, "Outlier frames"), and with the lower tail
#: (``noise_low_tail``, docs/pem.md, "The lower tail"), and those with a bend of the
#: noise's size gain at 150 px (``noise_bend_gain``, ``noise_bend_px``: a 13th value, the
#: knot [px]; docs/pem.md, "The close rider"). Not for cars: there the
#: cube wins held out (-0.297 vs -0.337 per frame) but the check's car cells drop from 9
#: to 5 of 15, and the side term and the upper size gain win on seed 2's 30 even runs but
#: little on seed 3's 150, with the close cells no better, so they are measured
#: (``benchmarks/pem_cell_candidates.py``, :data:`EXTRA_SETS`), not candidates.
CLASS_CANDIDATES = (
    ("ar1_edge_size3", 1.0, True, True, None, False, False, ("size3",)),
    ("ar1_edge_scale_image_size3", 1.0, True, True, IMAGE_HEIGHT, False, False, ("size3",)),
    ("ar1_edge_scale_outliers", 1.0, True, True, 0.0, False, False, (), False, True),
    ("ar1_edge_scale_up", 1.0, True, True, 0.0, False, False, (), False, False, True),
    ("ar1_edge_scale_image_size3_outliers", 1.0, True, True, IMAGE_HEIGHT, False, False,
     ("size3",), False, True),
    ("ar1_edge_scale_tail", 1.0, True, True, 0.0, False, False, (), False, False, False,
     True),
    ("ar1_edge_scale_image_size3_tail", 1.0, True, True, IMAGE_HEIGHT, False, False,
     ("size3",), False, False, False, True),
    ("ar1_edge_scale_image_size3_outliers_tail", 1.0, True, True, IMAGE_HEIGHT, False, False,
     ("size3",), False, True, False, True),
    ("ar1_edge_scale_image_size3_bend_tail", 1.0, True, True, IMAGE_HEIGHT, False, False,
     ("size3",), False, False, False, True, 150.0),
    ("ar1_edge_scale_image_size3_outliers_bend_tail", 1.0, True, True, IMAGE_HEIGHT, False,
     False, ("size3",), False, True, False, True, 150.0),
)  # fmt: skip


#: Candidates tried for cars besides :data:`CANDIDATES`: the chosen model's family with
#: bends of the size term at 40 and 80 px (``size_hinge40_gain``, ``size_hinge80_gain``:
#: the car's scores rise faster through 40-80 px and flatten above, docs/pem.md, "The
#: two-stage fit"), and with a bend at 40 px seen side-on (``view_hinge40_gain``: a close
#: car crossing side-on scores higher than one seen end-on, docs/pem.md, "The side-on
#: bend"), and that with the lower tail (``noise_low_tail``, docs/pem.md, "The lower
#: tail"); measured on cars only.
CAR_CANDIDATES = (
    ("ar1_edge_scale_image_size_hinge", 1.0, True, True, IMAGE_HEIGHT, True, False,
     ("hinge40", "hinge80")),
    ("ar1_edge_scale_image_size_hinge_view", 1.0, True, True, IMAGE_HEIGHT, True, False,
     ("hinge40", "hinge80", "view_hinge40")),
    ("ar1_edge_scale_image_size_hinge_view_tail", 1.0, True, True, IMAGE_HEIGHT, True, False,
     ("hinge40", "hinge80", "view_hinge40"), False, False, False, True),
)  # fmt: skip


def candidates_for(kind: str) -> tuple[tuple[Any, ...], ...]:
    """The model choice's candidates for ``kind``: :data:`CANDIDATES`, and for cars
    :data:`CAR_CANDIDATES`, for pedestrians and cyclists :data:`CLASS_CANDIDATES` too."""
    return CANDIDATES + CAR_CANDIDATES if kind == "car" else CANDIDATES + CLASS_CANDIDATES


#: Extra term sets (not chosen among by default: ``sitcov calibrate`` uses
#: :data:`CANDIDATES`; ``benchmarks/pem_cell_candidates.py`` measures them on each class's
#: chosen model, :func:`extended`): terms that could carry the per-cell gaps of the
#: held-out check and the left/right asymmetry (docs/pem.md, "Terms tried for the
#: per-cell check"). Each is (name, extra logit terms of :data:`EXTRA_TERMS`, whether the
#: score noise's scale gets a close-range factor ``exp(kn)``, ``Noise.kn``[, whether a
#: share of frames are outliers, ``Noise.po``/``ro``[, whether the upper scale has its own
#: size gain, ``Noise.ku``[, whether the noise has the lower tail, ``Noise.tl``]]]).
EXTRA_SETS: tuple[tuple[Any, ...], ...] = (
    ("side", ("side",), False),
    ("side_band", ("side_near", "side_mid", "side_far"), False),
    ("side_offset", ("side", "side_offset"), False),
    ("lane", ("lane", "lane_near"), False),
    ("approach", ("from_left", "from_right"), False),
    ("edge_near", ("offset_near", "trunc_near"), False),
    ("near", ("near",), False),
    ("near_noise", ("near",), True),
    ("size3", ("size3",), False),
    ("size_hinge", ("hinge40", "hinge80"), False),
    ("size_hinge3", ("hinge35", "hinge60", "hinge120"), False),
    ("det_size", ("det_size", "det_size2"), False),
    (
        "size_hinge_det",
        ("hinge40", "hinge80", "det_size", "det_size2", "det_hinge40", "det_hinge80"),
        False,
    ),
    ("hinge_120", ("hinge40", "hinge80", "hinge120"), False),
    ("hinge_160", ("hinge40", "hinge80", "hinge160"), False),
    ("hinge_det", ("hinge40", "hinge80", "det_size"), False),
    ("hinge_near", ("hinge40", "hinge80", "near"), False),
    ("hinge_trunc_side", ("hinge40", "hinge80", "trunc_side"), False),
    ("hinge_120_trunc_side", ("hinge40", "hinge80", "hinge120", "trunc_side"), False),
    ("hinge_view80", ("hinge40", "hinge80", "view_hinge80"), False),
    ("hinge_view40", ("hinge40", "hinge80", "view_hinge40"), False),
    ("hinge_view120", ("hinge40", "hinge80", "view_hinge120"), False),
    ("hinge_view80_det", ("hinge40", "hinge80", "view_hinge80", "det_view_hinge80"), False),
    ("hinge_view40_side", ("hinge40", "hinge80", "view_hinge40", "side"), False),
    (
        "hinge_view40_side_band",
        ("hinge40", "hinge80", "view_hinge40", "side_near", "side_mid", "side_far"),
        False,
    ),
    ("hinge_view40_trunc_near", ("hinge40", "hinge80", "view_hinge40", "trunc_near"), False),
    ("outliers", (), False, True),
    ("size3_outliers", ("size3",), False, True),
    ("up_size", (), False, False, True),
    ("hinge_view40_up_size", ("hinge40", "hinge80", "view_hinge40"), False, False, True),
    ("size3_up_size", ("size3",), False, False, True),
    ("hinge_view40_outliers", ("hinge40", "hinge80", "view_hinge40"), False, True),
    ("tail", (), False, False, False, True),
    ("hinge_view40_tail", ("hinge40", "hinge80", "view_hinge40"), False, False, False, True),
    ("hinge_view40_cut_tail", ("hinge40", "hinge80", "view_hinge40", "cut"), False, False,
     False, True),
    ("hinge_view40_cut_trunc20_tail", ("hinge40", "hinge80", "view_hinge40", "cut",
     "trunc_hinge20"), False, False, False, True),
)  # fmt: skip


def extended(
    candidate: Sequence[Any], name: str, extras: Sequence[str], near: bool,
    outliers: bool = False, up_size: bool = False, low_tail: bool = False,
    noise_bend: float | None = None,
) -> tuple:  # fmt: skip
    """``candidate`` (:data:`CANDIDATES`) with the set's extra logit terms (in place of
    its own), close-range noise factor, outlier frames, upper scale's size gain, lower
    tail and the noise's size bend at ``noise_bend`` px (None: none), named
    ``<candidate>+<name>``."""
    full = [*candidate[:7], *(None, False, False)[min(3, len(candidate) - 4) :]]
    return (f"{candidate[0]}+{name}", *full[1:7], tuple(extras), near, outliers, up_size,
            low_tail, noise_bend)  # fmt: skip


def _extras(
    candidate: Sequence[Any],
) -> tuple[tuple[str, ...], bool, bool, bool, bool, float | None]:
    """(extra logit terms, close-range noise scale, outlier frames, the upper scale's
    size gain, the lower tail, the noise's size bend's knot [px] or None) of a candidate
    (values 8 to 13 of its tuple)."""
    names = tuple(candidate[7]) if len(candidate) > 7 else ()
    flags = [bool(candidate[i]) if len(candidate) > i else False for i in (8, 9, 10, 11)]
    knot = float(candidate[12]) if len(candidate) > 12 and candidate[12] else None
    return names, flags[0], flags[1], flags[2], flags[3], knot


def _flags(candidate: Sequence[Any]) -> tuple[float, bool, bool, float | None, bool, bool]:
    """(ridge, ar, edge, scale cap or None, size terms free, side term) of a
    :data:`CANDIDATES` entry (4 to 7 values)."""
    cap = float(candidate[4]) if len(candidate) > 4 and candidate[4] is not None else None
    free = bool(candidate[5]) if len(candidate) > 5 else False
    side = bool(candidate[6]) if len(candidate) > 6 else False
    return float(candidate[1]), bool(candidate[2]), bool(candidate[3]), cap, free, side


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
        approach: where the run's road user comes from, seen by the ego (+1 left, -1
            right, 0 ahead, a sweep frame or unknown; :func:`approach_of`): the lane it
            drives in (from the left the near lane, from the right the far one).
        rain_wind: the run's precipitation times its wind, as fractions
            (:func:`rain_wind_of`; 0 for a sweep frame).
    """

    feats: tuple[PEMFeatures, ...]
    score: np.ndarray
    track: np.ndarray
    gap: np.ndarray
    group: np.ndarray
    distance: np.ndarray
    approach: np.ndarray | None = None
    rain_wind: np.ndarray | None = None

    def subset(self, groups: np.ndarray) -> Tracks:
        """The frames of the given groups."""
        keep = np.isin(self.group, groups)
        idx = np.flatnonzero(keep)
        return Tracks(
            tuple(self.feats[i] for i in idx), self.score[keep], self.track[keep],
            self.gap[keep], self.group[keep], self.distance[keep],
            None if self.approach is None else self.approach[keep],
            None if self.rain_wind is None else self.rain_wind[keep],
        )  # fmt: skip


def approach_of(situation: dict[str, Any]) -> float:
    """+1 if the run's road user comes from the ego's left, -1 from its right, 0 otherwise
    (:func:`sitcov.hyperspace._situation.approach_side` of the recorded situation)."""
    from sitcov.hyperspace._situation import approach_side

    side = approach_side(situation.get("bins", {}), situation.get("values", {}))
    return {"left": 1.0, "right": -1.0}.get(side, 0.0)


def rain_wind_of(situation: dict[str, Any]) -> float:
    """A recorded situation's precipitation times its wind, both as fractions of 100 (0
    without weather values): the ``rain_wind`` column, the rain the wind slants."""
    from sitcov.weather import rain_wind_of as of_values

    return of_values(situation.get("values") or {})


def tracks_of(data: KindFrames) -> Tracks:
    """The tracks of one kind's frames: each sweep frame alone, each run split by actor.

    Runs recorded before frame numbers were stored (``frame`` = -1) count their frames
    as consecutive (the gated camera frames of one road user are, until its AEB fires).
    """
    feats: list[PEMFeatures] = []
    score, track, gap, group, dist, appr, windy = [], [], [], [], [], [], []
    n_track = 0
    for i, (f, s, d) in enumerate(data.sweep):
        if f.height_px < 1.0:
            continue
        feats.append(f)
        score.append(s), track.append(n_track), gap.append(0), group.append(-1 - i)
        dist.append(d), appr.append(0.0), windy.append(0.0)
        n_track += 1
    for r, run in enumerate(data.runs):
        side = approach_of(run.situation or {})
        wind = rain_wind_of(run.situation or {})
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
                dist.append(fr.distance), appr.append(side), windy.append(wind)
                prev = number
            n_track += 1
    return Tracks(tuple(feats), np.asarray(score, dtype=float), np.asarray(track),
                  np.asarray(gap), np.asarray(group), np.asarray(dist, dtype=float),
                  np.asarray(appr, dtype=float), np.asarray(windy, dtype=float))  # fmt: skip


# --- step 1: the detected frames' scores, as independent (ridge least squares) ------------


def _ridge_ls(x: np.ndarray, y: np.ndarray, ridge: float) -> tuple[np.ndarray, float, float]:
    """Ridge least squares of ``y`` on ``x`` (intercept free): (coefficients, residual
    standard deviation, Gaussian NLL)."""
    pen = ridge * np.eye(x.shape[1])
    pen[0, 0] = 0.0
    beta = np.linalg.solve(x.T @ x + pen, x.T @ y)
    res = y - x @ beta
    sigma = float(np.sqrt(np.mean(res * res)))
    nll = 0.5 * len(y) * (1.0 + math.log(2 * math.pi * sigma * sigma))
    return beta, sigma, nll


def _design_for(t: Tracks, size_max: float, ref: float) -> np.ndarray:
    return _design(t.feats, 1.0, size_max, ref)


def sides(t: Tracks) -> np.ndarray:
    """The frames' ``side`` (the sine of the road user's heading relative to the line of
    sight; 0 in frames recorded before it was stored)."""
    return np.asarray([f.side for f in t.feats], dtype=float)


#: Close range [m]: the check's first distance band (:mod:`sitcov.calibration._frame_check`).
NEAR_M = 10.0
#: Extra logit terms (:func:`extra_columns`): ``side`` the side's sine, split by the check's
#: distance bands (``side_near`` < 10 m, ``side_mid`` 10-20 m, ``side_far`` >= 20 m) or
#: times the box's offset from the image centre (``side_offset``); ``lane`` the run's
#: approach (+1 left: the near lane, -1 right: the far lane; :attr:`Tracks.approach`) and
#: that at close range (``lane_near``), or one level each for the left and the right
#: (``from_left``, ``from_right``: ahead is the reference); ``near`` an intercept below
#: :data:`NEAR_M`, ``offset_near``/``trunc_near`` the offset and the truncation there
#: (their gain at close range apart from the one at every range); ``trunc_side`` the
#: truncation times ``side`` (a road user cut by the image's left edge from one cut by
#: its right); ``cut`` a ramp from 0 to 1 over the first :data:`CUT_RAMP` of truncation (a
#: road user cut by the image edge at all: its detected scores sit higher than the
#: truncation's linear term says, docs/pem.md, "The lower tail"); ``trunc_hinge<N>`` the
#: truncation past ``N`` % (``max(0, trunc - N / 100)``: a bend of the truncation term,
#: measured, no PEM parameter; docs/pem.md, "The car cut by the image edge, again");
#: ``cut_hinge<N>`` the ``cut`` ramp times the size hinge ``max(0, ln(h / N))`` (a large
#: box cut by the edge apart from a small one; measured, no PEM parameter; docs/pem.md,
#: "Which frames the car is fitted on"); ``vis_hinge<N>`` the size hinge of the visible
#: box's size (``h sqrt(1 - trunc)``) less that of the whole box's (the hinge as the
#: image shows the box; measured, as ``cut_hinge``); ``cut_tent<N>`` the ``cut`` ramp
#: times a tent in the log box height, ``max(0, 1 - |ln(h / N)| / ln 2)`` (a mid-size box
#: cut by the edge: the PEM parameter ``cut_tent_gain`` at ``N`` = 220, ``CUT_TENT_PX``;
#: docs/pem.md, "The mid-size cut car"); ``head_on`` a car seen from the front within
#: ``HEAD_ON_DEG`` of head-on on a box of ``HEAD_ON_PX`` times a tent in the view angle, 1
#: head-on (the PEM parameter ``head_on_gain``: :func:`head_on_column`); ``size3`` the cube of
#: the log apparent size; ``hinge<N>`` (any whole ``N`` px, e.g. ``hinge40``) the hinge
#: ``max(0, ln(h / N))`` of the box height ``h`` [px] (unclamped: a piecewise-linear
#: bend of the size term at ``N`` px, which the quadratic in the clamped log size cannot
#: make), ``view_hinge<N>`` that hinge times the sine of the view angle (the bend seen
#: side-on), ``size``/``size2`` the clamped log
#: size and its square (the logit has them already: only as detection terms). Any name
#: prefixed ``det_`` (``det_size``, ``det_hinge40``) is that column in the detection
#: term's probit only (:func:`is_detection_term`), not in the score's mean: the SSD's
#: chance of giving a box at all need not follow the box size as its score does.
#: ``rain`` is minus the rain noise (its gain adds to ``rain_gain``), ``rain_wind`` the
#: run's precipitation times its wind (fractions; 0 for a sweep frame, which varies one
#: weather element at a time, and a run without weather values) and ``rain_wind_size``
#: that times the clamped log size: the wind that slants the rendered rain streaks
#: (``benchmarks/pem_rain_wind.py``; docs/pem.md, "The wind in the rain, on frames";
#: measured, no PEM parameter).
EXTRA_TERMS = ("side", "side_near", "side_mid", "side_far", "side_offset", "lane",
               "lane_near", "from_left", "from_right", "near", "offset_near", "trunc_near",
               "trunc_side", "cut", "trunc_hinge<N>", "cut_hinge<N>", "vis_hinge<N>",
               "cut_tent<N>", "head_on", "size3", "hinge<N>", "view_hinge<N>", "size",
               "size2", "rain", "rain_wind", "rain_wind_size", "det_<term>")  # fmt: skip


def is_detection_term(name: str) -> bool:
    """Whether the extra term ``name`` enters the detection term only (``det_`` prefix)."""
    return name.startswith("det_")


def near_of(t: Tracks) -> np.ndarray:
    """1 for a frame closer than :data:`NEAR_M` (a recorded distance), else 0."""
    return ((t.distance >= 0.0) & (t.distance < NEAR_M)).astype(float)


def extra_columns(t: Tracks, x: np.ndarray, names: Sequence[str]) -> np.ndarray:
    """The extra terms ``names`` (:data:`EXTRA_TERMS`) per frame (rows), ``x`` the frames'
    design (:func:`sitcov.calibration._calibrate._design`: its 2nd column is the log size,
    its 14th minus the offset)."""
    if not names:
        return np.zeros((len(t.score), 0))
    side, d = sides(t), t.distance
    appr = t.approach if t.approach is not None else np.zeros(len(d))
    near = near_of(t)
    cols = {
        "side": lambda: side,
        "side_near": lambda: side * near,
        "side_mid": lambda: side * ((d >= NEAR_M) & (d < 2 * NEAR_M)),
        "side_far": lambda: side * (d >= 2 * NEAR_M),
        "side_offset": lambda: side * -x[:, 13],
        "lane": lambda: appr,
        "lane_near": lambda: appr * near,
        "from_left": lambda: appr == 1.0,
        "from_right": lambda: appr == -1.0,
        "near": lambda: near,
        "offset_near": lambda: -x[:, 13] * near,
        "trunc_near": lambda: -x[:, 8] * near,
        "trunc_side": lambda: -x[:, 8] * side,
        "cut": lambda: _cut_ramp(x),
        "head_on": lambda: head_on_column(t),
        "size3": lambda: x[:, 1] ** 3,
        "size": lambda: x[:, 1],
        "size2": lambda: x[:, 2],
        "rain": lambda: np.asarray([-f.rain_noise for f in t.feats], dtype=float),
        "rain_wind": lambda: t.rain_wind if t.rain_wind is not None else np.zeros(len(d)),
        "rain_wind_size": lambda: (t.rain_wind if t.rain_wind is not None else 0.0) * x[:, 1],
    }
    heights = None  # the box heights [px], read once for the size hinges
    for name in names:
        if name.startswith("det_"):  # the same column, in the detection term only
            cols[name] = lambda n=name[4:]: extra_columns(t, x, (n,))[:, 0]
            continue
        if name.startswith("trunc_hinge") and name[11:].isdigit():
            cols[name] = lambda k=int(name[11:]) / 100.0: np.maximum(0.0, -x[:, 8] - k)
            continue
        prefix, knot = _hinge_knot(name)
        if prefix is not None:
            if heights is None:
                heights = np.asarray([f.height_px for f in t.feats], dtype=float)
            cols[name] = lambda p=prefix, n=knot, h=heights: _hinge_column(p, n, h, x)
        if name not in cols:
            raise SitcovError(f"unknown extra term {name!r}; expected one of {EXTRA_TERMS}")
    return np.column_stack([np.asarray(cols[n](), dtype=float) for n in names]).reshape(
        len(d), len(names)
    )


#: The size terms' name prefixes (each followed by a whole knot ``N`` > 0 [px]): the
#: three that end in ``hinge`` before ``hinge`` itself.
_HINGE_PREFIXES = ("view_hinge", "cut_hinge", "vis_hinge", "hinge", "cut_tent")


def head_on_column(t: Tracks) -> np.ndarray:
    """Per frame of ``t``: ``max(0, 1 - view / HEAD_ON_DEG)`` for a car seen from the front
    (``facing`` < 0) on a box of ``HEAD_ON_PX`` [px] (from the lower bound to below the
    upper), else 0: what the PEM's ``head_on_gain`` multiplies (its logit computes it
    per frame the same way)."""
    view = np.asarray([f.view_angle for f in t.feats], dtype=float)
    front = np.asarray([f.facing < 0.0 for f in t.feats], dtype=bool)
    h = np.asarray([f.height_px for f in t.feats], dtype=float)
    inside = front & (h >= HEAD_ON_PX[0]) & (h < HEAD_ON_PX[1])
    return np.where(inside, np.maximum(0.0, 1.0 - view / math.radians(HEAD_ON_DEG)), 0.0)


def _hinge_knot(name: str) -> tuple[str | None, int]:
    """(prefix, knot) of a size-hinge term's name (:data:`_HINGE_PREFIXES`), or (None, 0)
    for any other name or a knot that is not a whole number above 0."""
    for prefix in _HINGE_PREFIXES:
        if name.startswith(prefix):
            knot = name[len(prefix) :]
            return (prefix, int(knot)) if knot.isdigit() and int(knot) > 0 else (None, 0)
    return None, 0


def _cut_ramp(x: np.ndarray) -> np.ndarray:
    """The ``cut`` ramp per frame of the design ``x`` (its 9th column minus the
    truncation): 0 for a whole box, 1 past :data:`CUT_RAMP` of truncation."""
    return np.minimum(1.0, -x[:, 8] / CUT_RAMP)


def _size_hinge(h: np.ndarray, knot: float) -> np.ndarray:
    """``max(0, ln(h / knot))`` of the box heights ``h`` [px]: a bend of the size term."""
    return np.maximum(0.0, np.log(np.maximum(h, 1e-9) / knot))


def _hinge_column(prefix: str, knot: int, h: np.ndarray, x: np.ndarray) -> np.ndarray:
    """The size-hinge term ``prefix`` + ``knot`` per frame (:data:`EXTRA_TERMS`): the
    hinge itself, times the sine of the view angle, times the ``cut`` ramp, or the hinge
    of the visible size less the whole box's; or the ``cut`` ramp times a tent at the
    knot (``cut_tent``)."""
    if prefix == "cut_tent":
        far = np.abs(np.log(np.maximum(h, 1e-9) / knot))
        return _cut_ramp(x) * np.maximum(0.0, 1.0 - far / math.log(2.0))
    hinge = _size_hinge(h, knot)
    if prefix == "view_hinge":
        return -x[:, 4] * hinge  # the sine of the view angle (side-on: 1)
    if prefix == "cut_hinge":
        return _cut_ramp(x) * hinge
    if prefix == "vis_hinge":
        return _size_hinge(h * np.sqrt(np.clip(1.0 + x[:, 8], 1e-6, 1.0)), knot) - hinge
    return hinge


def geometry(t: Tracks) -> np.ndarray:
    """The detection term's geometry per frame (rows): truncation and ``fill``
    (:func:`sitcov.perception._pem.fill_of` for the default camera's width)."""
    from sitcov.perception._base import CameraSpec
    from sitcov.perception._pem import fill_of

    width = float(CameraSpec().width)
    return np.asarray(
        [(f.truncation, fill_of(f.width_px, width)) for f in t.feats], dtype=float
    ).reshape(-1, 2)


def scale_size(t: Tracks, size_ref: float, cap: float) -> np.ndarray:
    """The log box height the score noise's scale follows per frame (``ln(h / size_ref)``,
    ``h`` clamped to [1 px, ``cap``]: :func:`sitcov.perception._pem.noise_scale`)."""
    h = np.asarray([f.height_px for f in t.feats], dtype=float)
    return np.log(np.clip(h, 1.0, cap) / size_ref)


def _observed(t: Tracks) -> tuple[np.ndarray, np.ndarray]:
    """(logit score, observed) per frame; a score >= 1 - 1e-6 counts as 1 - 1e-6."""
    obs = t.score >= CENSOR
    y = _logit(np.clip(np.where(obs, t.score, 0.5), CENSOR, 1.0 - 1e-6))
    return y, obs


# --- step 2: tracks as sequences (forward filter on a grid of the AR state) -------------------


def _grid(noise: Noise) -> tuple[np.ndarray, np.ndarray]:
    """Nodes and prior weights of the AR state; one node (0) when nothing depends on it
    (independent frames: no AR share, no detection term on it)."""
    if noise.share <= 0.0 and noise.lam == 0.0:
        return np.zeros(1), np.ones(1)
    u = np.linspace(-4.0, 4.0, GRID_NODES)
    p = np.exp(-0.5 * u * u)
    return u, p / p.sum()


def _kernel(u: np.ndarray, rho: float) -> np.ndarray:
    """Row-stochastic transition of the unit AR(1) state over one step of coefficient rho."""
    sd = math.sqrt(max(1e-12, 1.0 - rho * rho))
    k = np.exp(-0.5 * ((u[None, :] - rho * u[:, None]) / sd) ** 2)
    return k / k.sum(axis=1, keepdims=True)


def _kernels(u: np.ndarray, rho: np.ndarray) -> np.ndarray:
    """:func:`_kernel` for each coefficient of ``rho`` (an array: one kernel each)."""
    sd = np.sqrt(np.maximum(1e-12, 1.0 - rho * rho))[:, None, None]
    k = np.exp(-0.5 * ((u[None, None, :] - rho[:, None, None] * u[None, :, None]) / sd) ** 2)
    return k / k.sum(axis=2, keepdims=True)


#: The box height [px] from which the windy rain's upper-scale term acts (``Noise.uw_px``,
#: PEM ``noise_up_rain_wind_px``): profiled at 60 and 100 px on the car's frames, 100 the
#: better on every file (``benchmarks/pem_rain_wind.py``; docs/pem.md, "The wind in the
#: rain, on frames").
UP_WIND_PX = 100.0
#: The held term of the upper scale's gain in windy rain on a box of :data:`UP_WIND_PX` or
#: more (``Noise.uw``).
UP_RAIN_WIND = "up_rain_wind"
#: The held term of the AR part's size gain of its time constant (``Noise.kt``), fitted
#: with the AR coefficient by the sequence likelihood (:func:`fit_tau_size`): the only
#: held term the frames-alone likelihood cannot see.
TAU_SIZE = "tau_size"
#: The held term of the score's ceiling (``Noise.cl``, ``cg``, ``cs``), its three
#: parameters fitted together by the frames-alone likelihood (:func:`fit_ceiling`).
CEILING = "ceiling"
#: Held terms of the score noise rather than of the logit (:func:`fit_held_terms`) and
#: their PEM parameter (the ceiling's: the one that switches it on).
NOISE_HELD_TERMS = {UP_RAIN_WIND: "noise_up_rain_wind_gain", TAU_SIZE: "noise_tau_size_gain",
                    CEILING: "noise_ceiling_slope"}  # fmt: skip


@dataclass(frozen=True)
class Noise:
    """The model's noise and detection terms (module docstring): ``sigma`` the logit
    score's noise scale below its median, ``up`` the scale above it over ``sigma``,
    ``share`` the AR part's share of the unit latent noise, ``rho`` the AR coefficient per
    frame; detection ``P = Phi(d0 + d1 * m - dt * trunc - df * fill + lam * a_t)``;
    ``sigma`` grows as ``(h / size_ref) ** k`` with the box height ``h`` clamped to
    ``cap`` [px] (:func:`_scale`); a share ``po`` of frames are outliers, whose logit
    score is the mean plus ``ro`` times the frame's scale times a fresh N(0, 1)
    (independent of the AR state; PEM ``noise_outlier_share``/``_ratio``); the scale
    above the median is ``sigma * up * (h / size_ref) ** (k + ku)`` (``ku`` the upper
    side's own size gain, PEM ``noise_up_size_gain``); below ``LOW_TAIL_KNEE`` standard
    units under the median the latent noise ``n`` acts as ``n - tl (n + LOW_TAIL_KNEE) ** 2``
    (``tl`` the lower tail's curvature, PEM ``noise_low_tail``; :func:`_ginv`); above
    the knot ``kb_at`` (on the axis of :func:`scale_size`: ``ln(knot_px / size_ref)``)
    the size gain ``k`` becomes ``k + kb`` (PEM ``noise_bend_gain``, ``noise_bend_px``);
    on a box at least ``uw_px`` high the scale above the median is further times
    ``exp(uw * rain_wind)`` (the run's precipitation times its wind, :func:`wind_column`;
    PEM ``noise_up_rain_wind_gain``, ``noise_up_rain_wind_px``); a step of ``g`` frames
    into a frame of log size ``s`` (:func:`scale_size`) has the AR coefficient ``rho **
    (g exp(kt s))`` (PEM ``noise_tau_size_gain``: a close box's noise forgets faster);
    above the median, a logit offset past the knee ``max(cl + cg s - m, 0)`` (``m`` the
    frame's logit) grows ``cs`` times as fast (the score's ceiling, :func:`_knee`; PEM
    ``noise_ceiling_logit``, ``_size_gain``, ``_slope``; ``cs`` 1: none)."""

    sigma: float
    share: float
    rho: float
    d0: float = 8.0
    d1: float = 0.0
    lam: float = 0.0
    up: float = 1.0
    dt: float = 0.0
    df: float = 0.0
    k: float = 0.0
    cap: float = 450.0
    kn: float = 0.0
    po: float = 0.0
    ro: float = 1.0
    ku: float = 0.0
    tl: float = 0.0
    kb: float = 0.0
    kb_at: float = 0.0
    uw: float = 0.0
    uw_px: float = UP_WIND_PX
    kt: float = 0.0
    cl: float = 0.0
    cg: float = 0.0
    cs: float = 1.0


#: The log curvature at or below which the tail is off (0): its value while the rest of
#: the model is fitted first (:func:`_with_tail`).
TAIL_OFF = -12.0
#: Most evaluations of the derivative-free polish after the tail's profile (Powell: the
#: frames-alone likelihood's steps stop L-BFGS-B's first line search there).
TAIL_POLISH_EVALS = 3000


def _scale(
    noise: Noise, size: np.ndarray | None, near: np.ndarray | None = None
) -> np.ndarray | float:
    """The score noise's scale below the median per frame: ``sigma * exp(k * size + kb *
    max(0, size - kb_at) + kn * near)``, ``size`` the frames' log box height
    (:func:`scale_size`), ``near`` 1 at close range (:func:`near_of`); ``sigma`` alone
    when ``k``, ``kb`` and ``kn`` are 0 or their arrays not given."""
    sig: np.ndarray | float = noise.sigma
    if noise.k != 0.0 and size is not None:
        sig = sig * np.exp(noise.k * size)
    if noise.kb != 0.0 and size is not None:
        sig = sig * np.exp(noise.kb * np.maximum(0.0, size - noise.kb_at))
    if noise.kn != 0.0 and near is not None:
        sig = sig * np.exp(noise.kn * near)
    return sig


def _upper(
    noise: Noise, sig: np.ndarray | float, size: np.ndarray | None, wind: np.ndarray | None = None
) -> Any:
    """The score noise's scale above the median per frame: ``sig * up``, times ``exp(ku *
    size)`` with the upper size gain ``ku`` (``size`` the frames' :func:`scale_size`), times
    ``exp(uw * wind)`` in windy rain (``wind`` the frames' :func:`wind_column`)."""
    upper = sig * noise.up
    if noise.ku != 0.0 and size is not None:
        upper = upper * np.exp(noise.ku * size)
    if noise.uw != 0.0 and wind is not None:
        upper = upper * np.exp(noise.uw * wind)
    return upper


def wind_column(t: Tracks, noise: Noise) -> np.ndarray | None:
    """Per frame of ``t``, the run's ``rain_wind`` on a box at least ``noise.uw_px`` high
    and 0 on a lower one (what ``noise.uw`` multiplies, :func:`_upper`); None without a
    gain or a ``rain_wind`` column."""
    if noise.uw == 0.0 or t.rain_wind is None:
        return None
    h = np.asarray([f.height_px for f in t.feats], dtype=float)
    return np.where(h >= noise.uw_px, t.rain_wind, 0.0)


def _knee(noise: Noise, m: np.ndarray, size: np.ndarray | None) -> np.ndarray | None:
    """Per frame, how far above its logit ``m`` the score's ceiling bends the noise:
    ``max(cl + cg * size - m, 0)`` (``size`` the frames' :func:`scale_size`;
    :func:`sitcov.perception._pem.ceiling_knee`); None without a ceiling (``cs`` 1)."""
    if noise.cs == 1.0:
        return None
    level = noise.cl + (noise.cg * size if size is not None else 0.0)
    return np.maximum(level - m, 0.0)


def _ginv(
    v: np.ndarray, noise: Noise, sigma: np.ndarray | float | None = None, upper: Any = None,
    knee: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """The latent unit noise ``n`` whose score offset ``g(n)`` is ``v`` [logit] (``sigma``
    the scale below the median per frame, :func:`_scale`; ``noise.sigma`` if None;
    ``upper`` the scale above it, :func:`_upper`; ``sigma * noise.up`` if None; ``knee``
    the ceiling's per frame, :func:`_knee`, past which ``g`` grows ``noise.cs`` times as
    fast; None: no ceiling)."""
    sig = noise.sigma if sigma is None else sigma
    if knee is not None:
        v = np.where(v > knee, knee + (v - knee) / noise.cs, v)
    n = np.where(v < 0.0, v / sig, v / (sig * noise.up if upper is None else upper))
    if noise.tl != 0.0:  # beyond the knee, x - tl x**2 of the standard units x past it
        w = np.minimum(n + LOW_TAIL_KNEE, 0.0)
        x = (1.0 - np.sqrt(1.0 - 4.0 * noise.tl * w)) / (2.0 * noise.tl)
        n = np.where(w < 0.0, x - LOW_TAIL_KNEE, n)
    return n


def _slope(
    v: np.ndarray, n: np.ndarray, noise: Noise, sig: Any, upper: Any,
    knee: np.ndarray | None = None,
) -> Any:  # fmt: skip
    """d g(n) / d n per frame at the latent noise ``n`` of the logit offset ``v``."""
    slope = np.where(v < 0.0, sig, upper)
    if knee is not None:
        slope = np.where(v > knee, slope * noise.cs, slope)
    if noise.tl != 0.0:
        slope = slope * (1.0 - 2.0 * noise.tl * np.minimum(n + LOW_TAIL_KNEE, 0.0))
    return slope


def frames_alone_loglik(
    m: np.ndarray, y: np.ndarray, obs: np.ndarray, noise: Noise,
    geom: np.ndarray | None = None, size: np.ndarray | None = None,
    near: np.ndarray | None = None, det: np.ndarray | None = None,
    wind: np.ndarray | None = None,
) -> float:  # fmt: skip
    """Sum over frames of each frame's log-likelihood with its AR state integrated over
    the prior (:func:`frame_logliks` on the prior's grid): the frames-alone likelihood of
    the two-stage fit's stage 1 and of :meth:`FrameFit.marginal_loglik`."""
    from scipy.special import logsumexp

    u, prior = _grid(noise)
    le = frame_logliks(m, y, obs, u, noise, geom, size, near, det, wind)
    return float(np.sum(logsumexp(le + np.log(prior)[None, :], axis=1)))


def frame_logliks(
    m: np.ndarray, y: np.ndarray, obs: np.ndarray, u: np.ndarray, noise: Noise,
    geom: np.ndarray | None = None, size: np.ndarray | None = None,
    near: np.ndarray | None = None, det: np.ndarray | None = None,
    wind: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """Log-likelihood of each frame (rows) given the AR state at each grid node (columns);
    ``geom`` the frames' :func:`geometry` (needed when ``dt`` or ``df`` is not 0), ``size``
    their log apparent size (needed when ``k`` is not 0, :func:`_scale`), ``near`` their
    close-range flag (needed when ``kn`` is not 0), ``det`` a shift of the detection
    term's probit per frame (its extra terms, :func:`is_detection_term`; None: none),
    ``wind`` their :func:`wind_column` (needed when ``uw`` is not 0)."""
    from scipy.special import log_ndtr

    c = float(_logit(CENSOR))
    ra, re = math.sqrt(noise.share), math.sqrt(1.0 - noise.share)
    lin = noise.d0 + noise.d1 * m
    if geom is not None and (noise.dt != 0.0 or noise.df != 0.0):
        lin = lin - noise.dt * geom[:, 0] - noise.df * geom[:, 1]
    if det is not None:
        lin = lin + det
    det = lin[:, None] + noise.lam * u[None, :]
    log_det, log_miss = log_ndtr(det), log_ndtr(-det)
    v = y - m
    sig = _scale(noise, size, near)
    upper = _upper(noise, sig, size, wind)
    knee = _knee(noise, m, size)
    n = _ginv(v, noise, sig, upper, knee)
    slope = _slope(v, n, noise, sig, upper, knee)
    r = (n[:, None] - ra * u[None, :]) / re
    nc = _ginv(c - m, noise, sig, upper, knee)
    below = log_ndtr((nc[:, None] - ra * u[None, :]) / re)
    if noise.po > 0.0:
        seen, below = _with_outliers(v, c - m, sig, noise, r, re, slope, below)
        seen = log_det + seen
    else:  # (the operations in their order before outliers: the same bits)
        seen = log_det - 0.5 * r * r - math.log(re) - 0.5 * math.log(2 * math.pi)
        seen = seen - np.log(slope)[:, None]
    low = np.logaddexp(log_miss, log_det + below)
    return np.where(obs[:, None], seen, low)


def _with_outliers(
    v: np.ndarray, vc: np.ndarray, sig: np.ndarray | float, noise: Noise, r: np.ndarray,
    re: float, slope: np.ndarray, below: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """A frame's score law (log density of the logit score ``v`` above the mean, per AR
    node) and its log probability below the censoring point (``vc`` above the mean) as
    the mixture of the usual law (standardised residual ``r``, its frame part's scale
    ``re``, the split normal's ``slope``; ``below`` its censored part) and the outlier
    frames' wide normal (share ``noise.po``, scale ``noise.ro`` times the frame's ``sig``),
    which does not depend on the AR state."""
    from scipy.special import log_ndtr

    half_log_2pi = 0.5 * math.log(2 * math.pi)
    law = -0.5 * r * r - math.log(re) - half_log_2pi - np.log(slope)[:, None]
    wide = noise.ro * np.broadcast_to(np.asarray(sig, dtype=float), v.shape)
    out_law = -0.5 * (v / wide) ** 2 - np.log(wide) - half_log_2pi
    keep, share = math.log1p(-noise.po), math.log(noise.po)
    law = np.logaddexp(keep + law, share + out_law[:, None])
    below = np.logaddexp(keep + below, share + log_ndtr(vc / wide)[:, None])
    return law, below


def track_loglik(
    m: np.ndarray, y: np.ndarray, obs: np.ndarray, t: Tracks, noise: Noise,
    geom: np.ndarray | None = None, size: np.ndarray | None = None,
    near: np.ndarray | None = None, det: np.ndarray | None = None,
    wind: np.ndarray | None = None,
) -> np.ndarray:  # fmt: skip
    """Log-likelihood of each track (array over tracks, in track order): the forward
    filter over the AR state's grid; ``m`` the PEM logit per frame, ``y``/``obs`` the
    logit score and whether one >= CENSOR was recorded, ``geom`` the frames'
    :func:`geometry` (computed from ``t`` when the noise needs it and it is not given),
    ``size`` their log apparent size (for the noise's size gain ``k`` and the AR
    coefficient's ``kt``: needed then), ``wind`` their :func:`wind_column` (computed from
    ``t`` when the noise needs it and it is not given)."""
    if noise.kt != 0.0 and size is None:
        raise ValueError("track_loglik: the AR coefficient's size gain needs the frames' size")
    n_tracks = int(t.track.max()) + 1 if len(t.track) else 0
    u, prior = _grid(noise)
    if geom is None and (noise.dt != 0.0 or noise.df != 0.0):
        geom = geometry(t)
    if near is None and noise.kn != 0.0:
        near = near_of(t)
    if wind is None:
        wind = wind_column(t, noise)
    log_e = frame_logliks(m, y, obs, u, noise, geom, size, near, det, wind)
    starts = np.flatnonzero(np.r_[True, t.track[1:] != t.track[:-1]])
    lengths = np.diff(np.r_[starts, len(t.track)])
    order = np.argsort(-lengths, kind="stable")  # longest first: active tracks are a prefix
    starts, lengths = starts[order], lengths[order]
    ids = t.track[starts]
    out = np.zeros(n_tracks)
    alpha = np.tile(prior, (len(starts), 1))
    kernels: dict[int, np.ndarray] = {}
    for step in range(int(lengths.max()) if len(lengths) else 0):
        active = int(np.sum(lengths > step))
        idx = starts[:active] + step
        a = alpha[:active]
        if step > 0 and noise.kt != 0.0:  # a coefficient per frame (its box's size)
            steps = t.gap[idx] * np.exp(noise.kt * np.asarray(size)[idx])
            a = np.einsum("ti,tij->tj", a, _kernels(u, noise.rho**steps))
        elif step > 0:
            new = np.empty_like(a)
            gaps = t.gap[idx]
            for g in np.unique(gaps):
                sel = gaps == g
                if int(g) not in kernels:
                    kernels[int(g)] = _kernel(u, noise.rho ** int(g))
                new[sel] = a[sel] @ kernels[int(g)]
            a = new
        le = log_e[idx]
        top = le.max(axis=1, keepdims=True)
        a = a * np.exp(le - top)
        total = np.maximum(a.sum(axis=1), 1e-300)
        out[ids[:active]] += np.log(total) + top[:, 0]
        alpha[:active] = a / total[:, None]
    return out


@dataclass(frozen=True)
class FrameFit:
    """A fitted frame model: the logit's coefficients (``_LINEAR`` order), the size clamp
    and reference [px], the noise and detection terms, and the side's gain (0 without
    the side term)."""

    beta: np.ndarray
    size_max: float
    size_ref: float
    noise: Noise
    side_gain: float = 0.0
    extras: tuple[str, ...] = ()
    gains: tuple[float, ...] = ()

    def logit(self, t: Tracks) -> np.ndarray:
        """The PEM logit ``m`` of every frame of ``t``."""
        x = _design_for(t, self.size_max, self.size_ref)
        m = x @ self.beta + self.extra(t, x)
        return m + self.side_gain * sides(t) if self.side_gain != 0.0 else m

    def extra(
        self, t: Tracks, x: np.ndarray | None = None, detection: bool = False
    ) -> np.ndarray | float:
        """The extra terms' part of the logit per frame (0 without extra terms); with
        ``detection`` that of the terms in the detection term only (``det_``)."""
        pick = [i for i, n in enumerate(self.extras) if is_detection_term(n) == detection]
        if not pick:
            return 0.0
        x = _design_for(t, self.size_max, self.size_ref) if x is None else x
        names = tuple(self.extras[i] for i in pick)
        return extra_columns(t, x, names) @ np.asarray([self.gains[i] for i in pick])

    def _frame_inputs(self, t: Tracks) -> tuple[np.ndarray | None, np.ndarray | None]:
        """(the frames' log size when the noise reads it, the detection term's shift per
        frame when the fit has detection-only terms) of ``t``: what both likelihoods pass
        to the frame law besides the logit."""
        nz = self.noise
        needs_size = (nz.k != 0.0 or nz.ku != 0.0 or nz.kb != 0.0 or nz.kt != 0.0
                      or nz.cs != 1.0)  # fmt: skip
        size = scale_size(t, self.size_ref, nz.cap) if needs_size else None
        det = self.extra(t, detection=True)
        return size, None if np.isscalar(det) else np.asarray(det)

    def loglik(self, t: Tracks) -> float:
        """Sequence log-likelihood of ``t`` (every track)."""
        y, obs = _observed(t)
        size, det = self._frame_inputs(t)
        return float(track_loglik(self.logit(t), y, obs, t, self.noise, size=size, det=det).sum())

    def marginal_loglik(self, t: Tracks) -> float:
        """Frames-alone log-likelihood of ``t``: the sum over frames of each frame's
        log-likelihood with its AR state integrated over the prior (not filtered from the
        track's earlier frames). It scores each frame's law of (output, score), the
        marginal that P(score >= θ) per frame and the held-out check read, and not the
        law over consecutive frames (the AR share and coefficient do not enter it but
        through the detection term's correlation with the score noise)."""
        y, obs = _observed(t)
        geom, size, near, det = self.frames_alone_inputs(t)
        wind = wind_column(t, self.noise)
        return frames_alone_loglik(self.logit(t), y, obs, self.noise, geom, size, near, det, wind)

    def frames_alone_inputs(
        self, t: Tracks
    ) -> tuple[np.ndarray | None, np.ndarray | None, np.ndarray | None, np.ndarray | None]:
        """What :func:`frames_alone_loglik` takes of ``t`` besides the logit and scores,
        for this fit's noise: ``(geom, size, near, det)``, each None when the noise does
        not read it."""
        nz = self.noise
        size, det = self._frame_inputs(t)
        geom = geometry(t) if (nz.dt != 0.0 or nz.df != 0.0) else None
        near = near_of(t) if nz.kn != 0.0 else None
        return geom, size, near, det


def logistic(x: float, top: float = 1.0) -> float:
    """``top / (1 + exp(-x))`` without overflow: the optimiser may step an AR parameter to
    a large negative value (the seed-1 top-score frames did: ``math range error``); beyond
    |x| = 50 the value is 0 or ``top`` to float precision. Computed as the unclipped
    formula was (a division by ``1 + exp``), so every value below |x| = 50 has the same
    bits and fits that never went there are unchanged."""
    return top / (1.0 + math.exp(-min(50.0, max(-50.0, float(x)))))


def fit_tracks(
    t: Tracks, *, ridge: float, ar: bool, size_ref: float, edge: bool = False,
    scale: float | None = None, free_size: bool = False, side: bool = False,
    extras: Sequence[str] = (), near_noise: bool = False, extras_from_zero: bool = False,
    restarts: int = 0, starts: int = 1, stages: int = 1, outliers: bool = False,
    up_size: bool = False, low_tail: bool = False, noise_bend: float | None = None,
) -> FrameFit:  # fmt: skip
    """Steps 1 and 2 of the module docstring on ``t`` (``edge``: with the detection
    term's geometry gains dt and df; ``scale``: with the score noise's size gain k, the
    height capped at ``scale`` px, or at the fitted ``size_max_px`` for 0; ``free_size``:
    the three size terms' coefficients fitted in step 2 too, not only scaled with the
    others: the least squares of step 1 see only the scores above CENSOR, which bends
    the score's mean over distance; ``side``: with the term ``side_gain * side``, started
    from step 1's least squares and fitted by likelihood in step 2; ``extras``: the extra
    terms of :data:`EXTRA_TERMS`, the same way; ``near_noise``: the score noise's scale
    times ``exp(kn)`` at close range, :data:`NEAR_M`; ``extras_from_zero``: the extra
    terms' gains started at 0 and the rest where the model without them starts, not
    from step 1's least squares with them (which can start step 2 far from the nested
    model's optimum); ``restarts``: step 2's L-BFGS-B started again that many times from
    where it stopped, each kept only if it raised the likelihood (it stops on failed
    line searches; a restart drops its curvature memory); ``starts``: step 2 run from
    that many starts, the first as without the option, the others it moved by N(0, 0.3)
    in every parameter (a Generator seeded with the start's number), the best kept;
    ``stages``: 1 fits every parameter at once by the sequence likelihood, 2 in two
    stages (a composite likelihood, :func:`_two_stage`: the marginal parameters by the
    frames-alone likelihood, then the AR share and coefficient by the sequence likelihood
    with the per-frame marginal held; ``starts`` and ``restarts`` then act on stage 1);
    ``outliers``: with a share of outlier frames and their noise's scale ratio
    (``Noise.po``, ``Noise.ro``; started at 5 % and 3); ``up_size``: with the upper
    scale's own size gain (``Noise.ku``, started at 0; needs ``scale``); ``low_tail``: with
    the lower tail's curvature (``Noise.tl``), fitted after the rest has converged
    without it (:func:`_with_tail`); ``noise_bend``: with a change of the noise's size
    gain (``Noise.kb``, started at 0; needs ``scale``) above that many px (a fixed knot,
    as the size hinges' are; None: none).
    The defaults give the same bits as before these options."""
    from scipy.optimize import minimize

    y, obs = _observed(t)
    geom = geometry(t) if edge else None
    if int(np.sum(t.score >= FLOOR)) < 10:
        raise SitcovError(f"only {int(np.sum(t.score >= FLOOR))} frames detected at >= {FLOOR}")
    side_col = sides(t) if side else None
    if side_col is not None and not side_col.any():
        side_col = None  # frames recorded before ``side``: exactly the model without it
    best: tuple[float, np.ndarray, float, float, np.ndarray, np.ndarray] | None = None
    # the detection-only terms: not in the score's least squares, started at 0
    in_det = np.asarray(
        [False] * (side_col is not None) + [is_detection_term(n) for n in extras], dtype=bool
    )
    for size_max in SIZE_MAX_GRID:
        x = _design_for(t, size_max, size_ref)
        ex = extra_columns(t, x, extras)
        ex = ex if side_col is None else np.column_stack([side_col, ex])
        xs = np.column_stack([x, ex[:, ~in_det]]) if ex.shape[1] else x
        beta, sigma0, value = _ridge_ls(xs[obs], y[obs], ridge)
        if in_det.any():  # the score's terms as fitted, the detection terms at 0
            ls, beta = beta, np.zeros(x.shape[1] + len(in_det))
            beta[: x.shape[1]] = ls[: x.shape[1]]
            beta[x.shape[1] :][~in_det] = ls[x.shape[1] :]
        if extras_from_zero and extras:
            b, sigma0, value = _ridge_ls(x[obs], y[obs], ridge)
            beta = np.r_[b, beta[len(b) : len(b) + (side_col is not None)],
                         np.zeros(len(extras))]  # fmt: skip
        if best is None or value < best[0]:
            best = (value, beta, sigma0, size_max, x, ex)
    assert best is not None
    _, beta, sigma0, size_max, x, ex = best
    n_ex = ex.shape[1]
    ex0: list[float] = []
    if n_ex:  # the extra terms' start values; the others as without them
        ex0, beta = [float(b) for b in beta[-n_ex:]], beta[:-n_ex]
    near = near_of(t) if near_noise else None
    rest = x[:, 1:] @ beta[1:]
    sized = x[:, 1:4]  # size, size^2, sin(view) * size: _LINEAR's 2nd to 4th
    cap = (scale or size_max) if scale is not None else IMAGE_HEIGHT
    size = scale_size(t, size_ref, cap) if scale is not None else None

    def unpack(p: np.ndarray) -> tuple[float, float, Noise]:
        # p: b0, kappa, ln sigma, d0, d1, ln up [, share, rho, lam (ar)] [, dt, df (edge)]
        # [, k (scale)]
        up = math.exp(min(3.0, max(-5.0, p[5])))
        share = logistic(p[6], SHARE_MAX) if ar else 0.0
        rho = logistic(p[7], RHO_MAX) if ar else 0.0
        lam = p[8] if ar else 0.0
        at = 9 if ar else 6
        dt, df = (float(p[at]), float(p[at + 1])) if edge else (0.0, 0.0)
        at += 2 if edge else 0
        k = float(min(3.0, max(-3.0, p[at]))) if scale is not None else 0.0
        sigma = math.exp(min(3.0, max(-6.0, p[2])))
        return float(p[0]), float(p[1]), Noise(sigma, share, rho, float(p[3]), float(p[4]),
                                               float(lam), up, dt, df, k, cap)  # fmt: skip

    at_free = len(start_of(ar, edge, scale))
    at_side = at_free + (3 if free_size else 0)
    at_kn = at_side + n_ex

    def mean(p: np.ndarray, b0: float, kappa: float) -> np.ndarray:
        m = b0 + kappa * rest
        m = m + sized @ p[at_free : at_free + 3] if free_size else m
        if not n_ex:
            return m
        return m + ex[:, ~in_det] @ p[at_side:at_kn][~in_det]

    def det_shift(p: np.ndarray) -> np.ndarray | None:
        return ex[:, in_det] @ p[at_side:at_kn][in_det] if in_det.any() else None

    at_kb = at_kn + (1 if near_noise else 0)
    bend = noise_bend is not None
    at_out = at_kb + (1 if bend else 0)
    at_ku = at_out + (2 if outliers else 0)
    at_tl = at_ku + (1 if up_size else 0)
    if up_size and scale is None:
        raise SitcovError("the upper scale's size gain needs the noise's size term (scale)")
    if bend and (scale is None or up_size):
        raise SitcovError(
            "the noise's size bend needs the noise's size term (scale) and no upper size gain"
        )
    kb_at = math.log(noise_bend / size_ref) if noise_bend is not None else 0.0

    def with_kn(p: np.ndarray, noise: Noise) -> Noise:
        # the close-range factor and the outlier frames (shares capped at OUTLIER_MAX)
        if near_noise:
            noise = replace(noise, kn=float(min(3.0, max(-3.0, p[at_kn]))))
        if bend:
            noise = replace(noise, kb=float(min(3.0, max(-3.0, p[at_kb]))), kb_at=kb_at)
        if outliers:
            ratio = 1.0 + math.exp(min(4.0, max(-6.0, p[at_out + 1])))
            noise = replace(noise, po=logistic(p[at_out], OUTLIER_MAX), ro=ratio)
        if up_size:
            noise = replace(noise, ku=float(min(3.0, max(-3.0, p[at_ku]))))
        if low_tail:
            tl = math.exp(min(3.0, p[at_tl])) if p[at_tl] > TAIL_OFF else 0.0
            noise = replace(noise, tl=tl)
        return noise

    def nll(p: np.ndarray) -> float:
        b0, kappa, noise = unpack(p)
        m = mean(p, b0, kappa)
        noise = with_kn(p, noise)
        return -float(track_loglik(m, y, obs, t, noise, geom, size, near, det_shift(p)).sum())

    rate = float(np.clip(np.mean(obs), 0.02, 0.98))
    # start: no detection slope, a slightly narrower upper spread, an AR share of 0.7
    # and rho 0.8 (the car fit's neighbourhood: fewer iterations on a loaded machine)
    start = [beta[0], 1.0, math.log(sigma0), float(_ndtri(rate)), 0.0, -0.2]
    start += [0.85, 1.5, 0.5] if ar else []
    if edge:  # the detection terms from a probit of "output" on (1, m, trunc, fill)
        d0, d1, dt, df = _probit_start(x @ beta, obs, geom)
        start[3:5] = [d0, d1]
        start += [dt, df]
    start += [0.0] if scale is not None else []
    start += [0.0, 0.0, 0.0] if free_size else []
    start += ex0
    start += [0.0] if near_noise else []
    start += [0.0] if bend else []
    start += [math.log(0.05 / (OUTLIER_MAX - 0.05)), math.log(2.0)] if outliers else []
    start += [0.0] if up_size else []
    start += [TAIL_OFF] if low_tail else []

    def frames_nll(p: np.ndarray) -> float:  # every frame alone (stage 1)
        b0, kappa, noise = unpack(p)
        noise = with_kn(p, noise)
        m = mean(p, b0, kappa)
        return -frames_alone_loglik(m, y, obs, noise, geom, size, near, det_shift(p))

    two = stages == 2 and ar
    opts = {"maxiter": 150 if edge else 80, "ftol": 1e-6}
    if two:  # wide differences: the frames-alone likelihood's steps (SMOOTH_EPS)
        opts = {"maxiter": 400, "ftol": 1e-10, "eps": SMOOTH_EPS}
    # stage 1 (two stages): the AR share and coefficient held at their start (the
    # frames-alone likelihood does not see rho; the share only through lam * sqrt(share))
    fixed = np.zeros(len(start), dtype=bool)
    if two:
        fixed[6:8] = True
    if low_tail:  # first without the tail (it starts where the nested model ends)
        fixed[at_tl] = True
    full0 = np.asarray(start, dtype=float)

    def embed(q: np.ndarray) -> np.ndarray:
        p = full0.copy()
        p[~fixed] = q
        return p

    first = (lambda q: frames_nll(embed(q))) if two else nll

    def run(x0: np.ndarray) -> Any:
        return minimize(first, x0, method="L-BFGS-B", options=opts)

    res = run(full0[~fixed])
    for k in range(1, starts):
        moved = full0[~fixed] + np.random.default_rng(k).normal(0.0, 0.3, int((~fixed).sum()))
        other = run(moved)
        if other.fun < res.fun:
            res = other
    for _ in range(restarts):
        again = minimize(first, res.x, method="L-BFGS-B", options=opts)
        if again.fun < res.fun:
            res = again
    px = embed(res.x)
    if low_tail:  # the tail profiled from the optimum without it, then all freed
        px = _with_tail(px, at_tl, first, embed, fixed, res.fun)
    if two:
        det_at = [3, 4] + ([9, 10] if edge else [])
        det_at += [at_side + i for i in np.flatnonzero(in_det)]
        px = _two_stage(px, nll, det_at)
    b0, kappa, noise = unpack(px)
    noise = with_kn(px, noise)
    coef = np.r_[b0, kappa * beta[1:]]
    if free_size:
        coef[1:4] += px[at_free : at_free + 3]
    gains = [float(g) for g in px[at_side:at_kn]]
    gain = gains.pop(0) if side_col is not None else 0.0
    return FrameFit(coef, size_max, size_ref, noise, gain, tuple(extras), tuple(gains))


#: The gains :func:`fit_held_terms` tries first for each held term [logit], the smaller
#: first (a tie keeps the smaller).
HELD_GRID = np.asarray(sorted(np.round(np.arange(-1.0, 1.0001, 0.02), 2), key=abs))


def fit_held_terms(fit: FrameFit, t: Tracks, names: Sequence[str]) -> FrameFit:
    """``fit`` with the extra terms ``names`` (:data:`EXTRA_TERMS`, or a noise term of
    :data:`NOISE_HELD_TERMS`) added, their gains fitted by the frames-alone likelihood of
    ``t`` with every other parameter held (each gain the best of :data:`HELD_GRID` with
    the others at 0, then Powell's search from there; 0, the grid's best or the search's
    end, whichever is best).

    Why held: a term fitted with the rest can be traded away. The mid-size car cut by
    the image edge scores higher than the logit says, but a joint fit moved the
    truncation's and the detection term's gains instead, and the close cells did not
    move (docs/pem.md, "The mid-size cut car"). Fitted after, the term takes only what
    the chosen model leaves unexplained; it cannot make the fit worse on ``t`` (0 is
    where the search starts)."""
    from scipy.optimize import minimize

    names = tuple(names)
    if not names:
        return fit
    for alone, fitter in ((TAU_SIZE, fit_tau_size), (CEILING, fit_ceiling)):
        if alone in names:
            if len(names) > 1:
                raise SitcovError(f"{alone} is fitted alone (held terms one at a time)")
            return fitter(fit, t)
    clash = [n for n in names if n in fit.extras]
    if UP_RAIN_WIND in names and fit.noise.uw != 0.0:
        clash.append(UP_RAIN_WIND)
    if clash:
        raise SitcovError(f"held terms {clash} are already terms of the fit")
    y, obs = _observed(t)
    geom, size, near, det0 = fit.frames_alone_inputs(t)
    in_noise = np.asarray([n in NOISE_HELD_TERMS for n in names], dtype=bool)
    logit_names = tuple(n for n in names if n not in NOISE_HELD_TERMS)
    cols = extra_columns(t, _design_for(t, fit.size_max, fit.size_ref), logit_names)
    in_det = np.asarray([is_detection_term(n) for n in logit_names], dtype=bool)
    m0 = fit.logit(t)
    # the windy rain's column at the gain 1 (the gain enters the noise, not the column)
    wind = wind_column(t, replace(fit.noise, uw=1.0)) if in_noise.any() else None

    def noise_at(g: np.ndarray) -> Noise:
        return replace(fit.noise, uw=float(g[in_noise][0])) if in_noise.any() else fit.noise

    def nll(g: np.ndarray) -> float:
        gl = g[~in_noise]
        m = m0 + cols[:, ~in_det] @ gl[~in_det]
        det = det0
        if in_det.any():
            det = (0.0 if det0 is None else det0) + cols[:, in_det] @ gl[in_det]
        noise = noise_at(g)
        return -frames_alone_loglik(m, y, obs, noise, geom, size, near, det, wind)

    # the likelihood is not smooth at this scale (a 0.02 step can lose 0.1 where a local
    # search stops): each gain from a grid with the others at 0, then all from there
    zero = np.zeros(len(names))
    start = zero.copy()
    for i in range(len(names)):
        trial = [np.where(np.arange(len(names)) == i, g, 0.0) for g in HELD_GRID]
        start[i] = HELD_GRID[int(np.argmin([nll(g) for g in trial]))]
    res = minimize(nll, start, method="Powell", options={"xtol": 1e-3, "ftol": 1e-9})
    best = min((zero, start, np.atleast_1d(res.x)), key=nll)
    return replace(fit, noise=noise_at(best), extras=fit.extras + logit_names,
                   gains=fit.gains + tuple(float(g) for g in best[~in_noise]))  # fmt: skip


#: The ceiling's starts of :func:`fit_ceiling`: its logit at the reference size, its size
#: gain and its slope past the knee (the slope through a logistic, so it stays in (0, 1)).
CEILING_GRID = ((-0.5, 0.0, 0.5), (0.0, 0.25, 0.5), (0.2, 0.5))


def fit_ceiling(fit: FrameFit, t: Tracks) -> FrameFit:
    """``fit`` with the score's ceiling (the held term :data:`CEILING`: ``Noise.cl``,
    ``cg``, ``cs``) fitted by the frames-alone likelihood of ``t``, every other parameter
    held: the best start of :data:`CEILING_GRID`, then Powell's search from it; no ceiling
    (``cs`` 1) if neither is better. Past the knee the slope ``cs`` stays in (0, 1): a
    ceiling bends the upper tail down, never up."""
    from scipy.optimize import minimize

    if fit.noise.cs != 1.0:
        raise SitcovError(f"held terms ['{CEILING}'] are already terms of the fit")
    y, obs = _observed(t)
    m = fit.logit(t)
    geom, _, near, det = fit.frames_alone_inputs(t)
    size = scale_size(t, fit.size_ref, fit.noise.cap)
    wind = wind_column(t, fit.noise)

    def noise_at(x: Sequence[float]) -> Noise:
        slope = min(logistic(x[2]), 0.999999)  # past |x| = 50 it is 0 or 1: kept under 1
        return replace(fit.noise, cl=float(x[0]), cg=float(x[1]), cs=slope)

    def nll(x: Sequence[float]) -> float:
        return -frames_alone_loglik(m, y, obs, noise_at(x), geom, size, near, det, wind)

    without = -frames_alone_loglik(m, y, obs, fit.noise, geom, size, near, det, wind)
    starts = [np.asarray(x, dtype=float) for x in itertools.product(*CEILING_GRID)]
    start = min(starts, key=nll)
    res = minimize(nll, start, method="Powell", options={"xtol": 1e-3, "ftol": 1e-10})
    best = min((start, np.asarray(res.x, dtype=float)), key=nll)
    if nll(best) >= without:
        return fit
    return replace(fit, noise=noise_at(best))


def fit_tau_size(fit: FrameFit, t: Tracks) -> FrameFit:
    """``fit`` with the AR coefficient's size gain ``kt`` (the held term :data:`TAU_SIZE`)
    and the coefficient ``rho`` (at the reference size) fitted by the sequence likelihood
    of ``t`` (:func:`track_loglik`), every other parameter held: the gain first on
    :data:`TAU_GRID` (``rho`` fitted at each), then both by Powell's search from the best;
    0 and the fit's own ``rho`` if nothing is better. A frame's own law does not depend
    on either, so the frames-alone likelihood (:func:`fit_held_terms`'s) cannot fit them."""
    from scipy.optimize import minimize

    if fit.noise.kt != 0.0:
        raise SitcovError(f"held terms ['{TAU_SIZE}'] are already terms of the fit")
    if fit.noise.share <= 0.0:
        return fit  # no AR part: nothing to correlate
    nll = persistence_nll(fit, t)
    kept = (nll(fit.noise.rho, 0.0), fit.noise.rho, 0.0)
    grid = [(*best_rho(nll, kt), kt) for kt in TAU_GRID]
    start = min(grid)
    res = minimize(lambda x: nll(min(0.995, max(0.05, x[0])), x[1]), [start[1], start[2]],
                   method="Powell", options={"xtol": 1e-4, "ftol": 1e-10})  # fmt: skip
    end = (float(res.fun), min(0.995, max(0.05, float(res.x[0]))), float(res.x[1]))
    _, rho, kt = min(kept, start, end)
    return replace(fit, noise=replace(fit.noise, rho=rho, kt=kt))


def persistence_nll(fit: FrameFit, t: Tracks) -> Any:
    """``nll(rho, kt)``: minus the sequence log-likelihood of ``t`` under ``fit`` with the
    AR coefficient ``rho`` (at the reference size) and its size gain ``kt``, every other
    parameter held (the frames' logit, size and detection shift computed once)."""
    y, obs = _observed(t)
    m = fit.logit(t)
    size = scale_size(t, fit.size_ref, fit.noise.cap)
    det = fit._frame_inputs(t)[1]

    def nll(rho: float, kt: float) -> float:
        noise = replace(fit.noise, rho=rho, kt=kt)
        return -float(track_loglik(m, y, obs, t, noise, size=size, det=det).sum())

    return nll


def best_rho(nll: Any, kt: float) -> tuple[float, float]:
    """``(nll, rho)`` at the AR coefficient that minimises ``nll(rho, kt)``
    (:func:`persistence_nll`) for the size gain ``kt``: a bounded search on [0.05, 0.995]."""
    from scipy.optimize import minimize_scalar

    res = minimize_scalar(lambda r: nll(r, kt), bounds=(0.05, 0.995), method="bounded",
                          options={"xatol": 1e-4})  # fmt: skip
    return float(res.fun), float(res.x)


#: The size gains of the AR coefficient :func:`fit_tau_size` tries first.
TAU_GRID = (-0.25, 0.0, 0.25, 0.5)


def _with_tail(
    px: np.ndarray, at: int, first: Any, embed: Any, fixed: np.ndarray, without: float
) -> np.ndarray:
    """The lower tail's fit (:func:`fit_tracks` with ``low_tail``): from ``px``, the
    optimum with the tail off (objective ``without``), the log curvature (entry ``at``)
    alone on a bounded scalar search, then every free parameter from there by Powell's
    derivative-free search (``first``, ``embed`` and ``fixed`` as :func:`fit_tracks` made
    them): the frames-alone likelihood's steps stop L-BFGS-B's first line search when
    the tail is freed, and a gradient search with the tail from the start stalls short
    of the model without it (the pedestrian's seed-1 frames: 8 iterations, -376 against
    -445). The best of the three."""
    from scipy.optimize import minimize, minimize_scalar

    def at_tail(a: float) -> np.ndarray:
        p = px.copy()
        p[at] = a
        return p

    fixed[at] = False  # ``first`` now takes the tail among the free entries
    profile = minimize_scalar(lambda a: first(at_tail(a)[~fixed]), bounds=(-6.0, 1.0),
                              method="bounded", options={"xatol": 0.05})  # fmt: skip
    best, value = px, without
    if profile.fun < value:
        best, value = at_tail(float(profile.x)), float(profile.fun)
    again = minimize(first, best[~fixed], method="Powell",
                     options={"maxfev": TAIL_POLISH_EVALS, "xtol": 1e-3, "ftol": 1e-7})  # fmt: skip
    return embed(again.x) if again.fun < value else best


def _two_stage(p: np.ndarray, nll: Any, det_at: Sequence[int]) -> np.ndarray:
    """Stage 2 of the two-stage fit (:func:`fit_tracks` with ``stages=2``): the AR share
    ``s`` and coefficient ``rho`` by the sequence likelihood ``nll`` from the stage-1
    parameter vector ``p`` (its entries 6, 7, 8 the share, rho and detection AR gain
    ``lam`` as :func:`fit_tracks` packs them; ``det_at`` the detection probit's linear
    coefficients), with every frame's marginal held.

    A frame's marginal law depends on the share and ``lam`` only through the detection
    probit's total variance ``1 + lam**2`` and its correlation with the score noise,
    ``c = lam sqrt(s) / sqrt(1 + lam**2)`` (the probit's latent ``d + lam a + N(0, 1)``,
    the score noise ``sqrt(s) a + sqrt(1 - s) e``; ``rho`` does not enter). So for a new
    share ``s > c**2`` the detection AR gain is ``lam = c / sqrt(s - c**2)`` and the
    probit's linear coefficients are scaled by ``sqrt(1 + lam**2) / sqrt(1 + lam1**2)``:
    the same detection probability and correlation in every frame, so the same
    P(score >= θ) per frame (:func:`sitcov.perception._pem.pass_probability`) as stage 1
    gave; only the law over consecutive frames changes."""
    from scipy.optimize import minimize

    s1 = logistic(p[6], SHARE_MAX)
    lam1 = float(p[8])
    c = lam1 * math.sqrt(s1) / math.sqrt(1.0 + lam1 * lam1)
    lo = c * c

    def full(q: np.ndarray) -> np.ndarray:
        a = min(30.0, max(-30.0, float(q[0])))
        s = lo + (SHARE_MAX - lo) / (1.0 + math.exp(-a))
        s = max(s, lo + 1e-9)
        lam = c / math.sqrt(s - lo)
        out = p.copy()
        out[6] = math.log(s / (SHARE_MAX - s))
        out[7] = q[1]
        out[8] = lam
        out[list(det_at)] = (
            p[list(det_at)] * math.sqrt(1.0 + lam * lam) / math.sqrt(1.0 + lam1 * lam1)
        )
        return out

    a0 = math.log((s1 - lo) / (SHARE_MAX - s1)) if s1 > lo else 0.0
    res = minimize(lambda q: nll(full(q)), np.asarray([a0, p[7]]), method="L-BFGS-B",
                   options={"maxiter": 60, "ftol": 1e-7})  # fmt: skip
    return full(res.x)


def fit_candidate(t: Tracks, candidate: Sequence[Any], size_ref: float, **opts: Any) -> FrameFit:
    """:func:`fit_tracks` of ``t`` as the candidate (:data:`CANDIDATES`,
    :data:`EXTRA_SETS`) says; ``opts`` are :func:`fit_tracks`'s optimiser options
    (``extras_from_zero``, ``restarts``, ``starts``, ``stages``)."""
    ridge, ar, edge, scale, free, side = _flags(candidate)
    extras, near_noise, outliers, up_size, low_tail, bend = _extras(candidate)
    return fit_tracks(t, ridge=ridge, ar=ar, size_ref=size_ref, edge=edge, scale=scale,
                      free_size=free, side=side, extras=extras, near_noise=near_noise,
                      outliers=outliers, up_size=up_size, low_tail=low_tail,
                      noise_bend=bend, **opts)  # fmt: skip


def start_of(ar: bool, edge: bool, scale: float | None) -> list[int]:
    """Positions of step 2's parameters before the free size terms (their count)."""
    return list(range(6 + (3 if ar else 0) + (2 if edge else 0) + (scale is not None)))


def _probit_start(
    m: np.ndarray, obs: np.ndarray, geom: np.ndarray | None
) -> tuple[float, float, float, float]:
    """Start values of the detection term ``(d0, d1, dt, df)``: a probit of whether a
    score >= CENSOR was recorded on ``(1, m, -trunc, -fill)``, frames independent (the
    joint fit then adds the AR state; started at 0, the detection slope ``d1`` stays in
    the local optimum where it stands in for the missing geometry, negative)."""
    from scipy.optimize import minimize
    from scipy.special import log_ndtr

    g = np.zeros((len(m), 2)) if geom is None else geom
    x = np.column_stack([np.ones_like(m), m, -g[:, 0], -g[:, 1]])
    y = obs.astype(float)

    def nll(b: np.ndarray) -> float:
        z = x @ b
        return -float(np.sum(y * log_ndtr(z) + (1.0 - y) * log_ndtr(-z)))

    res = minimize(nll, np.zeros(4), method="BFGS")
    return float(res.x[0]), float(res.x[1]), float(res.x[2]), float(res.x[3])


def _ndtri(p: float) -> float:
    from scipy.special import ndtri

    return float(ndtri(p))


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
    candidates: Sequence[tuple[Any, ...]] = CANDIDATES,
    stages: int = 1,
    starts: int = 1,
) -> tuple[str, dict[str, Any]]:
    """The candidate with the best held-out log-likelihood (per held-out frame), over
    run-grouped folds: each fold's runs are left out of the fit and scored. ``stages``
    as :func:`fit_tracks`'s; with 2 the candidates are chosen by the frames-alone
    log-likelihood (:meth:`FrameFit.marginal_loglik`, ``heldout_marginal_loglik_per_frame``),
    else by the sequence's (``heldout_loglik_per_frame``); the table holds both.
    ``starts``: :func:`fit_tracks`'s."""
    table: dict[str, Any] = {}
    parts = _folds(t.group, folds)
    all_groups = np.unique(t.group)
    for cand in candidates:
        name = cand[0]
        total, marginal, frames = 0.0, 0.0, 0
        for held in parts:
            train = t.subset(np.setdiff1d(all_groups, held))
            test = t.subset(held)
            fit = fit_candidate(train, cand, size_ref, stages=stages, starts=starts)
            total += fit.loglik(test)
            marginal += fit.marginal_loglik(test)
            frames += len(test.score)
        table[name] = {"heldout_loglik_per_frame": round(total / max(1, frames), 4),
                       "heldout_marginal_loglik_per_frame": round(marginal / max(1, frames), 4),
                       "heldout_frames": frames}  # fmt: skip
    key = selector(stages)
    chosen = max(table, key=lambda k: table[k][key])
    return chosen, table


def selector(stages: int) -> str:
    """The model choice table's column that chooses (:func:`choose_model`): the
    frames-alone held-out log-likelihood for the two-stage fit, else the sequence's."""
    return "heldout_marginal_loglik_per_frame" if stages == 2 else "heldout_loglik_per_frame"


#: Kinds whose detection box is fitted with its mean edge offsets and a corner noise per
#: axis (:func:`box_offsets`): the cyclist, whose detections are its rider's box and its
#: bicycle's, inside the cyclist's (docs/pem.md, "The cyclist's detection is its rider",
#: "The cyclist's two detections"), and the
#: pedestrian, whose detected box is narrower than its projected one and scattered far
#: less up and down than across (docs/pem.md, "The pedestrian's box"). Cars keep the
#: jitter from the horizontal errors alone, as their file was fitted.
BOX_OFFSET_KINDS = ("pedestrian", "cyclist", "bicycle")
#: The PEM parameters of the box's mean edge offsets, in ``box_error``'s order.
BOX_EDGES = ("box_dx0", "box_dy0", "box_dx1", "box_dy1")


def box_offsets(frames: Sequence[Any]) -> dict[str, float] | None:
    """The detected box's mean edge offsets and corner noise from recorded frames' box
    errors (``RunFrame.box_error``: each edge's error over the true box's width or height)
    on the frames :func:`sitcov.calibration._calibrate._jitter` uses (boxes at least
    ``JITTER_MIN_WIDTH`` wide, not cut by the image edge): per edge the median error
    (``box_dx0``, ``box_dy0``, ``box_dx1``, ``box_dy1``), and per axis the median absolute
    deviation around it over 0.6745 (``jitter``: the left and right edges; ``jitter_y``:
    top and bottom), robust to the odd misplaced box. None with fewer than 20 frames."""
    from sitcov.calibration._calibrate import JITTER_MIN_WIDTH

    errs = np.asarray([
        f.box_error for f in frames
        if f.box_error is not None and f.width_px >= JITTER_MIN_WIDTH
        and f.features.truncation < 0.05
    ], dtype=np.float64).reshape(-1, 4)  # fmt: skip
    if len(errs) < 20:
        return None
    mid = np.median(errs, axis=0)
    dev = np.abs(errs - mid)
    out = {name: round(float(v), 4) for name, v in zip(BOX_EDGES, mid, strict=True)}
    out["jitter"] = round(float(np.median(dev[:, [0, 2]])) / 0.6745, 4)
    out["jitter_y"] = round(float(np.median(dev[:, [1, 3]])) / 0.6745, 4)
    return out


def to_params(
    fit: FrameFit, base: PEMParams, t: Tracks, runs: Sequence[Any], *, box: bool = False
) -> PEMParams:
    """The fit as PEM parameters (other fields from ``base``; jitter from the runs'
    matched boxes; ``size_min_px`` the :data:`MIN_PX_PERCENTILE` percentile of the box
    heights reported: below it the sensor reports nothing, above it the fitted logit,
    fitted down to 1 px, decides). Of the extra terms (:data:`EXTRA_TERMS`) only those
    of :data:`~sitcov.calibration._calibrate.EXTRA_TERM_PARAMS` have a PEM parameter: a
    fit with another is refused (one clear error). ``box``: the box's mean edge offsets
    and per-axis corner noise from the runs' matched boxes (:func:`box_offsets`;
    :data:`BOX_OFFSET_KINDS`) instead of the horizontal-error jitter."""
    other = [n for n in fit.extras if n not in EXTRA_TERM_PARAMS]
    if other or fit.noise.kn != 0.0:
        raise SitcovError(
            f"the PEM has no parameter for the extra terms {other}"
            + (" or the close-range noise factor" if fit.noise.kn != 0.0 else "")
            + " (sitcov/calibration/_frame_model.py EXTRA_SETS: measured, not shipped)"
        )
    values = {name: round(float(v), 4) for name, v in zip(_LINEAR, fit.beta, strict=True)}
    gains = dict(zip(fit.extras, fit.gains, strict=True))
    heights = np.asarray([f.height_px for f in t.feats])
    seen = heights[t.score >= FLOOR]
    size_min = float(np.percentile(seen, MIN_PX_PERCENTILE)) if seen.size else base.size_min_px
    frames = [f for r in runs for f in r.frames]
    jitter = _jitter(frames)
    offsets = (box_offsets(frames) if box else None) or {}
    if "jitter" in offsets:  # around the mean offsets, not around the true box
        jitter = offsets.pop("jitter")
    nz = fit.noise
    tau = -FRAME_DT / math.log(nz.rho) if nz.share > 0.0 and nz.rho > 0.0 else 0.0
    return replace(
        base,
        **values,
        size_ref_px=round(fit.size_ref, 4),
        size_min_px=round(max(1.0, size_min), 2),
        size_max_px=fit.size_max,
        noise_sigma=round(nz.sigma, 4),
        noise_tau=round(tau, 4),
        noise_run_share=0.0,
        noise_frame_share=round(1.0 - nz.share, 4) if nz.share > 0.0 else 0.0,
        detect_bias=round(nz.d0, 4),
        detect_gain=round(nz.d1, 4),
        detect_ar=round(nz.lam, 4),
        detect_trunc_gain=round(nz.dt, 4),
        detect_fill_gain=round(nz.df, 4),
        noise_size_gain=round(nz.k, 4),
        noise_size_max_px=nz.cap,
        noise_up_ratio=round(nz.up, 4),
        noise_outlier_share=round(nz.po, 4),
        noise_outlier_ratio=round(nz.ro, 4),
        noise_up_size_gain=round(nz.ku, 4),
        noise_low_tail=round(nz.tl, 4),
        noise_bend_gain=round(nz.kb, 4),
        noise_bend_px=_bend_px(fit, base),
        noise_up_rain_wind_gain=round(nz.uw, 4),
        noise_up_rain_wind_px=nz.uw_px if nz.uw != 0.0 else base.noise_up_rain_wind_px,
        noise_tau_size_gain=round(nz.kt, 4),
        noise_ceiling_logit=round(nz.cl, 4) if nz.cs != 1.0 else 0.0,
        noise_ceiling_size_gain=round(nz.cg, 4) if nz.cs != 1.0 else 0.0,
        noise_ceiling_slope=round(nz.cs, 4) if nz.cs != 1.0 else 1.0,
        side_gain=round(fit.side_gain, 4),
        **{param: round(gains.get(term, 0.0), 4) for term, param in EXTRA_TERM_PARAMS.items()},
        rain_sigma=0.0,
        rain_miss=0.0,
        rain_jitter=0.0,
        jitter=round(jitter, 4) if jitter is not None else base.jitter,
        floor=FLOOR,
        **offsets,
    )


def _bend_px(fit: FrameFit, base: PEMParams) -> float:
    """The noise's size bend's knot [px] of ``fit`` (``base``'s without a bend)."""
    if fit.noise.kb == 0.0:
        return base.noise_bend_px
    return round(fit.size_ref * math.exp(fit.noise.kb_at), 2)


def held_out_choice(
    t: Tracks, held: Tracks, *, size_ref: float,
    candidates: Sequence[tuple[Any, ...]] = CANDIDATES, stages: int = 1, starts: int = 1,
) -> tuple[str, dict[str, Any], dict[str, FrameFit]]:  # fmt: skip
    """Each candidate fitted on ``t`` and scored by its log-likelihood on the held-out
    tracks ``held`` (per frame): (the best, the table, the fits). ``stages`` as
    :func:`fit_tracks`'s (and ``starts``); the choosing column as :func:`choose_model`'s
    (:func:`selector`)."""
    table: dict[str, Any] = {}
    fits: dict[str, FrameFit] = {}
    for cand in candidates:
        name = cand[0]
        fits[name] = fit_candidate(t, cand, size_ref, stages=stages, starts=starts)
        n = max(1, len(held.score))
        table[name] = {
            "heldout_loglik_per_frame": round(fits[name].loglik(held) / n, 4),
            "heldout_marginal_loglik_per_frame": round(fits[name].marginal_loglik(held) / n, 4),
            "heldout_frames": len(held.score),
        }
    key = selector(stages)
    chosen = max(table, key=lambda k: table[k][key])
    return chosen, table, fits


def split_runs(data: KindFrames, part: str) -> KindFrames:
    """The runs of even (``even``) or odd (``odd``) index, or all (``all``); no sweep frames
    unless ``all``. Held-out files are split so that the model is chosen on one half and
    checked on the other."""
    if part == "all":
        return data
    want = 0 if part == "even" else 1
    return KindFrames(runs=[r for r in data.runs if r.index % 2 == want])


def fit_kind(
    data: KindFrames, base: PEMParams, *, folds: int = 5, held: KindFrames | None = None,
    candidates: Sequence[tuple[Any, ...]] = CANDIDATES, stages: int = 2, starts: int = 1,
    box: bool = False, refit_held: bool = True, held_terms: Sequence[str] = (),
) -> tuple[PEMParams, dict[str, Any]]:  # fmt: skip
    """Choose the model on held-out runs and fit it on every frame of the kind; the
    parameters and a summary (frames, tracks, the choice table, the fitted noise).

    With ``held`` (frames recorded with another seed) the candidates are fitted on
    ``data`` and chosen by their log-likelihood on ``held``'s even-index runs, and the
    chosen one is refitted on ``data`` and those runs (the odd ones are left for the
    check, :mod:`sitcov.calibration._frame_check`), or with ``refit_held`` False kept as
    fitted on ``data`` alone (the car's file: docs/pem.md, "Which frames the car is
    fitted on"); else by ``folds`` run-grouped folds
    of ``data`` and the chosen one refitted on all of it. ``candidates``: those of
    :data:`CANDIDATES` to choose among. ``stages``: the fit's (:func:`fit_tracks`), 2 by
    default (the marginal parameters by the frames-alone likelihood, then the AR share
    and coefficient by the sequence's; candidates chosen by the frames-alone held-out
    likelihood); 1 the single-stage sequence fit and choice of the files before it.
    ``starts``: every fit's (:func:`fit_tracks`: its first stage from that many starts,
    the best kept; 1, the default, is the shipped files' fit). ``box``:
    :func:`to_params`'s (the box's mean offsets and per-axis noise). ``held_terms``:
    extra terms with a PEM parameter added to the fitted model with the rest held
    (:func:`fit_held_terms`, on the frames it was fitted on), one after another in the
    order given, each with the ones before it held too: fitted together, the car's cut
    tent and windy-rain terms traded (the tent 0.29 -> 0.20) and the pair lost on two of
    three held-out files against the two fitted in turn (docs/pem.md, "The wind in the
    rain, shipped")."""
    t = tracks_of(data)
    size_ref = base.size_ref_px
    if held is not None:
        even = split_runs(held, "even")
        chosen, table, fits = held_out_choice(t, tracks_of(even), size_ref=size_ref,
                                              candidates=candidates, stages=stages,
                                              starts=starts)  # fmt: skip
        fit = fits[chosen]
        if refit_held:
            # then the chosen model on every frame but the check's (written for fit runs
            # that an AEB stopped: the held-out runs, recorded with the stack given no
            # detections, held the closest frames)
            data = KindFrames(sweep=list(data.sweep), runs=[*data.runs, *even.runs])
            t = tracks_of(data)
            fit = fit_candidate(t, next(c for c in candidates if c[0] == chosen), size_ref,
                                stages=stages, starts=starts)  # fmt: skip
    else:
        chosen, table = choose_model(t, folds=folds, size_ref=size_ref, candidates=candidates,
                                     stages=stages, starts=starts)  # fmt: skip
        fit = fit_candidate(t, next(c for c in candidates if c[0] == chosen), size_ref,
                            stages=stages, starts=starts)  # fmt: skip
    before = fit.marginal_loglik(t) / max(1, len(t.score)) if held_terms else 0.0
    for name in held_terms:  # one after another, each with those before it held
        fit = fit_held_terms(fit, t, (name,))
    params = to_params(fit, base, t, data.runs, box=box)
    nz = fit.noise
    lag1 = nz.share * nz.rho
    summary = {
        "frames": len(t.score),
        "sweep_frames": len(data.sweep),
        "runs": len(data.runs),
        "tracks": int(t.track.max()) + 1 if len(t.track) else 0,
        "detected_ge_floor": round(float(np.mean(t.score >= FLOOR)), 4),
        "model_choice": {
            "on": "held-out runs (even index)" if held is not None else f"{folds} folds",
            "refitted_with_held_out_runs": held is not None and refit_held,
            "chosen": chosen,
            "by": selector(stages),
            "fit_stages": stages,
            "fit_starts": starts,
            "table": table,
        },
        "rho_per_frame": round(nz.rho, 4),
        "ar_share": round(nz.share, 4),
        "lag1_autocorrelation_of_logit_noise": round(lag1, 4),
        "loglik_per_frame": round(fit.loglik(t) / max(1, len(t.score)), 4),
        "marginal_loglik_per_frame": round(fit.marginal_loglik(t) / max(1, len(t.score)), 4),
    }
    if held_terms:
        noise_gains = {UP_RAIN_WIND: nz.uw, TAU_SIZE: nz.kt, CEILING: nz.cs}
        gains = dict(zip(fit.extras, fit.gains, strict=True)) | noise_gains
        summary["held_terms"] = {
            "gains": {n: round(gains[n], 4) for n in held_terms},
            "marginal_loglik_per_frame_without": round(before, 4),
        }
    return params, summary


def _fit_job(
    job: tuple[str, KindFrames, PEMParams, int, KindFrames | None, tuple[Any, ...], int, int,
               bool, tuple[str, ...]],
) -> tuple[PEMParams, dict[str, Any]]:  # fmt: skip
    kind, data, base, folds, held, candidates, stages, starts, refit_held, held_terms = job
    return fit_kind(data, base, folds=folds, held=held, candidates=candidates, stages=stages,
                    starts=starts, box=kind in BOX_OFFSET_KINDS, refit_held=refit_held,
                    held_terms=held_terms)  # fmt: skip


def _merged(paths: Sequence[Any]) -> dict[str, KindFrames]:
    from sitcov.calibration._frames import read_frames

    merged: dict[str, KindFrames] = {}
    for path in paths:
        for kind, data in read_frames(path).items():
            into = merged.setdefault(kind, KindFrames())
            into.sweep.extend(data.sweep)
            into.runs.extend(data.runs)
    return merged


def fit_files(
    paths: Sequence[Any],
    *,
    folds: int = 5,
    workers: int = 1,
    held: Sequence[Any] = (),
    stages: int = 2,
    starts: int = 1,
    kinds: Sequence[str] | None = None,
    refit_held: bool = True,
    held_terms: Sequence[str] = (),
) -> dict[str, tuple[PEMParams, dict[str, Any]]]:
    """:func:`fit_kind` for every kind in the frames files ``paths`` (merged per kind):
    kind -> (parameters, summary). Cars start from the shipped car parameters, the other
    kinds from the shipped per-class ones (their size reference [px] is kept).
    ``workers`` > 1 fits the kinds in that many processes (the same results). ``held``:
    frames files recorded with another seed, to choose the model on (:func:`fit_kind`);
    ``stages``, ``starts``, ``refit_held``, ``held_terms``: :func:`fit_kind`'s; ``kinds``:
    only these (None: every kind in the files)."""
    from sitcov.perception._pem_classes import load_class_params
    from sitcov.perception._pem_params import load_pem_params

    merged = _merged(paths)
    if kinds is not None:
        merged = {kind: data for kind, data in merged.items() if kind in kinds}
    other = _merged(held) if held else {}
    classes = load_class_params()
    jobs = [
        (kind, data, load_pem_params() if kind == "car" else _start(classes, kind), folds,
         other.get(kind) if held else None, candidates_for(kind), stages, starts, refit_held,
         tuple(held_terms))
        for kind, data in merged.items()
    ]  # fmt: skip
    if workers <= 1 or len(jobs) <= 1:
        return {job[0]: _fit_job(job) for job in jobs}
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(min(workers, len(jobs))) as pool:
        return dict(zip([j[0] for j in jobs], pool.map(_fit_job, jobs), strict=True))


def _start(classes: dict[str, tuple[str, PEMParams]], kind: str) -> PEMParams:
    """A class's starting parameters: its shipped entry, or for a part the file does not
    have yet (a cyclist's bicycle) its road user's (:data:`~sitcov.perception._detector.
    PART_KIND`)."""
    from sitcov.perception._detector import PART_KIND

    entry = classes.get(kind) or classes[PART_KIND.get(kind, kind)]
    return entry[1]


def frame_yaml(
    results: dict[str, tuple[PEMParams, dict[str, Any]]], command: str, seeds: Sequence[int],
    *, classes: bool,
) -> str:  # fmt: skip
    """The text of ``pem.yaml`` (cars, ``classes`` False) or ``pem_classes.yaml``
    (pedestrians and cyclists), headed by the command, with provenance in ``meta``."""
    import datetime

    import yaml

    from sitcov.perception._detector import PEM_LABELS

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
        body = {k: {"label": PEM_LABELS[k][0], "params": p.to_dict()}
                for k, (p, _) in results.items() if k != "car"}  # fmt: skip
        doc = {"meta": meta, "classes": body}
    else:
        head = "# Perception error model (PEM) parameters: the frame model of\n"
        head += "# sitcov/calibration/_frame_model.py, documented in docs/pem.md. Made by:\n"
        params, summary = results["car"]
        meta["frames"] = summary["frames"]
        meta["car"] = summary
        doc = {"meta": meta, "params": params.to_dict()}
    return head + f"#   {command}\n" + yaml.safe_dump(_plain(doc), sort_keys=False)


def _plain(value: Any) -> Any:
    """``value`` with numpy scalars as Python numbers (what ``yaml.safe_dump`` writes)."""
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, np.generic):
        return value.item()
    return value
