"""A CPU dash-cam renderer for the embedded world (numpy + Pillow).

The frame is built in three passes, each cheap enough for 10 Hz campaigns:

1. Ground and sky, per pixel, in numpy. The camera has no pitch or roll, so the ground
   point seen by each pixel below the horizon depends only on the camera; it is cached per
   camera and moved with the ego each frame. The road map (surface, markings, kerbs, grass,
   puddle field) is rasterised once per geometry into a top-down texture that the ground
   pixels sample.
2. Road users, by ``ActorView.kind``: vehicles as flat-shaded convex solids (body, cabin,
   wheels) with decals (windows, lights, plate), pedestrians as an articulated walking body
   (:mod:`sitcov.perception._person`), cyclists as a bicycle with a seated rider
   (:mod:`sitcov.perception._cyclist`); clipped at the near plane, depth-sorted far to near
   (painter's algorithm: actors by distance, then their parts) and filled with Pillow. The
   projection is the one of :func:`sitcov.perception.project_box`.
3. Weather: fog by Koschmieder's law (:func:`sitcov.weather.fog_transmittance`, the one
   the PEM uses): every colour the camera sees, a road user's face, a ground pixel or the
   sky, blends towards the airlight (fog colour) by ``1 - T(distance)``; the light level
   from the illumination, wet-road darkening and sky reflections in puddles, rain streaks.
4. Auto-exposure, as CARLA's RGB camera does by default (``exposure_mode`` histogram): the
   frame is metered on its luminance histogram and scaled so that the metered luminance
   matches clear noon's, within CARLA's exposure window (:func:`exposure_gain`). So cloud
   changes what diffuse light changes, the shading of a body's faces, the contact shadow,
   the sky and the white balance, not the overall brightness nor the contrast between
   surfaces of different colour (their reflectances do not change with the light).

Only ``rng`` supplies randomness (rain streak positions), so frames are reproducible.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
from PIL import Image, ImageDraw

from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._camera import NEAR, project_box
from sitcov.perception._cyclist import cyclist_polygons
from sitcov.perception._person import person_polygons
from sitcov.perception._texture import ground_texture
from sitcov.perception._vehicle import (
    BODY,
    contact_shadow,
    draw_supersampled,
    vehicle_polygons,
)
from sitcov.weather import fog_transmittance

if TYPE_CHECKING:
    from sitcov.weather import Conditions

#: Farthest ground distance drawn [m]; beyond it the ground blends into the horizon haze.
FAR = 400.0
#: Colours (linear-ish sRGB 0..255).
SKY_ZENITH = np.array([70.0, 120.0, 200.0])
SKY_HORIZON = np.array([185.0, 210.0, 235.0])
OVERCAST = np.array([165.0, 170.0, 178.0])
FOG = np.array([200.0, 203.0, 207.0])

# --- auto-exposure: CARLA's sensor.camera.rgb defaults ------------------------------------
# CARLA 0.9.x docs (ref_sensors.md, "Advanced camera attributes"): exposure_mode
# "histogram", exposure_min_bright 10.0, exposure_max_bright 12.0 (EV100), exposure_speed_up
# 3.0, exposure_speed_down 1.0; the histogram's percents are UE4's defaults
# (FPostProcessSettings: AutoExposureLowPercent 80, AutoExposureHighPercent 98.3), which
# CARLA does not override.
#: Histogram percents between which the luminance is averaged (in log2) [%].
EXPOSURE_LOW_PERCENT = 80.0
EXPOSURE_HIGH_PERCENT = 98.3
#: The exposure window [EV100] the camera adapts within.
EXPOSURE_MIN_BRIGHT = 10.0
EXPOSURE_MAX_BRIGHT = 12.0
#: Adaptation speeds [EV/s]: towards a brighter scene, towards a darker one. A run's
#: weather is constant and the renderer meters each frame at its steady state (the
#: adaptation has converged): docs/camera.md#auto-exposure says why that is exact enough.
EXPOSURE_SPEED_UP = 3.0
EXPOSURE_SPEED_DOWN = 1.0
#: Metered luminance (linear, 0..1) of clear noon, which sits at the top of the window:
#: the median over clear-weather frames of the calibration sweep (docs/camera.md). Darker
#: scenes are brightened by up to ``EXPOSURE_MAX_BRIGHT - EXPOSURE_MIN_BRIGHT`` EV, brighter
#: ones are not darkened.
EXPOSURE_REFERENCE = 0.47
#: White balance: the camera is balanced for clear daylight (CARLA's ``temp`` 6500 K);
#: overcast light is bluer, so its frames come out slightly cool (per-channel gain at
#: cloudiness 100).
OVERCAST_TINT = np.array([0.95, 1.0, 1.05], dtype=np.float32)


@lru_cache(maxsize=4)
def _ground_rays(camera: CameraSpec) -> tuple[Any, ...]:
    """Per ground pixel (rows below the horizon, up to FAR): forward and right offsets
    of the ground point from the camera [m], ray length [m] and the far-haze weight;
    plus the first ground row and how many rows carry haze."""
    f, cx, cy = camera.focal_px, 0.5 * camera.width, 0.5 * camera.height
    vs = np.arange(camera.height, dtype=np.float64) + 0.5
    us = np.arange(camera.width, dtype=np.float64) + 0.5
    rows = vs[vs > cy + 0.5]
    depth = camera.mount_z * f / (rows - cy)
    keep = depth <= FAR
    rows, depth = rows[keep], depth[keep]
    fwd = np.repeat(depth[:, None], camera.width, axis=1)
    right = fwd * ((us[None, :] - cx) / f)
    dist = np.sqrt(fwd**2 + right**2 + camera.mount_z**2)
    haze = np.clip((dist - 0.5 * FAR) / (0.5 * FAR), 0.0, 1.0)
    hazy_rows = int(np.count_nonzero(haze.max(axis=1) > 0))
    first_row = int(rows[0] - 0.5) if rows.size else camera.height
    f32 = np.float32
    return (fwd.astype(f32), right.astype(f32), dist.astype(f32),
            haze[:hazy_rows, :, None].astype(f32), first_row, hazy_rows)  # fmt: skip


@lru_cache(maxsize=4)
def _sky_gradient(height: int, horizon: float) -> np.ndarray:
    """Per-row blend factor 0 (horizon) .. 1 (zenith) for the sky."""
    rows = np.arange(height, dtype=np.float64) + 0.5
    return np.clip((horizon - rows) / max(horizon, 1.0), 0.0, 1.0) ** 0.7


def _weather(conditions: Conditions | None) -> dict[str, float]:
    raw = dict(conditions.raw) if conditions is not None else {}

    def val(key: str) -> float:
        try:
            return max(0.0, min(100.0, float(raw.get(key, 0.0)))) / 100.0
        except (TypeError, ValueError):
            return 0.0

    return {
        "cloud": val("cloudiness"),
        "rain": val("precipitation"),
        "deposits": val("precipitation_deposits"),
        "wet": val("wetness"),
        "wind": val("wind_intensity"),
        "illum": float(conditions.illumination) if conditions is not None else 1.0,
        "beta": float(conditions.fog_extinction) if conditions is not None else 0.0,
        "fog_start": float(conditions.fog_start) if conditions is not None else 0.0,
    }


def frame_draws(conditions: Conditions | None) -> bool:
    """Whether :func:`render_frame` draws from its ``rng`` in these conditions (rain
    streaks). If not, a frame is a function of the camera, the ego's pose, the road
    users' views, the conditions and the map alone: the same inputs give the same pixels."""
    return _weather(conditions)["rain"] > 0


def _sky_colors(w: dict[str, float]) -> tuple[np.ndarray, np.ndarray]:
    cloud = w["cloud"]
    zen = SKY_ZENITH * (1 - cloud) + OVERCAST * 0.85 * cloud
    hor = SKY_HORIZON * (1 - cloud) + OVERCAST * cloud
    return zen, hor


def render_frame(
    camera: CameraSpec,
    ego_pose: Pose,
    actors: Sequence[ActorView],
    conditions: Conditions | None,
    road_geometry: Mapping[str, Any] | None,
    rng: np.random.Generator,
    *,
    body_colors: Sequence[tuple[int, int, int]] | None = None,
) -> np.ndarray:
    """Render the ego's dash-cam view.

    Args:
        camera: the camera (size, field of view, mount).
        ego_pose: the ego's pose (vehicle centre) [m, rad].
        actors: other road users (cars, trucks, pedestrians, cyclists by ``kind``).
        conditions: weather quantities (None = clear noon).
        road_geometry: the map's ``render_geometry()`` (road polygons, markings, kerbs);
            None renders plain grass.
        rng: source of the rain streaks' randomness.
        body_colors: one RGB per actor (default: each actor's ``color``, else dark red).

    Returns:
        An HxWx3 uint8 image.
    """
    w = _weather(conditions)
    zen, hor = _sky_colors(w)
    pil, gain, offset = _exposed_background(camera, ego_pose, w, zen, hor, road_geometry)
    # --- road users, far to near ---
    colors = list(body_colors) if body_colors is not None else []
    order = sorted(
        range(len(actors)),
        key=lambda i: -math.hypot(actors[i].pose.x - ego_pose.x, actors[i].pose.y - ego_pose.y),
    )
    ops: list[tuple[list[tuple[float, float]], tuple[int, int, int]]] = []
    fog_c = tuple(float(v) for v in _fog_color(w, hor))
    for i in order:
        ops.extend(
            _actor_polygons(
                camera, ego_pose, actors[i], colors[i] if i < len(colors) else None, w, fog_c
            )
        )
    if ops:
        g_l, o_l = gain.tolist(), offset.tolist()
        lit = [
            (
                op[0],
                tuple(
                    int(min(255.0, max(0.0, c * g + o)))
                    for c, g, o in zip(op[1], g_l, o_l, strict=True)
                ),
                *op[2:],
            )
            for op in ops
        ]
        draw_supersampled(pil, lit)  # type: ignore[arg-type]
    # --- rain ---
    if w["rain"] > 0:
        pil = _rain(pil, w, rng)
    return np.asarray(pil, dtype=np.uint8)


#: The last frame's exposed background, ``(key, texture, image, gain, offset)``: a camera
#: that has not moved (a stopped ego) sees the same ground and sky, so a run's frames
#: while it stands reuse it (a copy: road users are drawn into it).
_LAST_BACKGROUND: list[Any] = [None]


def _exposed_background(
    camera: CameraSpec,
    ego_pose: Pose,
    w: dict[str, float],
    zen: np.ndarray,
    hor: np.ndarray,
    road_geometry: Mapping[str, Any] | None,
) -> tuple[Image.Image, np.ndarray, np.ndarray]:
    """Sky and ground lit, exposed and upscaled to the camera (a new image the caller may
    draw into), and the light map's gain and offset the road users are lit with.

    The exposure is metered on the background alone, so it is a function of the camera,
    the ego's pose, the weather and the map: the same inputs as the last frame's give the
    last frame's result (reused, the same bits)."""
    tex = ground_texture(road_geometry)
    key = (camera, ego_pose.x, ego_pose.y, ego_pose.yaw, tuple(w.items()))
    last = _LAST_BACKGROUND[0]
    if last is not None and last[1] is tex and last[0] == key:
        return last[2].copy(), last[3], last[4]
    # Sky and ground at half resolution (they are smooth), upscaled; vehicles at full.
    small = replace(camera, width=max(2, camera.width // 2), height=max(2, camera.height // 2))
    img = _background(small, ego_pose, w, zen, hor, tex)
    gain, offset = _light(img, w)
    expo = exposure_gain(img[::4, ::4] * gain + offset)  # 1 px in 16 of the half-res frame
    tint = 1.0 + (OVERCAST_TINT - 1.0) * np.float32(w["cloud"])
    gain, offset = gain * expo * tint, offset * expo * tint
    pil = _upscale(Image.fromarray(_expose(img, gain, offset)), camera, small, key[4], gain, offset)
    _LAST_BACKGROUND[0] = (key, tex, pil, gain, offset)
    return pil.copy(), gain, offset


#: Upscaled sky rows by (camera, weather, exposure gain, offset): the top rows of the
#: full-resolution background that only sky pixels reach (see :func:`_upscale`).
_SKY_TOP: dict[tuple[Any, ...], Image.Image] = {}
#: Rows of the half-resolution image kept above the first one the upscale must redo (the
#: bilinear filter reaches one input row; the first two output rows of a cropped resize
#: are the crop edge's, which the cached sky rows cover).
_SKY_MARGIN = 3


def _upscale(
    small_img: Image.Image,
    camera: CameraSpec,
    small: CameraSpec,
    weather: tuple[tuple[str, float], ...],
    gain: np.ndarray,
    offset: np.ndarray,
) -> Image.Image:
    """The exposed half-resolution background bilinearly upscaled to the camera: Pillow's
    resize of the whole image, to the bit, with the sky done once per weather and exposure.

    The rows above the ground (``_ground_rays``' first row) are the weather's sky alone,
    so every frame of one camera, weather and exposure has the same upscaled top rows;
    they are cached and only the rows below (from ``_SKY_MARGIN`` rows above the ground)
    are resized. A cropped resize gives the whole image's output rows away from the crop's
    top edge, so the result is the same to the bit (tests/perception/test_camspeed.py).
    """
    full = (camera.width, camera.height)
    cut = _ground_rays(small)[4] - _SKY_MARGIN
    if full != (2 * small_img.width, 2 * small_img.height) or cut < 1:
        return small_img.resize(full, Image.BILINEAR)
    key = (camera, weather, gain.tobytes(), offset.tobytes())
    top = _SKY_TOP.get(key)
    if top is None:
        pil = small_img.resize(full, Image.BILINEAR)
        if len(_SKY_TOP) >= 8:
            _SKY_TOP.pop(next(iter(_SKY_TOP)))
        _SKY_TOP[key] = pil.crop((0, 0, camera.width, 2 * cut + 2))
        return pil
    box = (0, cut, small_img.width, small_img.height)
    below = small_img.crop(box).resize((camera.width, camera.height - 2 * cut), Image.BILINEAR)
    pil = Image.new("RGB", full)
    pil.paste(below, (0, 2 * cut))
    pil.paste(top, (0, 0))
    return pil


def _expose(img: np.ndarray, gain: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """``clip(img * gain + offset, 0, 255)`` as uint8, per channel, computed in place.

    The per-channel gain and offset are tiled along a row, so numpy runs long inner loops
    over rows instead of three-element ones (the same float32 operations, 5x faster).
    """
    rows = img.reshape(img.shape[0], -1)
    np.multiply(rows, np.tile(gain, img.shape[1]), out=rows)
    np.add(rows, np.tile(offset, img.shape[1]), out=rows)
    np.clip(rows, 0, 255, out=rows)
    return img.astype(np.uint8)


def _actor_polygons(
    camera: CameraSpec,
    ego_pose: Pose,
    actor: ActorView,
    color: tuple[int, int, int] | None,
    w: dict[str, float],
    fog_c: tuple[float, ...],
) -> list[Any]:
    """One actor's screen polygons by its kind: a person, a cyclist or a vehicle."""
    if actor.kind == "pedestrian":
        view = actor if color is None else replace(actor, color=color)
        return person_polygons(camera, ego_pose, view, w, fog_c, FAR, contact_shadow, NEAR)
    if actor.kind == "cyclist":
        view = actor if color is None else replace(actor, color=color)
        return cyclist_polygons(camera, ego_pose, view, w, fog_c, FAR, contact_shadow, NEAR)
    body = color or actor.color or BODY
    return vehicle_polygons(camera, ego_pose, actor, body, w, fog_c, FAR)


def _background(
    camera: CameraSpec,
    ego_pose: Pose,
    w: dict[str, float],
    zen: np.ndarray,
    hor: np.ndarray,
    tex: Any,
) -> np.ndarray:
    """Sky, ground, wet road, puddles and fog as a float32 HxWx3 image.

    Everything that depends only on the camera and the weather (the sky with its fog,
    the per-pixel fog transmittance, the far haze, the sky mirrored in the wet road) is
    computed once per (camera, weather) by :func:`_layers`; each frame samples the road
    texture under the ego's pose and blends it with those layers.
    """
    layers = _layers(camera, tuple(sorted(w.items())), tuple(zen), tuple(hor))
    img = layers.sky.copy()
    fwd, right, _, _, first, _ = _ground_rays(camera)
    if fwd.size:
        c, s = math.cos(ego_pose.yaw), math.sin(ego_pose.yaw)
        cam_x = ego_pose.x + camera.mount_x * c
        cam_y = ego_pose.y + camera.mount_x * s
        wx = cam_x + fwd * c + right * s
        wy = cam_y + fwd * s - right * c
        ground, kind, puddle = tex.sample(
            wx, wy, kind=layers.wet is not None, puddle=layers.puddle_level is not None
        )
        ground = _wet_ground(ground, kind, puddle, layers)
        ground = _fog(ground, layers)
        img[first : first + ground.shape[0]] = ground
        if first + ground.shape[0] < camera.height:  # pragma: no cover - only with an odd camera
            img[first + ground.shape[0] :] = ground[-1:]
    return img


@dataclass(frozen=True)
class _Layers:
    """What a frame's background shares with every other frame of one camera and weather.

    Attributes:
        sky: the whole frame's sky (rows above the ground fogged as the sky is) [float32].
        haze: far-haze blend of the hazy ground rows: (1 - weight, horizon colour x weight).
        fog: fog blend of the ground: (transmittance, fog colour x (1 - transmittance)),
            None without fog.
        wet: wet-road darkening per surface kind, and the sheen of the first ground rows:
            (lut: surface kind x channel, sheen weight per row, mirrored sky x 0.8 on
            those rows), None when dry.
        puddle_level: puddle-field value below which a road texel is a puddle (None: no
            deposits), with the mirrored sky x 0.55 per ground pixel (the same per row).
    """

    sky: np.ndarray
    haze: tuple[np.ndarray, np.ndarray]
    fog: tuple[np.ndarray, np.ndarray] | None
    wet: tuple[np.ndarray, np.ndarray, np.ndarray] | None
    puddle_level: float | None
    puddle_sky: np.ndarray


@lru_cache(maxsize=8)
def _layers(
    camera: CameraSpec,
    weather: tuple[tuple[str, float], ...],
    zen_t: tuple[float, ...],
    hor_t: tuple[float, ...],
) -> _Layers:
    """The per-(camera, weather) layers of :func:`_background` (cached: a run renders all
    its frames in one weather)."""
    w = dict(weather)
    zen, hor = np.array(zen_t), np.array(hor_t)
    h_px, w_px = camera.height, camera.width
    horizon = 0.5 * h_px
    sky = np.empty((h_px, w_px, 3), dtype=np.float32)
    g = _sky_gradient(h_px, horizon)[:, None]
    sky[:] = (hor[None, :] * (1 - g) + zen[None, :] * g)[:, None, :].astype(np.float32)
    sky_row = sky[:, 0, :].copy()
    _, _, dist, haze, first, _ = _ground_rays(camera)
    # Sky under fog: infinitely far, so fully fog-coloured once there is any fog.
    if w["beta"] > 0:
        t_sky = fog_transmittance(w["beta"], w["fog_start"], FAR * 2)
        sky[:first] = sky[:first] * t_sky + _fog_color(w, hor) * (1 - t_sky)
    hor32 = hor.astype(np.float32)
    fog = None
    if w["beta"] > 0:
        t = _full(fog_transmittance32(w["beta"], w["fog_start"], dist)[..., None])
        fog = (t, _fog_color(w, hor).astype(np.float32) * (1 - t))
    reflect, graze = _mirrored_sky(sky_row, first, dist.shape[0], horizon)
    wet_level = max(w["wet"], 0.6 * w["rain"])
    wet = None
    if wet_level > 0 or w["deposits"] > 0:
        lut = np.array([1.0 - 0.15 * wet_level] + [1.0 - 0.4 * wet_level] * 3, dtype=np.float32)
        lut = np.repeat(lut[:, None], 3, axis=1)  # one row of 3 channels per surface kind
        m = int(np.count_nonzero(graze > 0)) if wet_level > 0 else 0
        sheen = (0.35 * wet_level * graze[:m, None, None]).astype(np.float32)
        wet = (lut, _full(sheen, camera.width), _full(reflect[:m] * 0.8, camera.width))
    puddle = 0.55 * w["deposits"] if w["deposits"] > 0 else None
    haze_blend = (_full(1 - haze), hor32 * haze)
    return _Layers(sky, haze_blend, fog, wet, puddle, _full(reflect * 0.55, camera.width))


#: Relative margin around numpy's ``exp`` within which :func:`fog_transmittance32` checks
#: that rounding to float32 cannot depend on the last bits of the float64 result (4 units
#: in the last place; numpy's float64 ``exp`` is within 1 of ``math.exp``'s).
_EXP_MARGIN = 2.0**-50


def fog_transmittance32(extinction: float, start: float, distance: np.ndarray) -> np.ndarray:
    """:func:`fog_transmittance` of every distance [m], rounded to float32: the same bits as
    calling it per element and rounding, in one numpy pass (~25x faster).

    numpy's ``exp`` may differ from ``math.exp`` in the last bit of a float64 (about 2 %
    of values); that changes the float32 only if the result lies within that bit of a
    float32 rounding boundary. Such elements (``_EXP_MARGIN`` wide, about one in a
    million) are taken from :func:`fog_transmittance` itself, so the result is exact.
    """
    d = np.asarray(distance, dtype=np.float64)
    beyond = d - start
    t64 = np.exp(-extinction * np.where(beyond > 0.0, beyond, 0.0))
    out = t64.astype(np.float32)
    lo = (t64 * (1.0 - _EXP_MARGIN)).astype(np.float32)
    hi = (t64 * (1.0 + _EXP_MARGIN)).astype(np.float32)
    for i in np.flatnonzero(lo != hi).tolist():
        out.flat[i] = fog_transmittance(extinction, start, float(d.flat[i]))
    return out


def _full(a: np.ndarray, width: int | None = None) -> np.ndarray:
    """``a`` (rows x width-or-1 x 3-or-1) broadcast to rows x width x 3 and stored so:
    blending with a whole ground array then runs numpy's long, contiguous inner loops."""
    return np.ascontiguousarray(np.broadcast_to(a, (a.shape[0], width or a.shape[1], 3)))


def _mirrored_sky(
    sky_row: np.ndarray, first: int, n: int, horizon: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per ground row: the sky colour it mirrors when wet (n x 1 x 3, float32) and the
    grazing weight of its wet sheen (1 at the horizon, 0 from half-way down)."""
    rows = np.arange(first, first + n)
    mirror = np.clip((2 * horizon - rows - 1).astype(int), 0, len(sky_row) - 1)
    reflect = sky_row[mirror][:, None, :].astype(np.float32)
    graze = np.clip(1.0 - (rows - horizon) / (0.5 * horizon), 0.0, 1.0)
    return reflect, graze


def _fog_color(w: dict[str, float], hor: np.ndarray) -> np.ndarray:
    return FOG * (1 - 0.3 * w["cloud"]) * 0.6 + hor * 0.4


def _fog(ground: np.ndarray, layers: _Layers) -> np.ndarray:
    """Blend to the fog colour by the fog's transmittance; far ground fades into haze."""
    keep, hazed = layers.haze
    hazy = keep.shape[0]
    if hazy:
        ground[:hazy] = ground[:hazy] * keep + hazed
    if layers.fog is None:
        return ground
    t, fogged = layers.fog
    return ground * t + fogged


def _wet_ground(
    ground: np.ndarray, kind: np.ndarray | None, puddle: np.ndarray | None, layers: _Layers
) -> np.ndarray:
    """Darken the wet road and mirror the sky in puddles (by precipitation deposits)."""
    if layers.wet is None or kind is None:
        return ground
    lut, sheen_row, reflect = layers.wet
    road = kind >= 1
    ground *= np.take(lut, kind, axis=0)  # lut's rows are per channel already
    m = sheen_row.shape[0]
    if m:
        sheen = sheen_row * np.repeat(road[:m, :, None], 3, axis=2)
        ground[:m] = ground[:m] * (1 - sheen) + reflect * sheen
    if layers.puddle_level is not None and puddle is not None:
        # Every pixel computed, the puddles' kept: the same float32 operations per
        # puddle pixel as gathering them, without the gather and scatter of rows of 3.
        wet = np.repeat((puddle < layers.puddle_level) & road, 3).reshape(ground.shape)
        mirrored = ground * 0.35
        mirrored += layers.puddle_sky
        ground = np.where(wet, mirrored, ground)
    return ground


def metered_luminance(img: np.ndarray) -> float:
    """The histogram metering of a frame (0..255 display values): the mean log2 of the
    linear luminance of the pixels between the ``EXPOSURE_LOW_PERCENT`` and
    ``EXPOSURE_HIGH_PERCENT`` percentiles, as a linear luminance in (0, 1].

    Luminance is taken on display values (Rec. 709 weights), then linearised (gamma 2.2).
    """
    y = img.reshape(-1, 3) @ np.asarray([0.2126, 0.7152, 0.0722], dtype=np.float32)
    y = np.sort(np.clip(y, 1.0, 255.0))
    n = y.size
    band = y[int(n * EXPOSURE_LOW_PERCENT / 100) : max(int(n * EXPOSURE_HIGH_PERCENT / 100), 1)]
    if not band.size:
        band = y[-1:]
    return float(2.0 ** (2.2 * (np.mean(np.log2(band)) - math.log2(255.0))))


def exposure_gain(img: np.ndarray) -> float:
    """The camera's steady-state exposure for a frame, as a gain on display values.

    The exposure brings the metered luminance to ``EXPOSURE_REFERENCE`` (clear noon), but
    only within CARLA's window: at most ``EXPOSURE_MAX_BRIGHT - EXPOSURE_MIN_BRIGHT`` EV
    brighter, never darker (clear noon sits at the top of the window).
    """
    metered = max(metered_luminance(img), 1e-6)
    window = EXPOSURE_MAX_BRIGHT - EXPOSURE_MIN_BRIGHT
    ev = min(max(math.log2(EXPOSURE_REFERENCE / metered), 0.0), window)
    return float(2.0 ** (ev / 2.2))  # linear gain 2**ev on gamma-2.2 display values


def _light(img: np.ndarray, w: dict[str, float]) -> tuple[float, np.ndarray]:
    """The affine light map ``c -> c * gain + offset`` before exposure: the scene's light
    (``illumination`` scales the linear radiance, so display values by its 1/2.2 power).

    No offset: cloud does not pull colours towards grey. Diffuse light changes the
    shading of faces and the shadows (``_vehicle._shade``, ``contact_shadow``), not the
    ratio of two surfaces' reflectances, so after the exposure a car keeps its contrast
    against the road (an earlier version flattened the whole frame by 35 % at full cloud,
    which made cloud a stronger blinder than dense fog)."""
    del img  # the light map is uniform: it does not depend on the frame
    illum = max(0.05, min(1.0, w["illum"]))
    return illum ** (1.0 / 2.2), np.zeros(3, dtype=np.float32)


@lru_cache(maxsize=8)
def _rain_tile(h: int, w: int, level: int, wind: int) -> np.ndarray:
    """A 2h x 2w streak-opacity tile for a rain level and wind (tenths), fixed seed.

    Each frame shows a window of it at an offset drawn from the run's rng, so streaks move
    between frames without drawing thousands of lines per frame.
    """
    rain, wnd = level / 10.0, wind / 10.0
    rng = np.random.default_rng(level * 31 + wind)
    count = int(6000 * rain)
    mask = Image.new("L", (2 * w, 2 * h), 0)
    d = ImageDraw.Draw(mask)
    xs = rng.uniform(0, 2 * w, count)
    ys = rng.uniform(0, 2 * h, count)
    lens = rng.uniform(8.0, 22.0 + 20.0 * rain, count)
    slant = 0.15 + 0.9 * wnd
    dx, dy = slant / math.hypot(slant, 1.0), 1.0 / math.hypot(slant, 1.0)
    val = int(60 + 70 * rain)
    for x, y, ln in zip(xs.tolist(), ys.tolist(), lens.tolist(), strict=True):
        d.line((x, y, x + dx * ln, y + dy * ln), fill=val, width=1)
    return np.asarray(mask, dtype=np.uint8)


def _rain(img: Image.Image, w: dict[str, float], rng: np.random.Generator) -> Image.Image:
    """Semi-transparent streaks, slanted by the wind, more and longer with precipitation;
    spray and drops on the lens wash the image out a little."""
    wd, h = img.size
    tile = _rain_tile(h, wd, max(1, round(10 * w["rain"])), round(10 * w["wind"]))
    oy, ox = int(rng.integers(0, h)), int(rng.integers(0, wd))
    mask = Image.fromarray(tile[oy : oy + h, ox : ox + wd])
    washed = img.point(_blend_table(190, 0.12 * w["rain"]))
    washed.paste(_flat_image(img.size, 215), None, mask)  # Image.composite, in place
    return washed


@lru_cache(maxsize=8)
def _blend_table(grey: int, alpha: float) -> list[int]:
    """``Image.blend(image, grey image, alpha)`` as a point table (per channel): Pillow's
    own blend of every value 0..255, so the same bits as blending the frame, in a third of
    the time (a pixel's blend depends on its value alone)."""
    ramp = Image.fromarray(np.repeat(np.arange(256, dtype=np.uint8)[None, :, None], 3, axis=2))
    out = np.asarray(Image.blend(ramp, Image.new("RGB", (256, 1), (grey,) * 3), alpha))
    return out[0].T.reshape(-1).tolist()


@lru_cache(maxsize=4)
def _flat_image(size: tuple[int, int], grey: int) -> Image.Image:
    """A uniform grey RGB image (cached; Pillow's blend and composite do not modify it)."""
    return Image.new("RGB", size, (grey, grey, grey))


#: A vehicle narrower than this in the frame [px] is below one input pixel of the 300x300
#: detector (the frame is scaled by 0.375), so it cannot be detected.
MIN_VISIBLE_PX = 2.0


#: ActorView kinds that are vehicles: the stack's ``min_box_width`` gate applies to them.
VEHICLE_KINDS = frozenset({"car", "truck"})
#: ActorView kind -> the detector's class label it is reported as.
KIND_CLASS = {"car": "car", "truck": "car", "pedestrian": "person", "cyclist": "bicycle"}


def actors_in_view(
    camera: CameraSpec,
    ego_pose: Pose,
    actors: Sequence[ActorView],
    min_px: float = MIN_VISIBLE_PX,
    min_sizes: Mapping[str, tuple[float, float]] | None = None,
    window: tuple[float, float] | None = None,
    spread: float = 0.5,
) -> bool:
    """Whether any actor's box is big enough in the image, and near enough to where the
    stack looks, to matter to the stack.

    Camera-mode backends use this to skip rendering and detection of frames that can hold
    no relevant road user (the stack then gets an empty detection list), which roughly
    halves the cost of a run; see docs/camera.md for the measured false-positive rate it
    ignores.

    Args:
        min_px: the narrowest vehicle box [px] that counts (the stack's ``min_box_width``
            gate); it applies to cars and trucks only.
        min_sizes: per class label (``car``, ``person``, ``bicycle``): the smallest box
            (width, height) [px] that counts for actors reported as that class; a class
            missing here counts at :data:`MIN_VISIBLE_PX` (any visible pedestrian or
            cyclist is rendered, so a car-width gate never hides a person). An entry for
            ``car`` overrides ``min_px``.
        window: the open interval (lo, hi) [px] of box centres the stack acts on (its
            ``centre_window`` times the image width); None = anywhere. An actor counts
            only if a detection of it could have its centre inside: its clipped true box,
            widened by ``spread`` times its width on each side, overlaps the window.
        spread: how far outside an actor's true box a detection's centre may lie, as a
            fraction of the box width (the backend passes ``(1 / frame_gate - 1) / 2``:
            a detection up to ``1 / frame_gate`` times as wide as the true box that
            covers its centre).
    """
    sizes = min_sizes or {}
    for actor in actors:
        proj = project_box(camera, ego_pose, actor)
        if proj is None or not proj.visible:
            continue
        label = KIND_CLASS.get(actor.kind, "car")
        default = min_px if actor.kind in VEHICLE_KINDS else MIN_VISIBLE_PX
        min_w, min_h = sizes.get(label, (default, 0.0))
        width = proj.width
        if width >= max(min_w, MIN_VISIBLE_PX) and proj.height >= min_h:
            if window is None:
                return True
            x0, x1 = proj.box[0] - spread * width, proj.box[2] + spread * width
            if x0 < window[1] and x1 > window[0]:
                return True
    return False


def vehicles_in_view(
    camera: CameraSpec, ego_pose: Pose, actors: Sequence[ActorView], min_px: float = MIN_VISIBLE_PX
) -> bool:
    """:func:`actors_in_view` with the vehicle gate only (the backends' call): vehicles
    count from ``min_px`` wide, pedestrians and cyclists whenever visible."""
    return actors_in_view(camera, ego_pose, actors, min_px)
