"""The perception error model (PEM): what an SSD car detector would report, without rendering.

For each actor the camera geometry (:func:`sitcov.perception.project_box`) gives the box a
detector would draw; the PEM turns what makes that box hard to detect into a score:

    L = ln(clamp(h, size_min_px, size_max_px) / size_ref_px)                   apparent size
    z = bias
        + size_gain * L + size2_gain * L^2 + side_size_gain * sin(view) * L    size
        - view_gain  * sin(view_angle) + view2_gain * sin(2 * view_angle)      side, oblique
        + facing_gain * facing + facing2_gain * (2 * facing^2 - 1)             rear/front
        - trunc_gain * truncation                                             image edge
        + fog_gain   * ln(transmittance(distance))                            fog contrast
        + illum_gain * ln(illumination)                                       darkness
        - rain_gain  * rain_noise                                             rain, spray
        + aspect_gain * ln(clamp(w / h, 0.25, 4))                             box shape
        - edge_gain  * offset                                                 off-centre
        + contrast_gain * contrast + detail_gain * detail                     body colour
        + chroma_gain * chroma + red_green_gain * red_green
        + yellow_blue_gain * yellow_blue                                      body hue
    score = sigmoid(z + (noise_sigma + rain_sigma * rain_noise) * n_t)

with ``h`` and ``w`` the unclipped box height and width [px], ``facing`` the cosine of the
actor's heading relative to the line of sight (+1 rear view, -1 front view), ``offset`` the
distance of the box centre from the image centre as a fraction of half the image width
(clamped to [0, 1]), ``contrast`` the luminance contrast of the body colour against the
road and sky under the scene's light and ``detail`` its contrast against the car's own
dark parts, ``chroma``, ``red_green`` and ``yellow_blue`` the body colour's CIELAB C*, a*
and b* over 100 (:mod:`sitcov.perception._colors`), and ``n_t`` a unit-variance noise,
optionally correlated in time:

    n_t = sqrt(noise_run_share) * a + sqrt(1 - noise_run_share) * u_t
    a ~ N(0, 1)                 drawn once per run and actor ("this car is hard to see")
    u_t = phi * u_{t-1} + sqrt(1 - phi^2) * N(0, 1),   phi = exp(-frame_dt / noise_tau)

A detection is reported when the score reaches the detector's output ``floor``; rain also
drops whole frames with probability ``rain_miss * rain_noise``, decided by a second
process of the same form (so misses come in runs too), and the box corners jitter by a
Gaussian whose standard deviation is ``jitter + rain_jitter * rain_noise`` times the box
size (independent per frame). The noise state lives in the sensor: it is reset by
:meth:`PEMSensor.reset` and automatically whenever ``detect`` is given a different rng
(each run has its own), so a sensor reused across runs stays deterministic per run.
The parameters live in ``data/pem.yaml`` (documented in docs/pem.md), the output of
``sitcov calibrate``, which fits this functional form against the real detector.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import asdict, dataclass, fields
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import yaml

from sitcov.errors import ConfigError
from sitcov.perception._base import ActorView, CameraSpec, Detection, Pose, Sensor
from sitcov.perception._camera import project_raw
from sitcov.perception._colors import chroma_features, color_features

if TYPE_CHECKING:
    import numpy as np

    from sitcov.weather import Conditions

#: The shipped parameter file.
PEM_PARAMS_FILE = Path(__file__).parent / "data" / "pem.yaml"


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
        jitter: box-corner noise as a fraction of the box size [-].
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
        contrast_gain: logit per unit of the body's luminance contrast against road and
            sky (Michelson, 0..1) [-].
        detail_gain: logit per unit of the body's contrast against the car's dark parts
            (signed Michelson, -1..1) [-].
        chroma_gain: logit per unit of the body's CIELAB chroma C*/100 (saturation) [-].
        red_green_gain: logit per unit of the body's CIELAB a*/100 (red +, green -) [-].
        yellow_blue_gain: logit per unit of the body's CIELAB b*/100 (yellow +, blue -) [-].
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
        for name in ("size_ref_px", "size_min_px", "size_max_px"):
            if getattr(self, name) <= 0:
                raise ConfigError(file=file, field=name, value=getattr(self, name), expected="> 0")
        if self.size_max_px < self.size_min_px:
            raise ConfigError(
                file=file, field="size_max_px", value=self.size_max_px, expected=">= size_min_px"
            )
        for name in ("noise_sigma", "rain_sigma", "jitter", "rain_jitter"):
            if getattr(self, name) < 0:
                raise ConfigError(file=file, field=name, value=getattr(self, name), expected=">= 0")
        if self.noise_tau < 0:
            raise ConfigError(file=file, field="noise_tau", value=self.noise_tau, expected=">= 0")
        for name in ("rain_miss", "floor", "noise_run_share"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise ConfigError(
                    file=file, field=name, value=getattr(self, name), expected="in [0, 1]"
                )

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


def _read(path: Path) -> PEMParams:
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read PEM parameters: {exc}") from exc
    except yaml.YAMLError as exc:
        raise ConfigError(f"{path}: invalid YAML: {exc}") from exc
    if not isinstance(data, Mapping) or not isinstance(data.get("params", {}), Mapping):
        raise ConfigError(file=str(path), field="params", expected="a mapping name -> number")
    return PEMParams.from_mapping(data.get("params", {}), file=str(path))


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


_TINY = 1e-9  # floor inside logarithms [-]


def pem_logit(features: PEMFeatures, params: PEMParams) -> float:
    """The noise-free logit ``z`` of the detection score (formula in the module docstring)."""
    return _logit(params, *features)


def _logit(
    p: PEMParams,
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
) -> float:
    h = min(max(height_px, p.size_min_px), p.size_max_px)
    size = math.log(h / p.size_ref_px)
    shape = 0.0
    if width_px > 0.0 and height_px > 0.0:
        shape = math.log(min(max(width_px / height_px, 0.25), 4.0))
    side = math.sin(view_angle)
    return (
        p.bias
        + (p.size_gain + p.size2_gain * size + p.side_size_gain * side) * size
        - p.view_gain * side
        + p.view2_gain * math.sin(2.0 * view_angle)
        + p.facing_gain * facing
        + p.facing2_gain * (2.0 * facing * facing - 1.0)
        - p.trunc_gain * truncation
        + p.fog_gain * math.log(max(transmittance, _TINY))
        + p.illum_gain * math.log(max(illumination, _TINY))
        - p.rain_gain * rain_noise
        + p.aspect_gain * shape
        - p.edge_gain * offset
        + p.contrast_gain * contrast
        + p.detail_gain * detail
        + p.chroma_gain * chroma
        + p.red_green_gain * red_green
        + p.yellow_blue_gain * yellow_blue
    )


def pem_score(features: PEMFeatures, params: PEMParams) -> float:
    """The noise-free detection score in (0, 1): ``sigmoid(pem_logit(features, params))``."""
    return _sigmoid(pem_logit(features, params))


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


def _offset(camera: CameraSpec, raw: tuple[float, float, float, float]) -> float:
    """Box centre's distance from the image centre over half the image width, in [0, 1]."""
    half = 0.5 * camera.width
    return min(abs(0.5 * (raw[0] + raw[2]) - half) / half, 1.0)


def _normal_cdf(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


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
        self._tracks: dict[int, _Track] = {}
        self._frame = 0
        self._classes_file = classes if not isinstance(classes, Mapping) else None
        self._classes: dict[str, tuple[str, PEMParams]] | None = (
            dict(classes) if isinstance(classes, Mapping) else None
        )  # per kind, lazily
        self._color_key: Any = None
        self._color_cache: dict[Any, tuple[float, ...]] = {}

    def reset(self, frame_dt: float | None = None) -> None:
        """Start a new run: forget every actor's noise state (optionally set ``frame_dt`` [s])."""
        if frame_dt is not None:
            self.frame_dt = float(frame_dt)
        self._rng = None
        self._tracks = {}
        self._frame = 0

    def features(self, ego: Pose, actor: ActorView, conditions: Conditions) -> PEMFeatures | None:
        """The PEM features of ``actor`` seen from ``ego``, or None if it is not in the image."""
        proj = project_raw(self.camera, ego, actor)
        if proj is None or not proj[6]:
            return None
        raw = proj[1]
        return PEMFeatures(
            raw[3] - raw[1],
            proj[5],
            proj[2],
            conditions.transmittance(proj[3]),
            conditions.illumination,
            conditions.rain_noise,
            raw[2] - raw[0],
            _offset(self.camera, raw),
            proj[7],
            *self._colors(actor.color, conditions),
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
        if self._classes is None:
            from sitcov.perception._pem_classes import load_class_params

            self._classes = load_class_params(self._classes_file)
        label, params = self._classes.get(kind, ("car", self.params))
        return params, label

    def _phi(self) -> float:
        tau = self.params.noise_tau
        return math.exp(-self.frame_dt / tau) if tau > 0.0 else 0.0

    def _noise(self, key: int, rng: np.random.Generator) -> tuple[float, float]:
        """Advance actor ``key``'s noise to this frame: (score noise, miss noise), N(0, 1) each."""
        p = self.params
        track = self._tracks.get(key)
        if track is None:
            a, u, m = rng.standard_normal(3).tolist()
            track = self._tracks[key] = _Track(a, u, m, self._frame)
        else:
            e_u, e_m = rng.standard_normal(2).tolist()
            phi = self._phi() ** (self._frame - track.frame)
            keep = math.sqrt(max(0.0, 1.0 - phi * phi))
            track.u = phi * track.u + keep * e_u
            track.m = phi * track.m + keep * e_m
            track.frame = self._frame
        share = p.noise_run_share
        n = math.sqrt(share) * track.offset + math.sqrt(1.0 - share) * track.u
        return n, track.m

    def detect(
        self,
        ego: Pose,
        actors: tuple[ActorView, ...],
        conditions: Conditions,
        rng: np.random.Generator,
    ) -> tuple[Detection, ...]:
        """Detections of the actors in view whose noisy score reaches the floor."""
        if rng is not self._rng:
            self.reset()
            self._rng = rng
        self._frame += 1
        p = self.params
        camera = self.camera
        out = []
        for key, actor in enumerate(actors):
            p, label = self._class_params(actor.kind)
            proj = project_raw(camera, ego, actor)
            if proj is None or not proj[6]:
                continue
            (x0, y0, x1, y1), raw, truncation, distance, _, view, _, facing = proj
            height = raw[3] - raw[1]
            if height < p.size_min_px:
                continue
            n, m = self._noise(key, rng)
            rain = conditions.rain_noise
            if rain > 0.0 and p.rain_miss > 0.0 and _normal_cdf(m) < p.rain_miss * rain:
                continue
            z = _logit(
                p,
                height,
                view,
                truncation,
                conditions.transmittance(distance),
                conditions.illumination,
                rain,
                raw[2] - raw[0],
                _offset(camera, raw),
                facing,
                *self._colors(actor.color, conditions),
            )
            score = _sigmoid(z + (p.noise_sigma + p.rain_sigma * rain) * n)
            if score < p.floor:
                continue
            n1, n2, n3, n4 = rng.standard_normal(4).tolist()
            jit = p.jitter + p.rain_jitter * rain
            sx, sy = jit * (x1 - x0), jit * (y1 - y0)
            w, h = float(camera.width), float(camera.height)
            x0 = min(max(x0 + sx * n1, 0.0), w)
            x1 = min(max(x1 + sx * n3, 0.0), w)
            y0 = min(max(y0 + sy * n2, 0.0), h)
            y1 = min(max(y1 + sy * n4, 0.0), h)
            if x1 <= x0 or y1 <= y0:
                continue
            out.append(Detection((x0, y0, x1, y1), score, label))
        return tuple(out)
