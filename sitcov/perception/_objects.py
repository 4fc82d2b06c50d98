"""Object lists: every road user as a planner sees it, in the ego frame, with an optional
noise and miss model (the third observation kind, ``wants = "objects"``).

An object list is what a tracking stage (or a simulator's ground truth, as CARLA's
ScenarioRunner or highway-env give) hands a planner: per road user its class, a stable
id, its position, heading, velocity and size. It is computed from the world's state, not
from pixels, so it is the same in PEM and camera mode.

Ego frame: origin at the ego's centre (``EgoState.x, y``), ``x`` forward, ``y`` to the left,
headings counter-clockwise from ``x`` [rad]. Velocities are over the ground, expressed in
the ego's axes [m/s] (subtract the ego's ``(speed, 0)`` for the relative velocity).

Without a model (:class:`ObjectNoise` None) the list is the ground truth: every active
road user, exactly. With one, each road user is reported with probability

    p = p_range(d) * p_weather(T, rain) * p_occlusion(o)          (or the hook's value)

and, when reported, with Gaussian errors on position (growing with range), heading and
velocity. ``d`` is the distance from the camera, ``T`` the fog's contrast transmittance over
``d`` (:func:`sitcov.weather.fog_transmittance`, the law the renderer and the PEM use),
``o`` the share of the road user's angular extent hidden behind nearer road users (a plan
view: the camera sees over nothing). The parameters are data
(``sitcov/perception/data/objects.yaml``, :func:`load_object_noise`); docs/your-own-stack.md
describes each.

The hook: ``ObjectNoise.detection_probability``, when set, replaces ``p_range * p_weather``
by a function ``(label, distance, transmittance, conditions) -> p`` so a per-class detector
model (the PEM's per-class detection probability) drives the misses; the occlusion factor
still applies.

Misses in time. The detector the PEM models misses a road user in runs of frames, not
frame by frame independently (docs/pem.md: its latent noise is an AR(1) process per road
user, fitted on camera frames). So whether a road user is reported in a frame follows a
latent standard normal per road user (its stable id) of the PEM's form

    n_t = sqrt(1 - f - r) * u_t + sqrt(f) * e_t + sqrt(r) * a
    u_t = rho * u_prev + sqrt(1 - rho^2) * N(0, 1),   rho = exp(-(t - t_prev) / tau)

(``e_t`` drawn afresh each frame, ``a`` once per run), and it is reported when
``Phi(n_t) < p_t``. ``n_t`` is N(0, 1) in every frame (each road user's state starts from
the stationary law), so the per-frame miss rate stays exactly ``1 - p_t`` while misses
come in runs: the lag-k correlation of ``n`` is ``(1 - f - r) * rho^k + r``. ``(tau, f,
r)`` per class: the shipped PEM's fitted ``noise_tau``, ``noise_frame_share`` and
``noise_run_share`` (:func:`pem_miss_processes`) with ``miss_tau: pem`` (the shipped
objects.yaml) or by default when the hook drives the misses, else ``(miss_tau,
miss_frame_share, 0)``. ``tau`` = 0 (and no run share) draws each frame independently
with exactly the draws of earlier versions (one uniform per road user in range). Time
runs in seconds, so a sensor rate other than the PEM's 10 Hz converts by itself; a road
user that leaves (range, field of view, the world) and comes back continues its process
from where it left it, ``rho`` spanning the time away (as the PEM's actors do), which
for an absence much longer than ``tau`` is a fresh start. The state lives in an
:class:`ObjectMisses`, one per run.

Randomness: every draw comes from the generator the backend passes (its own stream per run,
so the object list's noise shifts no other draw of the run).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, fields, replace
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

from sitcov._frozen import fast_init
from sitcov.errors import ConfigError
from sitcov.weather import fog_transmittance

if TYPE_CHECKING:
    import numpy as np

    from sitcov.perception._base import ActorView, Pose
    from sitcov.weather import Conditions

#: The shipped noise and miss model.
OBJECT_NOISE_FILE = Path(__file__).parent / "data" / "objects.yaml"
#: ActorView kind -> the class an object list reports (the detector's labels).
OBJECT_CLASS = {"car": "car", "truck": "car", "pedestrian": "person", "cyclist": "bicycle"}


@fast_init
@dataclass(frozen=True)
class ObjectState:
    """One road user in an object list (ego frame: ``x`` forward, ``y`` left, origin at the
    ego's centre).

    Attributes:
        id: stable within a run (the same road user keeps it from frame to frame).
        label: ``car`` (cars and trucks), ``person`` or ``bicycle`` (a cyclist and bike).
        x, y: position of its footprint's centre [m].
        heading: its heading relative to the ego's [rad], in (-pi, pi].
        vx, vy: its velocity over the ground in the ego's axes [m/s].
        length, width, height: its size [m].
    """

    id: int
    label: str
    x: float
    y: float
    heading: float
    vx: float
    vy: float
    length: float
    width: float
    height: float

    def to_dict(self) -> dict[str, Any]:
        """The protocol's JSON form (docs/protocol.md, ``objects``)."""
        return {
            "id": self.id,
            "label": self.label,
            "position": [self.x, self.y],
            "heading": self.heading,
            "velocity": [self.vx, self.vy],
            "size": [self.length, self.width, self.height],
        }


#: ``(label, distance [m], fog transmittance [-], conditions) -> P(reported)``.
DetectionProbability = Callable[[str, float, float, "Conditions"], float]


@dataclass(frozen=True)
class ObjectNoise:
    """The object list's noise and miss model (units in brackets; see the module docstring).

    Attributes:
        fov_deg: horizontal field of view centred on the heading [deg]; 360 = all around.
        max_range: nothing farther is reported [m].
        p_max: detection probability of a close, clear, unoccluded road user [-].
        range_50: distance at which ``p_range`` falls to half of ``p_max`` [m].
        range_width: logistic width of that fall [m].
        fog_t50: fog transmittance at which ``p_weather`` is one half [-] (the SSD detector
            loses a car around T = 0.05: it keeps it at 12 m in dense fog, T = 0.15, and
            loses it at 30 m, T = 0.01; tests/perception/test_fog_optics.py).
        fog_slope: logistic width of ``p_weather`` in ln(T) [-].
        rain_miss: share of reports lost at full ``Conditions.rain_noise`` [-].
        occlusion_hidden: share of a road user hidden at which it is never reported [-];
            below it ``p_occlusion = 1 - o / occlusion_hidden``.
        pos_sigma0, pos_sigma_per_m: position error sigma = pos_sigma0 + pos_sigma_per_m * d [m].
        heading_sigma: heading error sigma [rad].
        vel_sigma: velocity error sigma per axis [m/s].
        miss_tau: correlation time of the misses' latent AR(1) process [s] (module
            docstring): 0 misses independently frame by frame; ``"pem"`` takes the
            process per class from the shipped PEM (:func:`pem_miss_processes`); None
            (default): ``"pem"`` when ``detection_probability`` is set, else 0.
        miss_frame_share: share of the latent's variance drawn afresh every frame [-]
            (the detector's flicker; not used with ``"pem"``, which has its own).
        detection_probability: the hook (module docstring); None uses the terms above.
    """

    fov_deg: float = 360.0
    max_range: float = 100.0
    p_max: float = 0.98
    range_50: float = 60.0
    range_width: float = 8.0
    fog_t50: float = 0.05
    fog_slope: float = 0.5
    rain_miss: float = 0.2
    occlusion_hidden: float = 0.8
    pos_sigma0: float = 0.1
    pos_sigma_per_m: float = 0.01
    heading_sigma: float = 0.05
    vel_sigma: float = 0.3
    miss_tau: float | str | None = None
    miss_frame_share: float = 0.0
    detection_probability: DetectionProbability | None = None

    def __post_init__(self) -> None:
        tau = self.miss_tau
        if tau is not None and tau != "pem":
            if isinstance(tau, bool) or not isinstance(tau, int | float) or not tau >= 0:
                raise ConfigError(field="miss_tau", value=tau, expected="a number >= 0 or 'pem'")
            if math.isinf(tau):
                raise ConfigError(field="miss_tau", value=tau, expected="a finite number")
        if not 0.0 <= self.miss_frame_share <= 1.0:
            raise ConfigError(
                field="miss_frame_share", value=self.miss_frame_share, expected="a number in [0, 1]"
            )

    def miss_process(self, label: str) -> tuple[float, float, float]:
        """The latent miss process of a road user of ``label``: ``(tau [s], frame share,
        run share)`` (module docstring); ``tau`` and run share 0: independent misses."""
        tau = self.miss_tau
        if tau == "pem" or (tau is None and self.detection_probability is not None):
            processes = pem_miss_processes()
            return processes.get(label, processes["car"])
        return float(tau or 0.0), self.miss_frame_share, 0.0

    def probability(
        self, label: str, distance: float, occlusion: float, conditions: Conditions | None
    ) -> float:
        """P(a road user of ``label`` at ``distance`` m, ``occlusion`` hidden, is reported)."""
        if occlusion >= self.occlusion_hidden:
            return 0.0
        p_occ = 1.0 - occlusion / self.occlusion_hidden
        t = 1.0
        if conditions is not None:
            t = fog_transmittance(conditions.fog_extinction, conditions.fog_start, distance)
        if self.detection_probability is not None:
            return p_occ * float(self.detection_probability(label, distance, t, conditions))
        z = (distance - self.range_50) / self.range_width
        p_range = self.p_max / (1.0 + math.exp(min(50.0, z)))
        z = (math.log(max(t, 1e-300)) - math.log(self.fog_t50)) / self.fog_slope
        p_fog = 1.0 / (1.0 + math.exp(-max(-50.0, min(50.0, z))))
        rain = conditions.rain_noise if conditions is not None else 0.0
        return p_occ * p_range * p_fog * (1.0 - self.rain_miss * rain)


@lru_cache(maxsize=1)
def pem_miss_processes() -> dict[str, tuple[float, float, float]]:
    """Per object-list label, the shipped PEM's latent noise process: ``(noise_tau [s],
    noise_frame_share, noise_run_share)`` (docs/pem.md, "The noise"; ``car`` from
    ``data/pem.yaml``, ``person`` and ``bicycle`` from ``data/pem_classes.yaml``: the
    pedestrian's and the cyclist's, by kind, whatever label their PEM detection carries;
    a cyclist's is its rider's ``person``).

    The PEM's AR coefficient per frame is ``exp(-frame_dt / noise_tau)``; kept as a time
    constant here so the object list's own step (the sensor rate) converts it."""
    from sitcov.perception._pem_classes import load_class_params
    from sitcov.perception._pem_params import load_pem_params

    kinds = [("car", load_pem_params())]
    kinds += [(kind, params) for kind, (_, params) in load_class_params().items()]
    out = {}
    for kind, params in kinds:
        if kind not in OBJECT_CLASS:
            continue  # a part's own law (a cyclist's bicycle), not a road user's
        label = OBJECT_CLASS[kind]
        out.setdefault(label, (params.noise_tau, params.noise_frame_share, params.noise_run_share))
    return out


class ObjectMisses:
    """The latent miss state of every road user of one run (module docstring): per stable
    id its AR(1) state ``u``, its run offset ``a`` and the time it was last drawn [s].

    One per run (the backend makes it with the run's object-list generator); a road user
    seen for the first time starts from the stationary law N(0, 1)."""

    __slots__ = ("_state",)

    def __init__(self) -> None:
        self._state: dict[int, list[float]] = {}

    def draw(
        self,
        ident: int,
        time: float,
        process: tuple[float, float, float],
        rng: np.random.Generator,
    ) -> float:
        """Advance road user ``ident``'s latent to ``time`` [s] and return ``n_t`` ~ N(0, 1).

        Draws: one normal to start (two with a run share) or to advance, one more with a
        frame share."""
        tau, fresh, run = process
        state = self._state.get(ident)
        if state is None:
            u = float(rng.standard_normal())
            a = float(rng.standard_normal()) if run > 0.0 else 0.0
            state = self._state[ident] = [u, a, time]
        else:
            gap = time - state[2]
            rho = math.exp(-max(gap, 0.0) / tau) if tau > 0.0 else 0.0
            if gap <= 0.0:  # the same frame again: unchanged
                rho = 1.0
            keep = 1.0 - rho * rho
            state[0] = rho * state[0] + math.sqrt(keep if keep > 0.0 else 0.0) * float(
                rng.standard_normal()
            )
            state[2] = time
        ar = 1.0 - fresh - run
        n = math.sqrt(ar if ar > 0.0 else 0.0) * state[0] + math.sqrt(run) * state[1]
        if fresh > 0.0:
            n += math.sqrt(fresh) * float(rng.standard_normal())
        return n


def _normal_cdf(x: float) -> float:
    return 0.5 * math.erfc(-x / math.sqrt(2.0))


def load_object_noise(path: str | Path | None = None, **overrides: Any) -> ObjectNoise:
    """The noise and miss model from a YAML file (default: the shipped one), with overrides.

    Raises:
        ConfigError: the file is missing or not a mapping, a key is unknown, or a value is
            not a number >= 0 (probabilities and shares in [0, 1]).
    """
    import yaml

    file = Path(path) if path is not None else OBJECT_NOISE_FILE
    try:
        data = yaml.safe_load(file.read_text()) or {}
    except OSError as exc:
        raise ConfigError(
            file=str(file), expected=f"a readable YAML file ({exc.strerror})"
        ) from None
    except yaml.YAMLError:
        raise ConfigError(file=str(file), expected="valid YAML") from None
    if not isinstance(data, Mapping):
        raise ConfigError(file=str(file), value=data, expected="a mapping of parameters")
    known = {f.name for f in fields(ObjectNoise)} - {"detection_probability"}
    values: dict[str, Any] = {}
    for key, value in {**data, **overrides}.items():
        if key not in known:
            raise ConfigError(file=str(file), field=str(key), expected=" | ".join(sorted(known)))
        if key == "miss_tau" and value == "pem":
            values[key] = value
            continue
        ok = not isinstance(value, bool) and isinstance(value, int | float) and value >= 0
        unit = key in ("p_max", "rain_miss", "occlusion_hidden", "fog_t50", "miss_frame_share")
        if not ok or not math.isfinite(value) or (unit and value > 1):
            want = "a number in [0, 1]" if unit else "a number >= 0"
            if key == "miss_tau":
                want = "a number >= 0 [s] or 'pem'"
            raise ConfigError(file=str(file), field=str(key), value=value, expected=want)
        values[key] = float(value)
    for key in ("range_width", "fog_slope", "occlusion_hidden", "fog_t50", "max_range"):
        if values.get(key, 1.0) == 0.0:
            raise ConfigError(file=str(file), field=key, value=0, expected="a number > 0")
    return replace(ObjectNoise(), **values)


def _wrap(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    a = math.atan2(math.sin(angle), math.cos(angle))
    return a if a > -math.pi else a + 2.0 * math.pi


def _extent(cx: float, cy: float, yaw: float, hl: float, hw: float) -> tuple[float, float]:
    """Bearing interval [rad] of a footprint box (centre ``cx, cy`` in the camera frame)
    seen from the origin: (centre bearing - left half, + right half), unwrapped around
    the centre bearing."""
    mid = math.atan2(cy, cx)
    c, s = math.cos(yaw), math.sin(yaw)
    lo = hi = 0.0
    for u, v in ((hl, hw), (hl, -hw), (-hl, hw), (-hl, -hw)):
        a = _wrap(math.atan2(cy + u * s + v * c, cx + u * c - v * s) - mid)
        lo, hi = min(lo, a), max(hi, a)
    return mid + lo, mid + hi


def _hidden(lo: float, hi: float, blockers: Sequence[tuple[float, float]]) -> float:
    """Share of the bearing interval [lo, hi] covered by the union of ``blockers``."""
    span = hi - lo
    if span <= 0.0:
        return 0.0
    pieces = []
    mid = 0.5 * (lo + hi)
    for b_lo, b_hi in blockers:  # the blocker's interval on the same branch as ours
        shift = 2.0 * math.pi * round((mid - 0.5 * (b_lo + b_hi)) / (2.0 * math.pi))
        a, b = max(lo, b_lo + shift), min(hi, b_hi + shift)
        if b > a:
            pieces.append((a, b))
    covered, end = 0.0, -math.inf
    for a, b in sorted(pieces):
        a = max(a, end)
        if b > a:
            covered += b - a
            end = b
    return covered / span


def object_list(
    ego: Pose,
    actors: Sequence[tuple[int, ActorView, float, float]],
    *,
    mount_x: float = 0.0,
    conditions: Conditions | None = None,
    noise: ObjectNoise | None = None,
    rng: np.random.Generator | None = None,
    misses: ObjectMisses | None = None,
    time: float = 0.0,
) -> tuple[ObjectState, ...]:
    """The object list of one frame.

    Args:
        ego: the ego's pose (its centre) [m, rad].
        actors: per road user ``(id, view, vx, vy)``: its view (pose, size, kind) and its
            world-frame velocity [m/s].
        mount_x: where the sensor sits ahead of the ego's centre [m] (range, field of view
            and occlusion are measured from it; positions stay relative to the centre).
        conditions: the run's weather (fog and rain act on the miss model).
        noise: the noise and miss model; None gives the ground truth.
        rng: the source of the model's draws (required with ``noise``).
        misses: the run's latent miss state (:class:`ObjectMisses`), advanced in place;
            None with a correlated miss process: a fresh one (every road user in its
            first frame).
        time: this frame's time [s] (the latent advances by the time since a road
            user's last draw).

    Returns:
        The reported road users, nearest first.
    """
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    rows = []
    for ident, view, vx, vy in actors:
        dx, dy = view.pose.x - ego.x, view.pose.y - ego.y
        x, y = dx * c + dy * s, -dx * s + dy * c
        rows.append((math.hypot(x - mount_x, y), ident, view, x, y, vx, vy))
    rows.sort(key=lambda r: (r[0], r[1]))
    extents: list[tuple[float, float]] = []
    out = []
    for dist, ident, view, x, y, vx, vy in rows:
        heading = _wrap(view.pose.yaw - ego.yaw)
        lo, hi = _extent(x - mount_x, y, heading, 0.5 * view.length, 0.5 * view.width)
        blockers = list(extents)
        extents.append((lo, hi))
        label = OBJECT_CLASS.get(view.kind, "car")
        evx, evy = vx * c + vy * s, -vx * s + vy * c
        if noise is not None:
            if rng is None:
                raise ValueError("object_list: a noise model needs an rng")
            bearing = math.degrees(abs(math.atan2(y, x - mount_x)))
            if dist > noise.max_range or bearing > 0.5 * noise.fov_deg:
                continue
            p = noise.probability(label, dist, _hidden(lo, hi, blockers), conditions)
            process = noise.miss_process(label)
            if process[0] == 0.0 and process[2] == 0.0:  # independent: a uniform, as before
                if rng.random() >= p:
                    continue
            else:
                if misses is None:
                    misses = ObjectMisses()
                if not _normal_cdf(misses.draw(ident, time, process, rng)) < p:
                    continue
            sigma = noise.pos_sigma0 + noise.pos_sigma_per_m * dist
            ex, ey, eh, ev, ew = rng.standard_normal(5).tolist()
            x, y = x + sigma * ex, y + sigma * ey
            heading = _wrap(heading + noise.heading_sigma * eh)
            evx, evy = evx + noise.vel_sigma * ev, evy + noise.vel_sigma * ew
        out.append(
            ObjectState(ident, label, x, y, heading, evx, evy, view.length, view.width, view.height)
        )
    return tuple(out)
