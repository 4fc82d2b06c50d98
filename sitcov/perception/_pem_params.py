"""The PEM's parameters: the numbers of the error model and the file they are read from.

:mod:`sitcov.perception._pem` describes the model these numbers drive; the shipped values
(``data/pem.yaml``) are the output of ``sitcov calibrate`` (its command heads the file). The
per-class PEM (:mod:`sitcov.perception._pem_classes`) takes its missing names from these.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml

from sitcov.errors import ConfigError

#: The shipped parameter file.
PEM_PARAMS_FILE = Path(__file__).parent / "data" / "pem.yaml"


#: ``detect_bias`` at which (with no gain) the road user is always output: Phi(8) = 1 - 6e-16.
DETECT_ALWAYS = 8.0


@dataclass(frozen=True)
class PEMParams:
    """Coefficients of the PEM (see the module docstring for the formula).

    The defaults are the hand-tuned values first shipped in ``pem.yaml`` (docs/pem.md).

    Attributes:
        bias: logit of a rear view at the reference size in clear daylight [-].
        size_gain: logit per e-fold of box height [-].
        size_ref_px: box height where the size term is zero [px].
        size_min_px: below this box height the detector finds nothing [px].
        size_max_px: box heights above this count as this (detectors saturate) [px].
        view_gain: logit lost when seen exactly side-on [-].
        trunc_gain: logit lost when the box is entirely cut by the image edge [-].
        fog_gain: multiplies ln(fog transmittance) [-].
        illum_gain: multiplies ln(illumination) [-].
        rain_gain: logit lost at full rain noise [-].
        noise_sigma: standard deviation of the logit noise in clear weather [-].
        rain_sigma: extra logit noise at full rain noise [-].
        rain_miss: probability of a missed frame at full rain noise [-].
        jitter: box-corner noise as a fraction of the box size [-] (horizontal; vertical
            too unless ``jitter_y`` says otherwise).
        jitter_y: the vertical box-corner noise as a fraction of the box height [-]; a
            negative value (the default, files written before it) means ``jitter``.
        rain_jitter: extra box-corner noise at full rain noise [-].
        floor: the detector's output threshold: lower scores are not reported [-].
        aspect_gain: logit per e-fold of the box's width/height ratio [-].
        view2_gain: logit gained at a 45 degree (oblique) view, beyond the side-view term [-].
        edge_gain: logit lost with the box centre at the image's left or right edge [-].
        size2_gain: logit per squared e-fold of box height (curvature of the size term) [-].
        side_size_gain: extra logit per e-fold of box height when seen side-on [-].
        facing_gain: logit gained when seen from the rear rather than the front [-].
        facing2_gain: logit gained when seen end-on (rear or front) rather than side-on,
            as a cosine of twice the relative heading [-].
        noise_run_share: share of the logit-noise variance that is constant over a run
            for one actor (between-run share) [-].
        noise_tau: correlation time of the frame-to-frame part of the noise [s]
            (0 = independent frames).
        noise_frame_share: share of the logit-noise variance drawn afresh every frame,
            independent of the AR(1) part (the detector's frame-to-frame flicker) [-].
        detect_bias, detect_gain, detect_ar: whether the detector outputs the road user
            at all in a frame: probability ``Phi(detect_bias + detect_gain * z +
            detect_ar * u_t)`` with ``z`` the noise-free logit and ``u_t`` the noise's
            AR(1) part (unit variance); the default (8, 0, 0) always outputs it [-].
        detect_trunc_gain, detect_fill_gain: the road user cut by the image edge or
            filling it: ``- detect_trunc_gain * truncation - detect_fill_gain * fill``
            added to the detection term's argument, with ``fill = ln(clamp(w / W,
            FILL_MIN, 1) / FILL_MIN)`` the unclipped box width ``w`` over the image width
            ``W`` (0 for boxes narrower than :data:`sitcov.perception._pem.FILL_MIN` of
            the image). The SSD gives no box to most road users that fill or overflow the
            image; 0 (the default, files written before these terms) changes nothing [-].
        noise_size_gain: the logit noise's scale grows by ``(h / size_ref_px) **
            noise_size_gain`` with the box height ``h`` clamped to [size_min_px,
            noise_size_max_px]: the detector's scores on a large (close) box spread more
            than on a small one. 0 (the default, files written before it) gives one scale
            for every size [-].
        noise_size_max_px: box heights above this count as this in the noise's scale
            (the default 450 is the default camera's image height) [px].
        noise_bend_gain, noise_bend_px: the noise's size gain changes by
            ``noise_bend_gain`` above ``noise_bend_px``: the scale is further times
            ``(h / noise_bend_px) ** noise_bend_gain`` for ``h`` (clamped as for
            ``noise_size_gain``) above the knot. The class candidates fix the knot at 150
            px (the person's and the rider's ``size_max_px`` too): their close scores
            pile up in a narrow band up to 150 px and spread again on the larger, mostly
            cut boxes (docs/pem.md, "The close rider"). A gain of 0 (the default, files
            written before it) changes nothing [-], [px].
        noise_up_ratio: the logit noise's scale above its median over the scale below
            (``noise_sigma``): the detector's scores spread less upwards than downwards
            (1 = a normal law) [-].
        contrast_gain: logit per unit of the body's luminance contrast against road and
            sky (Michelson, 0..1) [-].
        detail_gain: logit per unit of the body's contrast against the car's dark parts
            (signed Michelson, -1..1) [-].
        chroma_gain: logit per unit of the body's CIELAB chroma C*/100 (saturation) [-].
        red_green_gain: logit per unit of the body's CIELAB a*/100 (red +, green -) [-].
        yellow_blue_gain: logit per unit of the body's CIELAB b*/100 (yellow +, blue -) [-].
        side_gain: logit per unit of ``side``, the sine of the road user's heading
            relative to the line of sight (+1 seen from its left, moving right to left in
            the image; -1 from its right, moving left to right): the one term that tells
            left from right. 0 (the default, files written before it) changes nothing [-].
        size3_gain: logit per cubed e-fold of box height (the size term's bend beyond
            ``size2_gain``; 0, the default of files written before it, changes nothing) [-].
        size_hinge40_gain, size_hinge80_gain: logit per e-fold of the unclamped box height
            above 40 px and above 80 px (``max(0, ln(h / 40))``, ``max(0, ln(h / 80))``:
            bends of the size term at fixed heights, which the quadratic in the clamped
            log size cannot make; 0, the default of files written before them, changes
            nothing) [-].
        view_hinge40_gain: logit per e-fold of the unclamped box height above 40 px, times
            the sine of the view angle (``sin(view) * max(0, ln(h / 40))``): the
            detector's scores on a close car seen side-on rise further with its size than
            on one seen end-on (docs/pem.md, "The side-on bend"); 0, the default of files
            written before it, changes nothing [-].
        box_dx0, box_dy0, box_dx1, box_dy1: the detected box's mean offset from the true
            (projected, clipped) box, per edge (left, top, right, bottom), as a fraction of
            the true box's width (x) or height (y); positive moves the edge right or down.
            The jitter scatters the corners around it. A cyclist's detection is its rider
            (``person``), whose box lies inside the cyclist's: its top lower than the 3-D
            box's near top corner, its bottom above the wheels' ground contact. 0 (the
            default, files written before them) centres the box on the true box [-].
        noise_outlier_share, noise_outlier_ratio: the share of frames whose score noise
            is an outlier, and that noise's scale over the frame's usual one (below the
            median): in such a frame the logit score is ``z + noise_outlier_ratio * sigma *
            e`` with ``e`` a fresh N(0, 1), independent of the AR(1) state and the same
            both ways. A narrow law for most frames with a few wide ones fits the
            detector's scores on a close road user better than one law for all (docs/
            pem.md, "Outlier frames"); a share of 0 (the default, files written before
            it) draws nothing and changes nothing [-].
        noise_up_size_gain: the logit noise's scale above the median grows by a further
            ``(h / size_ref_px) ** noise_up_size_gain`` (h clamped as for
            ``noise_size_gain``): negative, the scores on a close road user reach a
            ceiling the ones on a small box do not (docs/pem.md); 0 (the default, files
            written before it) changes nothing [-].
        noise_up_rain_wind_gain, noise_up_rain_wind_px: on a box at least
            ``noise_up_rain_wind_px`` high (unclamped), the logit noise's scale above the
            median is further times ``exp(noise_up_rain_wind_gain * rain_wind)``, with
            ``rain_wind`` the scene's precipitation times its wind intensity as fractions
            (:attr:`sitcov.weather.Conditions.rain_wind`): in windy rain the detector's
            scores on a close car reach higher than in calm rain, at the same median
            (the wind slants the rain streaks off the car; docs/pem.md, "The wind in the
            rain"). 0 (the default, files written before it) changes nothing [-], [px].
        noise_tau_size_gain: the AR(1) part's correlation time is ``noise_tau`` for a box
            ``size_ref_px`` high and ``noise_tau * (h / size_ref_px) ** -gain`` for one
            ``h`` high (``h`` clamped to [1, ``noise_size_max_px``]): positive, the
            detector's noise on a close road user, whose image changes more from frame to
            frame, forgets faster than on a far one (docs/pem.md, "The law over
            consecutive frames"). Only the law over frames changes, not any frame's own;
            0 (the default, files written before it) changes nothing [-].
        noise_low_tail: the score noise's lower tail beyond one standard unit below the
            median widens with its depth: a latent noise ``n = -1 + x``, ``x < 0``, moves
            the logit by ``sigma (n - noise_low_tail x**2)`` instead of ``sigma n``
            (outlier frames apart; slope and density stay continuous). The detector's
            scores on a close road user pile up under a ceiling with a long tail of weak
            frames below it; one normal scale spreads both ways and puts too few frames
            just under the ceiling (docs/pem.md, "The lower tail"). 0 (the default, files
            written before it) changes nothing [-].
        noise_ceiling_logit, noise_ceiling_size_gain, noise_ceiling_slope: the score's
            ceiling, which rises with the box: above the median, a logit offset past the
            knee ``max(noise_ceiling_logit + noise_ceiling_size_gain * ln(h /
            size_ref_px) - z, 0)`` (``z`` the mean logit, ``h`` clamped to [1,
            ``noise_size_max_px``]) grows ``noise_ceiling_slope`` times as fast: the
            detector's scores on a 60-80 px car almost never reach 0.7 and on a 200 px
            one do in a fifth of frames, which one upper spread cannot give
            (:func:`~sitcov.perception._pem.ceiling_knee`; docs/pem.md, "The score's
            ceiling"). ``noise_ceiling_slope`` 1 (the default, files written before it)
            changes nothing [logit], [-], [-].
        cut_gain: added to the logit of a box cut by the image edge, ramping from 0 to 1
            over the first ``CUT_RAMP`` (0.1) of truncation: the detector scores a close
            car partly out of the image higher than the truncation's linear term says
            (docs/pem.md, "The lower tail"). Measured, not fitted in the shipped files:
            0 (the default) changes nothing [-].
        cut_tent_gain: added to the logit of a box cut by the image edge (the same ramp
            as ``cut_gain``) times a tent in its log height, 1 at ``CUT_TENT_PX`` (220 px)
            and 0 at half and twice that: the detector scores a close car cut by 10-50 %
            with a box of 110-440 px higher than the rest of the logit says (above 0.6
            two to three times as often as the PEM without the term; docs/pem.md, "The
            mid-size cut car"). Fitted after the rest, which is held
            (``sitcov calibrate --held-term cut_tent220``); 0 (the default, files written
            before it) changes nothing [-].
        head_on_gain: added to the logit of a car seen from the front within 22.5 degrees
            of head-on (``HEAD_ON_DEG``), times a tent that is 1 head-on and 0 at that
            angle, on a box of 80 to 500 px (``HEAD_ON_PX``): the detector scores a close
            car coming straight at the camera lower than the view terms say, which rise
            smoothly with the view's sine (docs/pem.md, "The head-on front car"). Fitted
            after the rest, which is held (``sitcov calibrate --held-term head_on``); not in
            the shipped file (it fits the frames better and the verdicts no better); 0
            (the default) changes nothing [-].
    """

    bias: float = 0.5
    size_gain: float = 2.5
    size_ref_px: float = 25.0
    size_min_px: float = 6.0
    size_max_px: float = 250.0
    view_gain: float = 0.5
    trunc_gain: float = 3.0
    fog_gain: float = 2.5
    illum_gain: float = 0.7
    rain_gain: float = 2.0
    noise_sigma: float = 0.5
    rain_sigma: float = 1.0
    rain_miss: float = 0.3
    jitter: float = 0.03
    rain_jitter: float = 0.05
    floor: float = 0.3
    noise_run_share: float = 0.0
    noise_tau: float = 0.0
    noise_frame_share: float = 0.0
    detect_bias: float = DETECT_ALWAYS
    detect_gain: float = 0.0
    detect_ar: float = 0.0
    noise_up_ratio: float = 1.0
    aspect_gain: float = 0.0
    view2_gain: float = 0.0
    edge_gain: float = 0.0
    size2_gain: float = 0.0
    side_size_gain: float = 0.0
    facing_gain: float = 0.0
    facing2_gain: float = 0.0
    contrast_gain: float = 0.0
    detail_gain: float = 0.0
    chroma_gain: float = 0.0
    red_green_gain: float = 0.0
    yellow_blue_gain: float = 0.0
    detect_trunc_gain: float = 0.0
    detect_fill_gain: float = 0.0
    noise_size_gain: float = 0.0
    noise_size_max_px: float = 450.0
    noise_bend_gain: float = 0.0
    noise_bend_px: float = 150.0
    side_gain: float = 0.0
    size3_gain: float = 0.0
    size_hinge40_gain: float = 0.0
    size_hinge80_gain: float = 0.0
    view_hinge40_gain: float = 0.0
    box_dx0: float = 0.0
    box_dy0: float = 0.0
    box_dx1: float = 0.0
    box_dy1: float = 0.0
    jitter_y: float = -1.0
    noise_outlier_share: float = 0.0
    noise_outlier_ratio: float = 1.0
    noise_up_size_gain: float = 0.0
    noise_low_tail: float = 0.0
    cut_gain: float = 0.0
    cut_tent_gain: float = 0.0
    noise_up_rain_wind_gain: float = 0.0
    noise_up_rain_wind_px: float = 100.0
    noise_tau_size_gain: float = 0.0
    head_on_gain: float = 0.0
    noise_ceiling_logit: float = 0.0
    noise_ceiling_size_gain: float = 0.0
    noise_ceiling_slope: float = 1.0

    @classmethod
    def from_mapping(cls, data: Mapping[str, Any], *, file: str | None = None) -> PEMParams:
        """Validate a mapping of parameter names to numbers (unknown names are errors)."""
        known = {f.name for f in fields(cls)}
        values: dict[str, float] = {}
        for name, value in data.items():
            if name not in known:
                raise ConfigError(
                    f"{file + ': ' if file else ''}unknown PEM parameter {name!r}; "
                    f"expected one of: {', '.join(sorted(known))}",
                    file=file,
                    field=name,
                    value=name,
                )
            if isinstance(value, bool) or not isinstance(value, int | float):
                raise ConfigError(file=file, field=name, value=value, expected="a number")
            values[name] = float(value)
        params = cls(**values)
        params._check(file)
        return params

    def _check(self, file: str | None) -> None:
        for name in ("size_ref_px", "size_min_px", "size_max_px", "noise_size_max_px",
                     "noise_bend_px", "noise_up_rain_wind_px"):  # fmt: skip
            if getattr(self, name) <= 0:
                raise ConfigError(file=file, field=name, value=getattr(self, name), expected="> 0")
        if self.size_max_px < self.size_min_px:
            raise ConfigError(
                file=file, field="size_max_px", value=self.size_max_px, expected=">= size_min_px"
            )
        for name in ("noise_sigma", "rain_sigma", "jitter", "rain_jitter", "noise_up_ratio"):
            if getattr(self, name) < 0:
                raise ConfigError(file=file, field=name, value=getattr(self, name), expected=">= 0")
        if self.noise_tau < 0:
            raise ConfigError(file=file, field="noise_tau", value=self.noise_tau, expected=">= 0")
        if self.noise_run_share + self.noise_frame_share > 1.0 + 1e-9:
            raise ConfigError(
                file=file, field="noise_frame_share", value=self.noise_frame_share,
                expected="<= 1 - noise_run_share",
            )  # fmt: skip
        if self.noise_up_size_gain != 0.0 and self.noise_size_gain == 0.0:
            raise ConfigError(
                file=file, field="noise_up_size_gain", value=self.noise_up_size_gain,
                expected="0 when noise_size_gain is 0 (the upper scale's own size gain "
                "goes with the noise's)",
            )  # fmt: skip
        if self.noise_up_size_gain != 0.0 and self.noise_bend_gain != 0.0:
            raise ConfigError(
                file=file, field="noise_bend_gain", value=self.noise_bend_gain,
                expected="0 when noise_up_size_gain is not 0 (the upper scale's size gain "
                "is a power of the noise's whole size factor, which the bend would change)",
            )  # fmt: skip
        if self.noise_low_tail < 0:
            raise ConfigError(
                file=file, field="noise_low_tail", value=self.noise_low_tail, expected=">= 0"
            )
        if not 0.0 < self.noise_ceiling_slope <= 1.0:
            raise ConfigError(
                file=file, field="noise_ceiling_slope", value=self.noise_ceiling_slope,
                expected="in (0, 1] (1: no ceiling)",
            )  # fmt: skip
        if self.noise_outlier_ratio <= 0:
            raise ConfigError(
                file=file, field="noise_outlier_ratio", value=self.noise_outlier_ratio,
                expected="> 0",
            )  # fmt: skip
        for name in ("rain_miss", "floor", "noise_run_share", "noise_frame_share",
                     "noise_outlier_share"):  # fmt: skip
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ConfigError(
                    file=file, field=name, value=getattr(self, name), expected="in [0, 1]"
                )

    @property
    def jitter_vertical(self) -> float:
        """The vertical box-corner noise: ``jitter_y``, or ``jitter`` when it is negative."""
        return self.jitter_y if self.jitter_y >= 0.0 else self.jitter

    def to_dict(self) -> dict[str, float]:
        """Plain mapping, the form of ``pem.yaml``'s ``params``."""
        return asdict(self)


def load_pem_params(path: str | Path | None = None) -> PEMParams:
    """Read PEM parameters from a YAML file (default: the shipped ``pem.yaml``).

    The file holds ``params:`` (name -> number; missing names take the class defaults)
    and an optional free-form ``meta:`` (where the numbers came from).
    """
    if path is None:
        return _default_params()
    return _read(Path(path))


@lru_cache(maxsize=1)
def _default_params() -> PEMParams:
    return _read(PEM_PARAMS_FILE)


def read_yaml(path: Path, what: str) -> Any:
    """The YAML document in ``path`` ({} when empty); one-line ``ConfigError`` naming the
    file when it cannot be read (``what`` says what it should hold) or is not YAML."""
    try:
        return yaml.safe_load(path.read_text()) or {}
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read {what}: {exc}") from exc
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: invalid YAML: {exc}") from exc


def _read(path: Path) -> PEMParams:
    data = read_yaml(path, "PEM parameters")
    if not isinstance(data, Mapping) or not isinstance(data.get("params", {}), Mapping):
        raise ConfigError(file=str(path), field="params", expected="a mapping name -> number")
    return PEMParams.from_mapping(data.get("params", {}), file=str(path))
