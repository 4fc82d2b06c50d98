"""The perception error model (PEM): what an SSD car detector would report, without rendering.

For each actor the camera geometry (:func:`sitcov.perception.project_box`) gives the box a
detector would draw; the PEM turns what makes that box hard to detect into a score:

    L = ln(clamp(h, size_min_px, size_max_px) / size_ref_px)                   apparent size
    z = bias
        + size_gain * L + size2_gain * L^2 + side_size_gain * sin(view) * L    size
        + size3_gain * L^3                                                    (its bend)
        + size_hinge40_gain * max(0, ln(h / 40)) + size_hinge80_gain * max(0, ln(h / 80))
                                                        (bends at 40 and 80 px, h unclamped)
        + view_hinge40_gain * sin(view) * max(0, ln(h / 40))  (the bend at 40 px, side-on)
        - view_gain  * sin(view_angle) + view2_gain * sin(2 * view_angle)      side, oblique
        + facing_gain * facing + facing2_gain * (2 * facing^2 - 1)             rear/front
        - trunc_gain * truncation                                             image edge
        + cut_tent_gain * cut * max(0, 1 - |ln(h / 220)| / ln 2)   a mid-size box cut by it
        + head_on_gain * front * max(0, 1 - view / 22.5 deg) * [80 <= h < 500]
                                                        a close car seen head-on, front
        + fog_gain   * ln(transmittance(distance))                            fog contrast
        + illum_gain * ln(illumination)                                       darkness
        - rain_gain  * rain_noise                                             rain, spray
        + aspect_gain * ln(clamp(w / h, 0.25, 4))                             box shape
        - edge_gain  * offset                                                 off-centre
        + contrast_gain * contrast + detail_gain * detail                     body colour
        + chroma_gain * chroma + red_green_gain * red_green
        + yellow_blue_gain * yellow_blue                                      body hue
        + side_gain * side                                                    left/right
    score = sigmoid(z + (noise_sigma + rain_sigma * rain_noise) * s * r * n_t)
    r = noise_up_ratio * w if n_t > 0 else 1     (the scores spread less upwards)
    w = exp(noise_up_rain_wind_gain * rain_wind) if h >= noise_up_rain_wind_px else 1
                                         (wider upwards on a close car in windy rain)
    s = (h' / size_ref_px) ** noise_size_gain * max(1, h' / noise_bend_px) ** noise_bend_gain
    h' = clamp(h, size_min_px, noise_size_max_px)
                                             (larger boxes, wider scores; 1 if the gains are 0)

with ``h`` and ``w`` the unclipped box height and width [px], ``cut`` the ramp
``min(1, truncation / 0.1)`` (``CUT_RAMP``), ``front`` 1 for a front view (``facing``
< 0) and 0 else (the head-on window: ``HEAD_ON_DEG``, ``HEAD_ON_PX``), ``facing`` the
cosine of the actor's heading relative to the line of sight (+1 rear view, -1 front
view), ``side`` its sine (+1 seen from the actor's left, moving right to left in the
image, -1 from its right: the only feature that is not left/right symmetric; 0 in frames
recorded before it), ``rain_wind`` the scene's precipitation times its wind intensity
(fractions), ``offset`` the
distance of the box centre from the image centre as a fraction of half the image width
(clamped to [0, 1]), ``contrast`` the luminance contrast of the body colour against the
road and sky under the scene's light and ``detail`` its contrast against the car's own
dark parts, ``chroma``, ``red_green`` and ``yellow_blue`` the body colour's CIELAB C*, a*
and b* over 100 (:mod:`sitcov.perception._colors`), and ``n_t`` a unit-variance noise,
optionally correlated in time:

    n_t = sqrt(noise_run_share) * a + sqrt(1 - noise_run_share - noise_frame_share) * u_t
          + sqrt(noise_frame_share) * e_t
    a ~ N(0, 1)                 drawn once per run and actor ("this car is hard to see")
    u_t = phi * u_{t-1} + sqrt(1 - phi^2) * N(0, 1),   phi = exp(-frame_dt k / noise_tau)
    k = (h'' / size_ref_px) ** noise_tau_size_gain,  h'' = clamp(h, 1, noise_size_max_px)
                              (a close road user's noise forgets faster; 1 without the gain)
    e_t ~ N(0, 1)               drawn afresh every frame (the detector's flicker)

(the shipped parameters: the frame model of :mod:`sitcov.calibration._frame_model`,
fitted by maximum likelihood on recorded detector frames; ``e_t`` is drawn only when
``noise_frame_share`` > 0, so files without it draw as before)

The detector outputs the actor at all in a frame with probability ``Phi(detect_bias +
detect_gain * z - detect_trunc_gain * truncation - detect_fill_gain * fill + detect_ar *
u_t)`` (its misses: the frames in which the SSD gives the actor no box; one more N(0, 1)
draw per frame, only when that probability is not 1), with ``fill = ln(clamp(w / W,
FILL_MIN, 1) / FILL_MIN)`` the unclipped box width over the image width (:func:`fill_of`:
0 up to 5 % of the image, ln 20 for a box as wide as the image or wider): the SSD gives
no box to most road users that fill the image or are cut by its edge.
A detection is reported when the score reaches the detector's output ``floor``; rain also
drops whole frames with probability ``rain_miss * rain_noise``, decided by a second
process of the same form (so misses come in runs too), and the box corners jitter by a
Gaussian whose standard deviation is ``jitter + rain_jitter * rain_noise`` times the box
size (independent per frame), around the true box moved by the class's mean edge offsets
(``box_dx0`` ... ``box_dy1``: a cyclist's detection is its rider's box, inside the
cyclist's). The noise state lives in the sensor: it is reset by
:meth:`PEMSensor.reset` and automatically whenever ``detect`` is given a different rng
(each run has its own), so a sensor reused across runs stays deterministic per run.
The parameters live in ``data/pem.yaml`` (documented in docs/pem.md), the output of
``sitcov calibrate``, which fits this functional form against the real detector.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from functools import lru_cache
from pathlib import Path
from statistics import NormalDist
from typing import TYPE_CHECKING, Any, NamedTuple

from sitcov.perception._base import ActorView, CameraSpec, Detection, Pose, Sensor
from sitcov.perception._camera import _clip_near, _project, _view_angle, project_raw
from sitcov.perception._colors import chroma_features, color_features
from sitcov.perception._detector import PEM_PARTS
from sitcov.perception._pem_params import DETECT_ALWAYS, PEMParams, load_pem_params
from sitcov.weather._conditions import fog_transmittance

if TYPE_CHECKING:
    import numpy as np

    from sitcov.weather import Conditions

#: Colour features of an actor without a colour (dark red) in clear weather.
DEFAULT_CONTRAST, DEFAULT_DETAIL = color_features(None, None)
#: Hue features of an actor without a colour (dark red).
DEFAULT_CHROMA, DEFAULT_RED_GREEN, DEFAULT_YELLOW_BLUE = chroma_features(None)


class PEMFeatures(NamedTuple):
    """What the PEM's score depends on (one actor, one frame).

    Attributes:
        height_px: unclipped box height [px].
        view_angle: folded view angle [rad], 0 = rear/front, pi/2 = side-on.
        truncation: fraction of the box outside the image [-].
        transmittance: fog contrast transmittance over the distance, in [0, 1] [-].
        illumination: relative scene illumination in (0, 1] [-].
        rain_noise: rain/spray/glare noise intensity in [0, 1] [-].
        width_px: unclipped box width [px] (0 = unknown: no shape term).
        offset: box centre's distance from the image centre over half the image width,
            clamped to [0, 1] [-].
        facing: cosine of the actor's heading relative to the line of sight (+1 rear
            view, -1 front view) [-].
        contrast: the body's luminance contrast against road and sky under the scene's
            light, in [0, 1] [-] (default: the dark red of earlier versions, clear noon).
        detail: the body's contrast against the car's dark parts, in [-1, 1] [-].
        chroma, red_green, yellow_blue: the body colour's CIELAB C*, a*, b* over 100 [-].
        side: sine of the actor's heading relative to the line of sight (+1 seen from its
            left side, moving right to left in the image; -1 from its right side, moving
            left to right; a road user crossing from the ego's left has ``side`` < 0) [-]
            (default 0: frames recorded before it, which carry no side).
        rain_wind: the scene's precipitation times its wind intensity, both as fractions
            of 100 (:attr:`sitcov.weather.Conditions.rain_wind`): not in the logit, it
            widens the score noise's upper side (``noise_up_rain_wind_gain``) [-]
            (default 0; frames recorded before it get their run's value when read).
    """

    height_px: float
    view_angle: float
    truncation: float
    transmittance: float = 1.0
    illumination: float = 1.0
    rain_noise: float = 0.0
    width_px: float = 0.0
    offset: float = 0.0
    facing: float = 0.0
    contrast: float = DEFAULT_CONTRAST
    detail: float = DEFAULT_DETAIL
    chroma: float = DEFAULT_CHROMA
    red_green: float = DEFAULT_RED_GREEN
    yellow_blue: float = DEFAULT_YELLOW_BLUE
    side: float = 0.0
    rain_wind: float = 0.0


#: How many of :class:`PEMFeatures`' values :func:`_logit` takes (all but ``rain_wind``,
#: which acts on the noise only).
LOGIT_FEATURES = 15


_TINY = 1e-9  # floor inside logarithms [-]
#: Box width over image width below which the detection term's ``fill`` is 0 [-].
FILL_MIN = 0.05
#: Truncation over which ``cut_gain``'s step ramps from 0 to 1 [-].
CUT_RAMP = 0.1
#: Box height [px] at which ``cut_tent_gain``'s tent peaks; it falls to 0 at half and at
#: twice this height.
CUT_TENT_PX = 220.0
#: View angle [deg] at which ``head_on_gain``'s tent falls to 0 (it is 1 head-on), and the
#: box heights [px] it acts on, from the lower bound to below the upper: the close car
#: seen from the front (docs/pem.md, "The head-on front car").
HEAD_ON_DEG = 22.5
HEAD_ON_PX = (80.0, 500.0)
_HEAD_ON_RAD = math.radians(HEAD_ON_DEG)
_LN2 = math.log(2.0)
#: Where the score noise's lower tail widens (``noise_low_tail``), in standard units of
#: the latent noise below the median [-].
LOW_TAIL_KNEE = 1.0


def fill_of(width_px: float, image_width: float) -> float:
    """The detection term's ``fill``: ``ln(clamp(width_px / image_width, FILL_MIN, 1) /
    FILL_MIN)``, 0 for a box narrower than :data:`FILL_MIN` of the image and ln 20 for one
    as wide as the image or wider (``min``/``max`` written out: compiled in the kernel)."""
    frac = width_px / image_width if image_width > 0.0 else 0.0
    frac = FILL_MIN if frac < FILL_MIN else frac
    frac = 1.0 if frac > 1.0 else frac
    return math.log(frac / FILL_MIN)


def noise_scale(
    gain: float, height_px: float, size_min: float, size_cap: float, size_ref: float,
    bend_gain: float = 0.0, bend_px: float = 1.0,
) -> float:  # fmt: skip
    """The score noise's scale factor for a box ``height_px`` high: ``exp(gain * ln(h /
    size_ref) + bend_gain * max(0, ln(h / bend_px)))`` with ``h`` the height clamped to
    [``size_min``, ``size_cap``] [px] (``noise_size_gain``, ``size_min_px``,
    ``noise_size_max_px``, ``size_ref_px``, ``noise_bend_gain``, ``noise_bend_px``: the
    size gain changes by ``bend_gain`` above the knot); exactly 1 when both gains are 0
    (files without them draw as before)."""
    if gain == 0.0 and bend_gain == 0.0:
        return 1.0
    h = size_min if size_min > height_px else height_px
    h = size_cap if size_cap < h else h
    log_s = gain * math.log(h / size_ref)
    if bend_gain != 0.0 and h > bend_px:
        log_s += bend_gain * math.log(h / bend_px)
    return math.exp(log_s)


def up_wind_factor(params: PEMParams, rain_wind: float) -> float:
    """The upper noise scale's factor in windy rain on a box at least
    ``noise_up_rain_wind_px`` high: ``exp(noise_up_rain_wind_gain * rain_wind)``; exactly
    1 without the gain or without wind in the rain (files without it draw as before)."""
    gain = params.noise_up_rain_wind_gain
    return math.exp(gain * rain_wind) if gain != 0.0 and rain_wind != 0.0 else 1.0


def tau_steps(params: PEMParams, height_px: float) -> float:
    """How many reference-size frames one frame of a box ``height_px`` high counts for in
    the noise's AR(1) part: ``(h / size_ref_px) ** noise_tau_size_gain``, ``h`` clamped to
    [1, ``noise_size_max_px``] (the AR coefficient of a step of ``g`` frames into this
    frame is ``phi ** (g * tau_steps)``); exactly 1 without the gain."""
    gain = params.noise_tau_size_gain
    if gain == 0.0:
        return 1.0
    h = 1.0 if height_px < 1.0 else height_px
    h = params.noise_size_max_px if h > params.noise_size_max_px else h
    return (h / params.size_ref_px) ** gain


def detect_offset(features: PEMFeatures, params: PEMParams, image_width: float = 800.0) -> float:
    """What the box's geometry adds to the detection term's argument:
    ``-detect_trunc_gain * truncation - detect_fill_gain * fill`` (:func:`fill_of`;
    ``image_width`` [px], the default camera's 800)."""
    return -params.detect_trunc_gain * features.truncation - params.detect_fill_gain * fill_of(
        features.width_px, image_width
    )


#: The coefficients :func:`_logit` reads, in the order of its array (:func:`coefficients`).
COEFFICIENTS = (
    "bias",
    "size_gain",
    "size2_gain",
    "side_size_gain",
    "size_ref_px",
    "size_min_px",
    "size_max_px",
    "view_gain",
    "view2_gain",
    "facing_gain",
    "facing2_gain",
    "trunc_gain",
    "fog_gain",
    "illum_gain",
    "rain_gain",
    "aspect_gain",
    "edge_gain",
    "contrast_gain",
    "detail_gain",
    "chroma_gain",
    "red_green_gain",
    "yellow_blue_gain",
    "side_gain",
    "size3_gain",
    "size_hinge40_gain",
    "size_hinge80_gain",
    "view_hinge40_gain",
    "cut_gain",
    "cut_tent_gain",
    "head_on_gain",
)
(
    _BIAS,
    _SIZE,
    _SIZE2,
    _SIDE_SIZE,
    _SIZE_REF,
    _SIZE_MIN,
    _SIZE_MAX,
    _VIEW,
    _VIEW2,
    _FACING,
    _FACING2,
    _TRUNC,
    _FOG,
    _ILLUM,
    _RAIN,
    _ASPECT,
    _EDGE,
    _CONTRAST,
    _DETAIL,
    _CHROMA,
    _RED_GREEN,
    _YELLOW_BLUE,
    _SIDE_GAIN,
    _SIZE3,
    _HINGE40,
    _HINGE80,
    _VIEW_HINGE40,
    _CUT,
    _CUT_TENT,
    _HEAD_ON,
) = range(len(COEFFICIENTS))


#: :func:`coefficients`' values per ``id(params)``, with the parameters they are of (held,
#: so the id stays theirs): ``PEMParams`` is frozen, and a run reads them once per actor.
_COEFFICIENTS: dict[int, tuple[PEMParams, tuple[float, ...]]] = {}


def coefficients(params: PEMParams) -> tuple[float, ...]:
    """``params``' values named in :data:`COEFFICIENTS`, in that order (made once per
    parameters object: about 60 attribute reads, some of them properties)."""
    held = _COEFFICIENTS.get(id(params))
    if held is None or held[0] is not params:
        if len(_COEFFICIENTS) >= 64:
            _COEFFICIENTS.clear()
        values = tuple(getattr(params, name) for name in COEFFICIENTS)
        held = _COEFFICIENTS[id(params)] = (params, values)
    return held[1]


def pem_logit(features: PEMFeatures, params: PEMParams) -> float:
    """The noise-free logit ``z`` of the detection score (formula in the module docstring)."""
    return _logit(coefficients(params), *features[:LOGIT_FEATURES])


def _logit(
    c: Any,
    height_px: float,
    view_angle: float,
    truncation: float,
    transmittance: float,
    illumination: float,
    rain_noise: float,
    width_px: float = 0.0,
    offset: float = 0.0,
    facing: float = 0.0,
    contrast: float = DEFAULT_CONTRAST,
    detail: float = DEFAULT_DETAIL,
    chroma: float = DEFAULT_CHROMA,
    red_green: float = DEFAULT_RED_GREEN,
    yellow_blue: float = DEFAULT_YELLOW_BLUE,
    side_sin: float = 0.0,
) -> float:
    """The logit for coefficients ``c`` (:data:`COEFFICIENTS`' order, a sequence or float
    array: the compiled score :func:`_pem_view` calls this very code). ``min``/``max``
    are written out as the builtins decide (the first argument unless the second is
    strictly smaller/greater), so both give the same bits."""
    h = c[_SIZE_MIN] if c[_SIZE_MIN] > height_px else height_px
    h = c[_SIZE_MAX] if c[_SIZE_MAX] < h else h
    size = math.log(h / c[_SIZE_REF])
    shape = 0.0
    if width_px > 0.0 and height_px > 0.0:
        ratio = width_px / height_px
        ratio = 0.25 if ratio < 0.25 else ratio
        shape = math.log(4.0 if ratio > 4.0 else ratio)
    side = math.sin(view_angle)
    bend = 0.0
    if c[_HINGE40] != 0.0 and height_px > 40.0:
        bend += c[_HINGE40] * math.log(height_px / 40.0)
    if c[_HINGE80] != 0.0 and height_px > 80.0:
        bend += c[_HINGE80] * math.log(height_px / 80.0)
    if c[_VIEW_HINGE40] != 0.0 and height_px > 40.0:
        bend += c[_VIEW_HINGE40] * side * math.log(height_px / 40.0)
    if c[_CUT] != 0.0 and truncation > 0.0:  # cut by the image edge (0 without: same bits)
        bend += c[_CUT] * (1.0 if truncation > CUT_RAMP else truncation / CUT_RAMP)
    if c[_CUT_TENT] != 0.0 and truncation > 0.0 and height_px > 0.0:  # (0: the same bits)
        far = math.log(height_px / CUT_TENT_PX)
        tent = 1.0 - (far if far >= 0.0 else -far) / _LN2
        if tent > 0.0:
            ramp = 1.0 if truncation > CUT_RAMP else truncation / CUT_RAMP
            bend += c[_CUT_TENT] * ramp * tent
    if c[_HEAD_ON] != 0.0 and facing < 0.0 and HEAD_ON_PX[0] <= height_px < HEAD_ON_PX[1]:
        tent = 1.0 - view_angle / _HEAD_ON_RAD  # (0: the same bits)
        if tent > 0.0:
            bend += c[_HEAD_ON] * tent
    return (
        c[_BIAS]
        + (c[_SIZE] + c[_SIZE2] * size + c[_SIDE_SIZE] * side) * size
        - c[_VIEW] * side
        + c[_VIEW2] * math.sin(2.0 * view_angle)
        + c[_FACING] * facing
        + c[_FACING2] * (2.0 * facing * facing - 1.0)
        - c[_TRUNC] * truncation
        + c[_FOG] * math.log(_TINY if transmittance < _TINY else transmittance)
        + c[_ILLUM] * math.log(_TINY if illumination < _TINY else illumination)
        - c[_RAIN] * rain_noise
        + c[_ASPECT] * shape
        - c[_EDGE] * offset
        + c[_CONTRAST] * contrast
        + c[_DETAIL] * detail
        + c[_CHROMA] * chroma
        + c[_RED_GREEN] * red_green
        + c[_YELLOW_BLUE] * yellow_blue
        + c[_SIDE_GAIN] * side_sin
        + c[_SIZE3] * size * size * size
        + bend
    )


def pem_score(features: PEMFeatures, params: PEMParams) -> float:
    """The noise-free detection score in (0, 1): ``sigmoid(pem_logit(features, params))``."""
    return _sigmoid(pem_logit(features, params))


def pass_probability(
    features: PEMFeatures, params: PEMParams, threshold: float, image_width: float = 800.0
) -> float:
    """P(the sensor reports this frame's actor with a score >= ``threshold``): the detector
    outputs it (``Phi(detect_bias + detect_gain z + detect_offset + detect_ar u)``,
    :func:`detect_offset` for an image ``image_width`` px wide), its noisy score
    reaches ``max(threshold, floor)``, and rain does not drop the frame; averaged over the
    noise's AR(1) part ``u`` (Gauss-Hermite, 40 nodes). 0 for a box lower than
    ``size_min_px``. The noise ``n = sqrt(ar) u + sqrt(1 - ar) e`` enters the logit as
    ``sigma n`` below 0 and ``sigma noise_up_ratio n`` above (module docstring; times
    :func:`up_wind_factor` on a box of ``noise_up_rain_wind_px`` or more), ``sigma`` times
    :func:`noise_scale` of the box's height."""
    law = _PassLaw.of(features, params, threshold, image_width)
    if law is None:
        return 0.0
    nodes, weights = _hermite()
    total = 0.0
    for u, w in zip(nodes, weights, strict=True):
        detected, passes = law.at(u)
        total += w * detected * passes
    return law.keep * total


def pass_given_state(
    features: PEMFeatures, params: PEMParams, threshold: float, states: Sequence[float],
    image_width: float = 800.0,
) -> list[float]:  # fmt: skip
    """P(the sensor reports this frame's actor with a score >= ``threshold``) given the
    noise's AR(1) state ``u`` (one value per entry of ``states``): the law
    :func:`pass_probability` averages over ``u``. A track's frames share that state
    (``u_t = phi u_{t-1} + ...``), so the chance that *some* frame of a track reaches a
    threshold is a filter over it (``sitcov.calibration._frame_check.track_pass_probability``).
    The rain's frame drops (``rain_miss``) are taken as independent of ``u``."""
    law = _PassLaw.of(features, params, threshold, image_width)
    if law is None:
        return [0.0] * len(states)
    out = []
    for u in states:
        detected, passes = law.at(u)
        out.append(law.keep * detected * passes)
    return out


class _PassLaw(NamedTuple):
    """One frame's law of reaching a threshold, given the AR(1) state (the constants of
    :func:`pass_probability`): the detection term's argument without the state ``base``,
    the standard units the noise must reach ``need``, the AR part's variance share ``ar``,
    the outlier frames' share and their chance ``outlier``, the rain's keep share ``keep``
    and the detection term's gain on the state ``detect_ar``."""

    base: float
    need: float
    ar: float
    share: float
    outlier: float
    keep: float
    detect_ar: float

    @classmethod
    def of(
        cls, features: PEMFeatures, params: PEMParams, threshold: float, image_width: float
    ) -> _PassLaw | None:
        """The law of ``features`` (None for a box lower than ``size_min_px``)."""
        if features.height_px < params.size_min_px:
            return None
        theta = min(max(threshold, params.floor, 1e-12), 1.0 - 1e-12)
        sigma = params.noise_sigma + params.rain_sigma * features.rain_noise
        sigma *= noise_scale(params.noise_size_gain, features.height_px, params.size_min_px,
                             params.noise_size_max_px, params.size_ref_px,
                             params.noise_bend_gain, params.noise_bend_px)  # fmt: skip
        z = pem_logit(features, params)
        gap = z - math.log(theta / (1.0 - theta))
        keep = 1.0 - params.rain_miss * features.rain_noise
        ar = 1.0 - params.noise_run_share - params.noise_frame_share
        ar = ar if ar > 0.0 else 0.0
        upper = sigma * params.noise_up_ratio
        if params.noise_up_size_gain != 0.0:
            upper *= noise_scale(params.noise_up_size_gain, features.height_px,
                                 params.size_min_px, params.noise_size_max_px,
                                 params.size_ref_px)  # fmt: skip
        if features.height_px >= params.noise_up_rain_wind_px:
            upper *= up_wind_factor(params, features.rain_wind)
        if sigma <= 0.0:
            need = -math.inf if gap >= 0.0 else math.inf
        else:
            over = -gap
            if gap < 0.0 and params.noise_ceiling_slope != 1.0:  # θ above the median
                knee = ceiling_knee(z, features.height_px, params.noise_ceiling_logit,
                                    params.noise_ceiling_size_gain, params.size_ref_px,
                                    params.noise_size_max_px)  # fmt: skip
                over = ceiling_inverse(over, knee, params.noise_ceiling_slope)
            need = -gap / sigma if gap > 0.0 else over / upper
            if params.noise_low_tail != 0.0:  # the lower tail (below its knee only)
                need = low_tail_inverse(need, params.noise_low_tail)
        base = params.detect_bias + params.detect_gain * z
        base += detect_offset(features, params, image_width)
        share, outlier = params.noise_outlier_share, 0.0
        if share > 0.0:  # P(an outlier frame's wide noise reaches θ), independent of u
            wide = sigma * params.noise_outlier_ratio
            outlier = _normal_cdf(gap / wide) if wide > 0.0 else float(gap >= 0.0)
        return cls(base, need, ar, share, outlier, keep, params.detect_ar)

    def at(self, u: float) -> tuple[float, float]:
        """(P(the detector outputs the actor), P(its score reaches the threshold)) given
        the AR(1) state ``u``."""
        out = self.base + self.detect_ar * u
        ar, need = self.ar, self.need
        if ar >= 1.0 or math.isinf(need):
            passes = 1.0 if math.sqrt(ar) * u >= need else 0.0
        else:
            passes = _normal_cdf((math.sqrt(ar) * u - need) / math.sqrt(1.0 - ar))
        if self.share > 0.0:
            passes = (1.0 - self.share) * passes + self.share * self.outlier
        return _normal_cdf(out), passes


_HERMITE: tuple[list[float], list[float]] | None = None


def _hermite() -> tuple[list[float], list[float]]:
    """Probabilists' Gauss-Hermite nodes and weights (summing to 1), made once."""
    global _HERMITE
    if _HERMITE is None:
        import numpy as np

        x, w = np.polynomial.hermite_e.hermegauss(40)
        _HERMITE = (x.tolist(), (w / w.sum()).tolist())
    return _HERMITE


def _sigmoid(z: float) -> float:
    if z >= 0.0:
        return 1.0 / (1.0 + math.exp(-z))
    e = math.exp(z)
    return e / (1.0 + e)


#: Default time between two frames of the sensor [s] (10 Hz, the embedded backend's rate).
FRAME_DT = 0.1


class _Track:
    """Noise state of one actor in one run: persistent offset and two AR(1) terms."""

    __slots__ = ("offset", "u", "m", "frame")

    def __init__(self, offset: float, u: float, m: float, frame: int) -> None:
        self.offset, self.u, self.m, self.frame = offset, u, m, frame


def _offset(image_width: float, u0: float, u1: float) -> float:
    """Centre of the box from ``u0`` to ``u1`` [px]: its distance from the image centre over
    half the image width, in [0, 1] (``min`` written out as the builtin decides)."""
    half = 0.5 * image_width
    off = abs(0.5 * (u0 + u1) - half) / half
    return 1.0 if off > 1.0 else off


def _heading_sine(
    ex: float, ey: float, eyaw: float, mount_x: float, ax: float, ay: float, ayaw: float
) -> float:
    """:class:`PEMFeatures`' ``side``: the sine of the actor's heading ``ayaw`` relative to
    the line of sight from the camera (``mount_x`` [m] ahead of the ego at (ex, ey, eyaw))
    to the actor at (ax, ay): the same arithmetic as the projection's ``facing``, its
    cosine (:func:`~sitcov.perception._camera._project`) [-]."""
    cam_x = ex + mount_x * math.cos(eyaw)
    cam_y = ey + mount_x * math.sin(eyaw)
    return math.sin(ayaw - math.atan2(ay - cam_y, ax - cam_x))


def low_tail(n: float, curvature: float) -> float:
    """The lower tail's stretch of a latent unit noise ``n`` (``noise_low_tail``):
    ``n - curvature * (n + 1)**2`` below the knee (:data:`LOW_TAIL_KNEE`), ``n`` above."""
    x = n + LOW_TAIL_KNEE
    return n - curvature * x * x if x < 0.0 else n


def low_tail_inverse(v: float, curvature: float) -> float:
    """The latent unit noise ``n`` with :func:`low_tail` ``(n, curvature)`` = ``v``."""
    w = v + LOW_TAIL_KNEE
    if w >= 0.0 or curvature <= 0.0:
        return v
    return (1.0 - math.sqrt(1.0 - 4.0 * curvature * w)) / (2.0 * curvature) - LOW_TAIL_KNEE


def ceiling_knee(
    z: float, height_px: float, level: float, size_gain: float, size_ref: float, cap: float
) -> float:
    """How far above the mean logit ``z`` the score's ceiling bends the noise [logit]:
    ``max(level + size_gain * ln(h / size_ref) - z, 0)``, ``h`` the box height clamped to
    [1, ``cap``] (``noise_ceiling_logit``, ``noise_ceiling_size_gain``, ``size_ref_px``,
    ``noise_size_max_px``; the frame model's :func:`~sitcov.calibration._frame_model.
    scale_size` axis). Never below the median: the ceiling acts on the upper side only."""
    h = 1.0 if height_px < 1.0 else height_px
    h = cap if h > cap else h
    knee = level + size_gain * math.log(h / size_ref) - z
    return knee if knee > 0.0 else 0.0


def ceiling(offset: float, knee: float, slope: float) -> float:
    """A logit offset above the median under the score's ceiling: past ``knee`` it grows
    ``slope`` times as fast (``noise_ceiling_slope``; 1 or an offset below the knee: the
    offset itself, the same bits)."""
    return offset if offset <= knee else knee + slope * (offset - knee)


def ceiling_inverse(offset: float, knee: float, slope: float) -> float:
    """The offset before the ceiling that :func:`ceiling` takes to ``offset``."""
    return offset if offset <= knee else knee + (offset - knee) / slope


def _normal_cdf(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def up_size_power(params: PEMParams) -> float:
    """The upper scale's size factor as a power of the noise's (:func:`noise_scale`, the
    view kernel's ``s``): ``noise_up_size_gain / noise_size_gain``, so that ``s **
    power`` is ``(h / size_ref_px) ** noise_up_size_gain`` with the same clamped ``h``
    (0 without an upper size gain; :class:`PEMParams` refuses one without the noise's
    own size gain)."""
    if params.noise_up_size_gain == 0.0:
        return 0.0
    return params.noise_up_size_gain / params.noise_size_gain


@lru_cache(maxsize=64)
def outlier_cut(share: float) -> float:
    """The standard normal's ``share`` quantile: a frame is an outlier when its draw is
    below it (probability ``noise_outlier_share``); -inf for a share of 0 (no draw)."""
    if share <= 0.0:
        return -math.inf
    return NormalDist().inv_cdf(min(share, 1.0 - 1e-12))


#: Layout of the array :func:`_pem_view` takes (:meth:`PEMSensor._view_array`, one per
#: actor kind, size and colour and run): the class's :data:`COEFFICIENTS`, then the
#: camera (mount_x, mount_z, focal length, image width and height), the actor's box
#: (length, width, height), the scene (fog extinction and start, illumination, rain
#: noise), the body colour's features (contrast, detail, chroma, red_green,
#: yellow_blue), the detection term's geometry gains (detect_trunc_gain,
#: detect_fill_gain) and the score noise's size gain, cap and bend (noise_size_gain,
#: noise_size_max_px, noise_bend_gain, noise_bend_px). One array: each array argument
#: costs a compiled call about 0.3 us.
_CAMERA = len(COEFFICIENTS)
_BOX, _SCENE, _COLOR, _DETECT = _CAMERA + 5, _CAMERA + 8, _CAMERA + 12, _CAMERA + 17


def _pem_view(
    q: Any, ex: float, ey: float, eyaw: float, ax: float, ay: float, ayaw: float
) -> tuple:
    """One actor at (ax, ay, ayaw) seen from the ego at (ex, ey, eyaw): ``(seen, x0, y0,
    x1, y1, z, d, s, h)``, the box clipped to the image [px], the noise-free logit, what
    the box's geometry adds to the detection term (:func:`detect_offset`), the score
    noise's scale factor (:func:`noise_scale`) and the unclipped box height [px], or
    ``seen`` False (zeros, ``s`` 1) when the box is not in the image or lower than
    ``size_min_px``.

    The projection (:func:`~sitcov.perception._camera._project`), the features and
    :func:`_logit` in one call, compiled by numba when it is there (``sitcov/_jit.py``;
    the same bits). ``q``: the coefficients and what is constant over a run (layout above).
    """
    cam, box, scene, col, det = _CAMERA, _BOX, _SCENE, _COLOR, _DETECT
    ok, x0, y0, x1, y1, u0, v0, u1, v1, trunc, dist, _, view, visible, facing = _project(
        ex, ey, eyaw, ax, ay, ayaw, q[box], q[box + 1], q[box + 2],
        q[cam], q[cam + 1], q[cam + 2], q[cam + 3], q[cam + 4],
    )  # fmt: skip
    height = v1 - v0
    if not ok or not visible or height < q[_SIZE_MIN]:
        return False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0
    # the side's sine only when its gain is not 0 (0 times any side adds nothing)
    side = _heading_sine(ex, ey, eyaw, q[cam], ax, ay, ayaw) if q[_SIDE_GAIN] != 0.0 else 0.0
    z = _logit(
        q, height, view, trunc, fog_transmittance(q[scene], q[scene + 1], dist),
        q[scene + 2], q[scene + 3], u1 - u0, _offset(q[cam + 3], u0, u1), facing,
        q[col], q[col + 1], q[col + 2], q[col + 3], q[col + 4], side,
    )  # fmt: skip
    d = -q[det] * trunc - q[det + 1] * fill_of(u1 - u0, q[cam + 3])
    s = noise_scale(q[det + 2], height, q[_SIZE_MIN], q[det + 3], q[_SIZE_REF], q[det + 4],
                    q[det + 5])  # fmt: skip
    return True, x0, y0, x1, y1, z, d, s, height


#: The length of :func:`_pem_view`'s array: the layout above, ending with the detection
#: term's two gains and the score noise's size gain, cap, bend gain and bend knot.
VIEW_ARRAY_LEN = _DETECT + 6


def example_view_array() -> list[float]:
    """A whole :func:`_pem_view` array (:data:`VIEW_ARRAY_LEN` values: a car of the default
    :class:`PEMParams` in clear noon) for the compiled kernels' example calls.

    Whole, because compiled code does not check bounds: a short example reads past its
    end, and the bytes there (a different value in every process) once made the example
    call divide by zero (numba "could not compile _pem_frame (ZeroDivisionError)", seen
    intermittently in CI until 28 Nov 2026: the frame kernel's example lacked the noise's
    bend gain and knot, added to the layout after it was written)."""
    return [*coefficients(PEMParams()), 2.5, 1.0, 336.0, 800.0, 450.0, 4.6, 1.8, 1.5,
            0.0, 0.0, 1.0, 0.0, 0.5, 0.2, 0.3, 0.1, 0.1, 0.0, 0.0, 0.0, 450.0, 0.0,
            150.0]  # fmt: skip


_VIEW_FN: Any = None


def _view_kernel() -> Any:
    """:func:`_pem_view` compiled by numba when it is installed, else itself (loaded once)."""
    global _VIEW_FN
    if _VIEW_FN is None:
        import numpy as np

        from sitcov._jit import compiled, typed_entry

        q = np.array(example_view_array())
        helpers = (_clip_near, _view_angle, _project, _offset, fog_transmittance, _logit,
                   fill_of, noise_scale, _heading_sine)  # fmt: skip
        # the projection's helpers make lists: numba's NRT (_jit.compiled)
        _VIEW_FN = compiled(_pem_view, q, 0.0, 0.0, 0.0, 10.0, 1.0, 0.3, helpers=helpers, nrt=True)
        _VIEW_FN = typed_entry(_VIEW_FN) or _pem_view
    return _VIEW_FN


#: Layout of the constants array of :func:`_pem_frame` (:meth:`PEMSensor._frame_constants`):
#: the AR(1) coefficient per frame and the run and frame shares of the noise (the car
#: PEM's, as ``PEMSensor._noise`` takes them), then the actor class's noise sigma, rain
#: sigma, upper-spread ratio, detection gate (gain, AR weight, bias), score floor, box
#: jitter and rain jitter, the scene's rain noise and the image's width and height, and
#: the box's mean edge offsets (``box_dx0``, ``box_dy0``, ``box_dx1``, ``box_dy1``) and its
#: vertical corner noise (``PEMParams.jitter_vertical``), then the outlier frames' cut of
#: a standard normal (:func:`outlier_cut`) and their noise's scale ratio, then the upper
#: scale's size exponent over the noise's (:func:`up_size_power`), then the lower tail's
#: curvature (``noise_low_tail``), then the upper scale's factor in this scene's windy rain
#: (:func:`up_wind_factor`) and the box height from which it acts
#: (``noise_up_rain_wind_px``), then the AR part's size gain of its time constant
#: (``noise_tau_size_gain``), its reference size and its clamp (:func:`tau_steps`), then
#: the score's ceiling: its logit at the reference size, its size gain and the slope past
#: it (:func:`ceiling_knee`, :func:`ceiling`; the reference size and clamp are the two
#: before).
_F_PHI, _F_SHARE, _F_FRESH, _F_SIGMA, _F_RAIN_SIGMA, _F_UP, _F_GAIN, _F_AR, _F_BIAS = range(9)
_F_FLOOR, _F_JITTER, _F_RAIN_JITTER, _F_RAIN_NOISE, _F_WIDTH, _F_HEIGHT = range(9, 15)
_F_BOX, _F_JITTER_Y, _F_OUT_CUT, _F_OUT_RATIO, _F_UP_POWER, _F_LOW_TAIL = 15, 19, 20, 21, 22, 23
_F_UP_WIND, _F_UP_WIND_PX, _F_TAU_GAIN, _F_TAU_REF, _F_TAU_CAP = 24, 25, 26, 27, 28
_F_CEIL, _F_CEIL_GAIN, _F_CEIL_SLOPE = 29, 30, 31
#: Most normals :func:`_pem_frame` takes for one actor and frame.
FRAME_NORMALS = 11


#: How many values of :func:`_pem_frame`'s ``state`` are its constants ``c`` (then the
#: ``track``'s 5, then the view array ``q``).
_F_N = 32


def example_frame_state() -> list[float]:
    """A whole :func:`_pem_frame` state (its :data:`_F_N` constants, a fresh noise track
    of 5 and :func:`example_view_array`) for the compiled kernel's example call."""
    constants = [0.8, 0.0, 0.3, 1.0, 0.0, 0.7, -0.3, 0.4, 1.2, 0.1, 0.05, 0.0, 0.0, 800.0,
                 450.0, 0.0, 0.0, 0.0, 0.0, 0.05, -1.6, 3.0, -0.5, 0.2, 1.3, 100.0, 0.25,
                 25.0, 450.0, 0.05, 0.5, 0.55]  # fmt: skip
    return [*constants, *[0.0] * 5, *example_view_array()]


def _pem_frame(
    state: Any,
    normals: Any,
    at: int,
    frame: float,
    ex: float,
    ey: float,
    eyaw: float,
    ax: float,
    ay: float,
    ayaw: float,
) -> tuple[int, int, float, float, float, float, float]:
    """One actor in one frame of :meth:`PEMSensor.detect_prepared` when its class has no
    rain miss (``rain_miss`` 0 or a dry scene): :func:`_pem_view`, the noise
    (``PEMSensor._noise``: the same draws in the same order), the score, the detection
    gate, the floor and the box jitter, with the same operations in the same order (the
    builtins ``min``/``max`` written out as they decide). ``(code, next normal, x0, y0,
    x1, y1, score)``: code 0 not in view (nothing drawn), 1 not detected, 2 detected.

    ``state``: the actor's constants ``c`` (layout above, :data:`_F_N` values), its
    noise state ``track`` ``[offset, u, m, frame, known]`` (``known`` 0: a new track;
    updated in place) and :func:`_pem_view`'s array ``q``, in one float array (numba
    unboxes each array argument on every call, the dearest part of a call); ``normals``:
    standard normals of the run from index ``at`` on (at least :data:`FRAME_NORMALS`);
    ``frame``: this frame's number.
    """
    c, track, q = state[:_F_N], state[_F_N : _F_N + 5], state[_F_N + 5 :]
    seen, x0, y0, x1, y1, z, d, s, height = _pem_view(q, ex, ey, eyaw, ax, ay, ayaw)
    if not seen:
        return 0, at, 0.0, 0.0, 0.0, 0.0, 0.0
    if track[4] == 0.0:
        track[0], track[1], track[2] = normals[at], normals[at + 1], normals[at + 2]
        track[3], track[4] = frame, 1.0
        at += 3
    else:
        e_u, e_m = normals[at], normals[at + 1]
        at += 2
        steps = frame - track[3]
        if c[_F_TAU_GAIN] != 0.0:  # a close box's noise forgets faster (tau_steps)
            h = 1.0 if height < 1.0 else height
            h = c[_F_TAU_CAP] if h > c[_F_TAU_CAP] else h
            steps *= (h / c[_F_TAU_REF]) ** c[_F_TAU_GAIN]
        phi = c[_F_PHI] ** steps
        keep = 1.0 - phi * phi
        keep = math.sqrt(keep if keep > 0.0 else 0.0)
        track[1] = phi * track[1] + keep * e_u
        track[2] = phi * track[2] + keep * e_m
        track[3] = frame
    share, fresh = c[_F_SHARE], c[_F_FRESH]
    if fresh > 0.0:
        e = normals[at]
        at += 1
        ar = 1.0 - share - fresh
        ar = ar if ar > 0.0 else 0.0
        n = math.sqrt(share) * track[0] + math.sqrt(ar) * track[1] + math.sqrt(fresh) * e
    else:
        n = math.sqrt(share) * track[0] + math.sqrt(1.0 - share) * track[1]
    rain = c[_F_RAIN_NOISE]
    sig = c[_F_SIGMA] + c[_F_RAIN_SIGMA] * rain
    sig *= s  # the size's scale (1 without noise_size_gain: the same bits)
    outlier = False
    if c[_F_OUT_CUT] > -math.inf:  # an outlier frame? (no draw without them)
        outlier = normals[at] < c[_F_OUT_CUT]
        if outlier:
            n = c[_F_OUT_RATIO] * normals[at + 1]
        at += 2
    if n > 0.0 and not outlier:
        if c[_F_UP] != 1.0:
            sig *= c[_F_UP]
        if c[_F_UP_POWER] != 0.0:  # the upper scale's own size gain: s ** (ku / k)
            sig *= s ** c[_F_UP_POWER]
        if c[_F_UP_WIND] != 1.0 and height >= c[_F_UP_WIND_PX]:  # a close car, windy rain
            sig *= c[_F_UP_WIND]
    elif n < -LOW_TAIL_KNEE and c[_F_LOW_TAIL] != 0.0 and not outlier:  # the lower tail
        n = low_tail(n, c[_F_LOW_TAIL])
    if n > 0.0 and not outlier and c[_F_CEIL_SLOPE] != 1.0:  # the score's ceiling
        knee = ceiling_knee(z, height, c[_F_CEIL], c[_F_CEIL_GAIN], c[_F_TAU_REF], c[_F_TAU_CAP])
        score = _sigmoid(z + ceiling(sig * n, knee, c[_F_CEIL_SLOPE]))
    else:
        score = _sigmoid(z + sig * n)
    if (
        c[_F_GAIN] != 0.0
        or c[_F_AR] != 0.0
        or c[_F_BIAS] < DETECT_ALWAYS
        or q[_DETECT] != 0.0
        or q[_DETECT + 1] != 0.0
    ):
        e = normals[at]
        at += 1
        if c[_F_BIAS] + c[_F_GAIN] * z + d + c[_F_AR] * track[1] + e < 0:
            return 1, at, 0.0, 0.0, 0.0, 0.0, 0.0
    if score < c[_F_FLOOR]:
        return 1, at, 0.0, 0.0, 0.0, 0.0, 0.0
    n1, n2, n3, n4 = normals[at], normals[at + 1], normals[at + 2], normals[at + 3]
    at += 4
    w, h = c[_F_WIDTH], c[_F_HEIGHT]
    jit = c[_F_JITTER] + c[_F_RAIN_JITTER] * rain
    jit_y = c[_F_JITTER_Y] + c[_F_RAIN_JITTER] * rain
    bw, bh = x1 - x0, y1 - y0
    sx, sy = jit * bw, jit_y * bh
    # the mean offsets (0: x0 + 0.0 is x0, the same bits as without them)
    v = x0 + c[_F_BOX] * bw + sx * n1
    v = 0.0 if v < 0.0 else v
    nx0 = w if w < v else v
    v = x1 + c[_F_BOX + 2] * bw + sx * n3
    v = 0.0 if v < 0.0 else v
    x1 = w if w < v else v
    x0 = nx0
    v = y0 + c[_F_BOX + 1] * bh + sy * n2
    v = 0.0 if v < 0.0 else v
    ny0 = h if h < v else v
    v = y1 + c[_F_BOX + 3] * bh + sy * n4
    v = 0.0 if v < 0.0 else v
    y1 = h if h < v else v
    y0 = ny0
    if x1 <= x0 or y1 <= y0:
        return 1, at, 0.0, 0.0, 0.0, 0.0, 0.0
    return 2, at, x0, y0, x1, y1, score


_FRAME_FN: Any = None


def _frame_kernel() -> Any:
    """:func:`_pem_frame` compiled by numba when it is installed, else None (the sensor
    then runs its Python loop: :func:`_pem_frame` serves only the compiled path)."""
    global _FRAME_FN
    if _FRAME_FN is None:
        import numpy as np

        from sitcov._jit import compiled, typed_entry

        state, normals = np.array(example_frame_state()), np.zeros(FRAME_NORMALS)
        helpers = (_clip_near, _view_angle, _project, _offset, fog_transmittance, _logit)
        helpers += (fill_of, noise_scale, _heading_sine, _pem_view, _sigmoid, low_tail,
                    ceiling_knee, ceiling)  # fmt: skip
        example = (state, normals, 0, 1.0, 0.0, 0.0, 0.0, 10.0, 1.0, 0.3)
        fast = compiled(_pem_frame, *example, helpers=helpers, nrt=True)  # lists: as the view's
        _FRAME_FN = typed_entry(fast) or False
    return _FRAME_FN


class NormalStream:
    """Standard normals of a generator for the PEM's noise, drawn ahead in blocks of
    ``block`` values (0: exactly as many as asked, when asked).

    numpy's ``Generator`` draws normals one after another from its bit stream, so
    ``standard_normal(a)`` then ``standard_normal(b)`` give the values of
    ``standard_normal(a + b)``: the sensor gets the same values either way, one numpy
    call per block instead of one or two per actor and frame. Drawing ahead leaves the
    generator further on than the sensor's own draws would, which changes nothing only
    when nothing draws from it afterwards: a block > 0 is for the generator's last
    consumer in a run (the embedded backend's sensor; ``tests/sim/test_sim_world.py``
    checks that no other draw follows the sensor's first).
    """

    __slots__ = ("rng", "block", "_buffer", "_at", "_array")

    def __init__(self, rng: np.random.Generator, block: int = 0) -> None:
        self.rng, self.block = rng, int(block)
        self._buffer: list[float] = []
        self._at = 0
        self._array: Any = None  # the buffer as a float array once ahead() is used

    def take(self, n: int) -> list[float]:
        """The next ``n`` standard normals of the generator."""
        if self._array is not None:  # the array holds the buffer (ahead): back to a list
            self._buffer, self._array = self._array.tolist(), None
        at, end = self._at, self._at + n
        if end > len(self._buffer):
            if not self.block:
                return self.rng.standard_normal(n).tolist()
            fresh = self.rng.standard_normal(max(self.block, n)).tolist()
            self._buffer = self._buffer[at:] + fresh
            at, end = 0, n
        self._at = end
        return self._buffer[at:end]

    def ahead(self, n: int) -> tuple[Any, int]:
        """The buffer as a float array and where the next normal is, with at least ``n``
        normals from there (drawn ahead in blocks: only for ``block`` > 0); the caller
        takes what it uses and says how far it got with :meth:`advance`. The same
        values :meth:`take` gives, in the same order. From then on the array holds the
        buffer (until :meth:`take`)."""
        import numpy as np

        array = self._array
        if array is None:
            array = self._array = np.array(self._buffer, dtype=np.float64)
        at = self._at
        if at + n > len(array):
            fresh = self.rng.standard_normal(max(self.block, n))
            array = self._array = np.concatenate((array[at:], fresh))
            at = self._at = 0
        return array, at

    def advance(self, at: int) -> None:
        """The next normal is at ``at`` of the buffer (after :meth:`ahead`)."""
        self._at = at


class PEMSensor(Sensor):
    """A simulated SSD car detector: projection + :func:`pem_score` + correlated noise.

    All randomness comes from the rng given to :meth:`detect` (the run's rng). The noise
    state (per actor, keyed by its position in ``actors``) is cleared by :meth:`reset`
    and whenever ``detect`` receives a different rng object than on the previous call.

    Args:
        params: None (the shipped ``pem.yaml``), a :class:`PEMParams`, a mapping of
            overrides of the shipped values, or a path to a YAML file.
        camera: the dash-cam whose image the boxes are in.
        frame_dt: time between two ``detect`` calls [s]; sets the AR(1) coefficient.
        classes: the pedestrians' and cyclists' parameters: None (the shipped
            ``pem_classes.yaml``), a path to such a file, or kind -> (label, parameters).
    """

    def __init__(
        self,
        params: PEMParams | Mapping[str, Any] | str | Path | None = None,
        camera: CameraSpec | None = None,
        frame_dt: float = FRAME_DT,
        classes: str | Path | Mapping[str, tuple[str, PEMParams]] | None = None,
    ) -> None:
        if params is None:
            self.params = load_pem_params()
        elif isinstance(params, PEMParams):
            self.params = params
        elif isinstance(params, Mapping):
            merged = load_pem_params().to_dict()
            merged.update(params)
            self.params = PEMParams.from_mapping(merged)
        else:
            self.params = load_pem_params(params)
        self.camera = camera or CameraSpec()
        self.frame_dt = float(frame_dt)
        self._rng: Any = None
        self._normals: NormalStream | None = None
        self._tracks: dict[int, _Track] = {}
        #: per actor position, the compiled frame's ``(q, p, constants, state)``
        #: (``_frame_state``; the state holds the noise track) and the run its constants
        #: are for (``detect_prepared``)
        self._ftracks: dict[int, Any] = {}
        self._fstate: tuple[Any, ...] | None = None
        self._frame = 0
        self._classes_file = classes if not isinstance(classes, Mapping) else None
        self._classes: dict[str, tuple[str, PEMParams]] | None = (
            dict(classes) if isinstance(classes, Mapping) else None
        )  # per kind, lazily
        self._color_key: Any = None
        self._color_cache: dict[Any, tuple[float, ...]] = {}
        self._view_token: tuple[Any, ...] | None = None
        self._views: dict[Any, tuple[Any, PEMParams, str]] = {}

    def reset(self, frame_dt: float | None = None) -> None:
        """Start a new run: forget every actor's noise state (optionally set ``frame_dt`` [s])."""
        if frame_dt is not None:
            self.frame_dt = float(frame_dt)
        self._rng = None
        self._normals = None
        self._tracks = {}
        self._ftracks = {}
        self._frame = 0

    def features(self, ego: Pose, actor: ActorView, conditions: Conditions) -> PEMFeatures | None:
        """The PEM features of ``actor`` seen from ``ego``, or None if it is not in the image."""
        proj = project_raw(self.camera, ego, actor)
        if proj is None or not proj[6]:
            return None
        raw = proj[1]
        ap = actor.pose
        side = _heading_sine(ego.x, ego.y, ego.yaw, self.camera.mount_x, ap.x, ap.y, ap.yaw)
        return PEMFeatures(
            raw[3] - raw[1],
            proj[5],
            proj[2],
            conditions.transmittance(proj[3]),
            conditions.illumination,
            conditions.rain_noise,
            raw[2] - raw[0],
            _offset(self.camera.width, raw[0], raw[2]),
            proj[7],
            *self._colors(actor.color, conditions),
            side,
            conditions.rain_wind,
        )

    def _colors(self, color: Any, conditions: Conditions) -> tuple[float, ...]:
        """:func:`color_features` then :func:`chroma_features`, cached per colour for the
        last conditions: both are constant over a run (one entry per actor colour, so
        scenes with several actors do not recompute them every frame)."""
        if self._color_key is not conditions:
            self._color_key = conditions  # holds conditions: no id reuse
            self._color_cache = {}
        try:
            return self._color_cache[color]
        except KeyError:
            value = self._color_cache[color] = (
                *color_features(color, conditions),
                *chroma_features(color),
            )
        except TypeError:  # an unhashable colour (a list): not cached
            value = (*color_features(color, conditions), *chroma_features(color))
        return value

    def _class_params(self, kind: str) -> tuple[PEMParams, str]:
        """The PEM parameters and detection label for an actor kind: vehicles use
        ``self.params`` ("car"); pedestrians and cyclists their own (data/pem_classes.yaml,
        :mod:`sitcov.perception._pem_classes`)."""
        if kind in ("car", "truck"):
            return self.params, "car"
        label, params = self._class_entries().get(kind, ("car", self.params))
        return params, label

    def _class_entries(self) -> dict[str, tuple[str, PEMParams]]:
        """The per-class file's entries (loaded at the first call)."""
        if self._classes is None:
            from sitcov.perception._pem_classes import load_class_params

            self._classes = load_class_params(self._classes_file)
        return self._classes

    def parts(self, kind: str) -> tuple[str, ...]:
        """The detections a road user of ``kind`` gives, as the per-class entries that
        score them (:data:`~sitcov.perception._detector.PEM_PARTS`: a cyclist's rider and,
        when the per-class file has its entry, its bicycle); ``(kind,)`` for the rest."""
        names = PEM_PARTS.get(kind)
        if names is None or len(names) == 1:
            return (kind,)
        entries = self._class_entries()
        return (names[0], *(n for n in names[1:] if n in entries))

    def _phi(self, p: PEMParams | None = None) -> float:
        """The AR(1) coefficient per frame of the noise of a class with parameters ``p``
        (None: the car's)."""
        tau = (self.params if p is None else p).noise_tau
        return math.exp(-self.frame_dt / tau) if tau > 0.0 else 0.0

    def _noise(
        self, key: int, normals: NormalStream, p: PEMParams, height_px: float
    ) -> tuple[float, float]:
        """Advance actor ``key``'s noise to this frame: (score noise, miss noise), N(0, 1)
        each (the AR(1) part stays in ``self._tracks[key].u``), by the noise process of its
        class's parameters ``p`` (its ``noise_tau``, run share and frame share; the step's
        length by :func:`tau_steps` of the box ``height_px`` high)."""
        track = self._tracks.get(key)
        if track is None:
            a, u, m = normals.take(3)
            track = self._tracks[key] = _Track(a, u, m, self._frame)
        else:
            e_u, e_m = normals.take(2)
            steps = self._frame - track.frame
            if p.noise_tau_size_gain != 0.0:  # (x 1 without the gain: the same bits)
                steps *= tau_steps(p, height_px)
            phi = self._phi(p) ** steps
            keep = math.sqrt(max(0.0, 1.0 - phi * phi))
            track.u = phi * track.u + keep * e_u
            track.m = phi * track.m + keep * e_m
            track.frame = self._frame
        share, fresh = p.noise_run_share, p.noise_frame_share
        if fresh > 0.0:  # the frame's own part, independent of the AR(1) part
            (e,) = normals.take(1)
            ar = 1.0 - share - fresh
            ar = ar if ar > 0.0 else 0.0
            n = math.sqrt(share) * track.offset + math.sqrt(ar) * track.u + math.sqrt(fresh) * e
            return n, track.m
        n = math.sqrt(share) * track.offset + math.sqrt(1.0 - share) * track.u
        return n, track.m

    def _view_arrays(self, conditions: Conditions) -> dict[Any, tuple[Any, PEMParams, str]]:
        """The cache of :meth:`_view_array`'s values: emptied whenever the conditions,
        camera or parameters are other objects than at the last call (holding them, so no
        id is reused)."""
        token = self._view_token
        if (
            token is None
            or token[0] is not conditions
            or token[1] is not self.camera
            or token[2] is not self.params
        ):
            self._view_token = (conditions, self.camera, self.params)
            self._views = {}
        return self._views

    def _view_array(
        self, views: dict[Any, Any], actor: ActorView, conditions: Conditions, part: str
    ) -> tuple[Any, PEMParams, str]:
        """What :func:`_pem_view` takes for the detection ``part`` of ``actor`` (layout at
        ``_CAMERA``), its class's parameters and label; cached in ``views`` per part,
        size and colour (a run's actors repeat every frame)."""
        key = (part, actor.color, actor.length, actor.width, actor.height)
        try:
            return views[key]
        except KeyError:
            value = views[key] = self._make_view_array(actor, conditions, part)
        except TypeError:  # an unhashable colour (a list): not cached
            value = self._make_view_array(actor, conditions, part)
        return value

    def _make_view_array(
        self, actor: ActorView, conditions: Conditions, part: str
    ) -> tuple[Any, PEMParams, str]:
        params, label = self._class_params(part)
        cam = self.camera
        values = [
            *coefficients(params),
            *(cam.mount_x, cam.mount_z, cam.focal_px, float(cam.width), float(cam.height)),
            *(actor.length, actor.width, actor.height),
            conditions.fog_extinction,
            conditions.fog_start,
            conditions.illumination,
            conditions.rain_noise,
            *self._colors(actor.color, conditions),
            params.detect_trunc_gain,
            params.detect_fill_gain,
            params.noise_size_gain,
            params.noise_size_max_px,
            params.noise_bend_gain,
            params.noise_bend_px,
        ]
        if (_VIEW_FN or _view_kernel()) is not _pem_view:
            import numpy as np

            return np.array(values, dtype=np.float64), params, label
        return values, params, label

    def prepare(
        self, actor: ActorView, conditions: Conditions, part: str | None = None
    ) -> tuple[Any, PEMParams, str]:
        """What :meth:`detect_prepared` needs of ``actor`` besides its pose (its size,
        colour and kind with the camera, ``conditions`` and parameters; ``actor.pose`` is
        not read) for one of its detections (``part``, one of :meth:`parts`; None: the
        first): made once per run and actor by a backend that calls the sensor every
        frame. Valid while the sensor's ``camera`` and ``params`` stay the same."""
        part = self.parts(actor.kind)[0] if part is None else part
        return self._view_array(self._view_arrays(conditions), actor, conditions, part)

    def prepare_parts(self, actor: ActorView, conditions: Conditions) -> tuple[Any, ...]:
        """:meth:`prepare` for each of ``actor``'s detections (:meth:`parts`), in order:
        a backend passes :meth:`detect_prepared` one pair (prepared, pose) per part, each
        with a noise track of its own."""
        return tuple(self.prepare(actor, conditions, part) for part in self.parts(actor.kind))

    def detect(
        self,
        ego: Pose,
        actors: tuple[ActorView, ...],
        conditions: Conditions,
        rng: np.random.Generator,
    ) -> tuple[Detection, ...]:
        """Detections of the actors in view whose noisy score reaches the floor."""
        views = self._view_arrays(conditions)
        seen = [
            (self._view_array(views, a, conditions, part), a.pose)
            for a in actors
            for part in self.parts(a.kind)
        ]
        return self.detect_prepared(ego.x, ego.y, ego.yaw, seen, conditions, rng)

    def _frame_ready(self, conditions: Conditions) -> bool:
        """Whether :func:`_pem_frame` serves this run: the prepared arrays are float arrays
        (the view kernel is compiled) and no class drops frames in this scene's rain (it
        has no rain miss or the scene no rain: the miss test stays in Python). Decided once
        per run (``detect_prepared``'s ``_fstate``)."""
        rain = conditions.rain_noise
        misses = [self.params.rain_miss]
        if rain > 0.0:
            misses += [p.rain_miss for _, p in self._class_entries().values()]
        compiled_view = (_VIEW_FN or _view_kernel()) is not _pem_view
        return compiled_view and (rain == 0.0 or all(m == 0.0 for m in misses))

    def _frame_constants(self, p: PEMParams, conditions: Conditions) -> Any:
        """:func:`_pem_frame`'s constants for an actor class with parameters ``p``."""
        import numpy as np

        values = [
            self._phi(p), p.noise_run_share, p.noise_frame_share, p.noise_sigma,
            p.rain_sigma, p.noise_up_ratio, p.detect_gain, p.detect_ar, p.detect_bias,
            p.floor, p.jitter, p.rain_jitter, conditions.rain_noise,
            float(self.camera.width), float(self.camera.height),
            p.box_dx0, p.box_dy0, p.box_dx1, p.box_dy1, p.jitter_vertical,
            outlier_cut(p.noise_outlier_share), p.noise_outlier_ratio, up_size_power(p),
            p.noise_low_tail, up_wind_factor(p, conditions.rain_wind),
            p.noise_up_rain_wind_px, p.noise_tau_size_gain, p.size_ref_px, p.noise_size_max_px,
            p.noise_ceiling_logit, p.noise_ceiling_size_gain, p.noise_ceiling_slope,
        ]  # fmt: skip
        return np.array(values, dtype=np.float64)

    def _frame_state(
        self,
        old: tuple[Any, Any, Any, Any] | None,
        q: Any,
        p: PEMParams,
        conditions: Conditions,
        constants: dict[int, tuple[PEMParams, Any]],
    ) -> tuple[Any, Any, Any, Any]:
        """``(q, p, constants, state)``: :func:`_pem_frame`'s ``state`` for an actor with
        view array ``q`` and class parameters ``p`` in this run (``constants``: its
        ``id(p) -> (p, their constants)``), the noise track taken over from ``old`` (the
        position's last state; a new track without one)."""
        import numpy as np

        held = constants.get(id(p))
        if held is None:  # holds p: no id reuse while cached
            held = constants[id(p)] = (p, self._frame_constants(p, conditions))
        track = old[3][_F_N : _F_N + 5] if old is not None else np.zeros(5)
        return q, p, constants, np.concatenate((held[1], track, q))

    def _compiled_frame(
        self,
        actors: Sequence[tuple[Any, Any]],
        conditions: Conditions,
        constants: dict[int, Any],
        tracks: dict[int, Any],
        normals: Any,
        frame_fn: Any,
        ex: float,
        ey: float,
        eyaw: float,
    ) -> tuple[Detection, ...]:
        """This frame (``self._frame``, already counted) of a run set up for the compiled
        kernel: each actor in one :func:`_pem_frame` call, with the same draws and values
        as :meth:`detect_prepared`'s Python loop (normals drawn ahead in blocks).
        ``constants``: the run's ``id(class parameters) -> ...``; ``tracks``: the kernel's
        state (constants, noise track, view array) per position, made anew (keeping the
        position's track) when another actor or run comes there."""
        frame = float(self._frame)
        out = []
        for key, ((q, p, label), pose) in enumerate(actors):
            held = tracks.get(key)
            if held is None or held[0] is not q or held[1] is not p or held[2] is not constants:
                held = self._frame_state(held, q, p, conditions, constants)
                tracks[key] = held
            at, buf = normals._at, normals._array  # normals.ahead, written out
            if buf is None or at + FRAME_NORMALS > len(buf):
                buf, at = normals.ahead(FRAME_NORMALS)
            code, at, x0, y0, x1, y1, score = frame_fn(
                held[3], buf, at, frame, ex, ey, eyaw, pose.x, pose.y, pose.yaw
            )
            if code:
                normals._at = at  # normals.advance(at)
                if code == 2:
                    out.append(Detection((x0, y0, x1, y1), score, label))
        return tuple(out)

    def frame_detector(
        self, conditions: Conditions, rng: np.random.Generator | NormalStream
    ) -> Callable[[float, float, float, Sequence[tuple[Any, Any]]], tuple[Detection, ...]]:
        """:meth:`detect_prepared` with a run's ``conditions`` and ``rng`` bound: ``(ex, ey,
        eyaw, actors) -> detections``, the same values and draws, for a backend that
        calls it every frame of the run.

        Once :meth:`detect_prepared` has set up the run (its first frame), each frame
        checks only that the sensor's run state is still the one it set up (no
        :meth:`reset`, no other call with other conditions or rng in between) and runs
        the compiled frame's loop itself; the sensor's ``camera``, ``params`` and
        ``frame_dt`` stay as they were for the run (as :meth:`prepare`'s values assume).
        Otherwise, or with :meth:`detect_prepared` overridden, it calls
        :meth:`detect_prepared`."""
        detect_prepared = self.detect_prepared
        if type(self).detect_prepared is not PEMSensor.detect_prepared:
            return lambda ex, ey, eyaw, actors: detect_prepared(
                ex, ey, eyaw, actors, conditions, rng
            )
        run: list[Any] = [None]  # (run state, frame kernel, normals, tracks) once set up

        def detect(
            ex: float, ey: float, eyaw: float, actors: Sequence[tuple[Any, Any]]
        ) -> tuple[Detection, ...]:
            held = run[0]
            if held is None or self._fstate is not held[0] or self._rng is not rng:
                out = detect_prepared(ex, ey, eyaw, actors, conditions, rng)
                fs, normals = self._fstate, self._normals
                frame_fn = _FRAME_FN
                ready = fs is not None and fs[4] and frame_fn and normals.block
                run[0] = (fs, frame_fn, normals, self._ftracks) if ready else None
                return out
            fs, frame_fn, normals, tracks = held
            # detect_prepared's compiled loop (the same steps)
            self._frame += 1
            return self._compiled_frame(
                actors, conditions, fs[5], tracks, normals, frame_fn, ex, ey, eyaw
            )

        return detect

    def detect_prepared(
        self,
        ex: float,
        ey: float,
        eyaw: float,
        actors: Sequence[tuple[Any, Any]],
        conditions: Conditions,
        rng: np.random.Generator | NormalStream,
    ) -> tuple[Detection, ...]:
        """:meth:`detect` from the ego's pose (ex, ey, eyaw) for actors given as pairs
        (:meth:`prepare`'s value, pose), the pose any object with ``x``, ``y`` and ``yaw``
        (a body: no ``Pose`` or ``ActorView`` per frame), in ``detect``'s order (the
        position keys each actor's noise). ``rng`` may be a :class:`NormalStream` of the
        run's generator (drawing ahead: only for the generator's last consumer)."""
        if rng is not self._rng:
            self.reset()
            self._rng = rng
            self._normals = rng if isinstance(rng, NormalStream) else NormalStream(rng)
        normals: Any = self._normals
        self._frame += 1
        camera = self.camera
        frame_fn = _FRAME_FN if _FRAME_FN is not None else _frame_kernel()
        if frame_fn and normals.block:
            fs = self._fstate  # this run's: (conditions, camera, params, frame_dt, ready, c)
            if (
                fs is None
                or fs[0] is not conditions
                or fs[1] is not camera
                or fs[2] is not self.params
                or fs[3] != self.frame_dt
            ):
                ready = self._frame_ready(conditions)
                fs = self._fstate = (conditions, camera, self.params, self.frame_dt, ready, {})
            if fs[4]:  # each actor in one _pem_frame call (the same draws and values as
                # the Python loop below; normals drawn ahead in blocks)
                return self._compiled_frame(
                    actors, conditions, fs[5], self._ftracks, normals, frame_fn, ex, ey, eyaw
                )
        w, h = float(camera.width), float(camera.height)
        view = _VIEW_FN or _view_kernel()
        rain = conditions.rain_noise
        out = []
        for key, ((q, p, label), pose) in enumerate(actors):
            seen, x0, y0, x1, y1, z, d, s, height = view(q, ex, ey, eyaw, pose.x, pose.y, pose.yaw)
            if not seen:
                continue
            n, m = self._noise(key, normals, p, height)
            if rain > 0.0 and p.rain_miss > 0.0 and _normal_cdf(m) < p.rain_miss * rain:
                continue
            sig = p.noise_sigma + p.rain_sigma * rain
            sig *= s  # the size's scale (noise_size_gain; 1 without it)
            outlier = False
            if p.noise_outlier_share > 0.0:  # an outlier frame: a wide noise of its own
                cut_at, wide = normals.take(2)
                outlier = cut_at < outlier_cut(p.noise_outlier_share)
                n = p.noise_outlier_ratio * wide if outlier else n
            if n > 0.0 and not outlier:
                if p.noise_up_ratio != 1.0:
                    sig *= p.noise_up_ratio  # the scores' narrower upper spread
                if p.noise_up_size_gain != 0.0:  # narrower still on a large box
                    sig *= s ** up_size_power(p)
                if height >= p.noise_up_rain_wind_px:  # a close car in windy rain (x 1: same)
                    sig *= up_wind_factor(p, conditions.rain_wind)
            elif n < -LOW_TAIL_KNEE and p.noise_low_tail != 0.0 and not outlier:
                n = low_tail(n, p.noise_low_tail)  # the lower tail's stretch
            if n > 0.0 and not outlier and p.noise_ceiling_slope != 1.0:  # the ceiling
                knee = ceiling_knee(z, height, p.noise_ceiling_logit, p.noise_ceiling_size_gain,
                                    p.size_ref_px, p.noise_size_max_px)  # fmt: skip
                score = _sigmoid(z + ceiling(sig * n, knee, p.noise_ceiling_slope))
            else:
                score = _sigmoid(z + sig * n)
            if (
                p.detect_gain != 0.0
                or p.detect_ar != 0.0
                or p.detect_bias < DETECT_ALWAYS
                or p.detect_trunc_gain != 0.0
                or p.detect_fill_gain != 0.0
            ):
                (e,) = normals.take(1)  # whether the detector outputs it at all
                out_arg = p.detect_bias + p.detect_gain * z + d + p.detect_ar * self._tracks[key].u
                if out_arg + e < 0:
                    continue
            if score < p.floor:
                continue
            n1, n2, n3, n4 = normals.take(4)
            jit = p.jitter + p.rain_jitter * rain
            jit_y = p.jitter_vertical + p.rain_jitter * rain
            bw, bh = x1 - x0, y1 - y0
            sx, sy = jit * bw, jit_y * bh
            x0, x1 = (
                min(max(x0 + p.box_dx0 * bw + sx * n1, 0.0), w),
                min(max(x1 + p.box_dx1 * bw + sx * n3, 0.0), w),
            )
            y0, y1 = (
                min(max(y0 + p.box_dy0 * bh + sy * n2, 0.0), h),
                min(max(y1 + p.box_dy1 * bh + sy * n4, 0.0), h),
            )
            if x1 <= x0 or y1 <= y0:
                continue
            out.append(Detection((x0, y0, x1, y1), score, label))
        return tuple(out)
