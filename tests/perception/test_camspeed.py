"""The camera path's speed work keeps its outputs: cached layers, in-place exposure,
letterbox buffer and best-logit scores give what the plain computations give."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from sitcov.perception import ActorView, CameraSpec, Pose, render_frame
from sitcov.perception import _renderer as R
from sitcov.perception._texture import ground_texture
from sitcov.sim import conditions_from_values

CAM = CameraSpec()
WET_FOG = {"precipitation": 60, "precipitation_deposits": 70, "wetness": 50, "fog_density": 30}


def _scene(ego: Pose) -> tuple[ActorView, ...]:
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)

    def at(fwd: float, left: float) -> Pose:
        return Pose(ego.x + fwd * c - left * s, ego.y + fwd * s + left * c, ego.yaw + 0.6)

    return (
        ActorView(at(14.0, 1.0), 4.5, 1.9, 1.5, color=(30, 60, 160)),
        ActorView(at(9.0, -2.0), 0.5, 0.5, 1.75, speed=1.2, kind="pedestrian"),
    )


def _render(geometry, ego, values, seed=3) -> np.ndarray:
    cond = conditions_from_values(values)
    return render_frame(CAM, ego, _scene(ego), cond, geometry, np.random.default_rng(seed))


def test_cached_weather_layers_do_not_leak_between_weathers(tjunction_geometry) -> None:
    geometry, ego = tjunction_geometry
    R._layers.cache_clear()
    wet_first = _render(geometry, ego, WET_FOG)
    clear_after_wet = _render(geometry, ego, {})
    wet_again = _render(geometry, ego, WET_FOG)
    R._layers.cache_clear()
    clear_fresh = _render(geometry, ego, {})
    assert np.array_equal(wet_first, wet_again)
    assert np.array_equal(clear_after_wet, clear_fresh)
    assert np.abs(wet_first.astype(int) - clear_fresh.astype(int)).mean() > 5.0


def test_a_camera_that_has_not_moved_reuses_its_background(tjunction_geometry) -> None:
    """A stopped ego's frames reuse the last exposed background: the same pixels as a
    fresh render, whatever the road users do, and the kept background stays clean."""
    geometry, ego = tjunction_geometry
    cond = conditions_from_values(WET_FOG)
    moved = _scene(Pose(ego.x, ego.y + 0.7, ego.yaw))

    def frame(actors, pose=ego) -> np.ndarray:
        return render_frame(CAM, pose, actors, cond, geometry, np.random.default_rng(5))

    R._LAST_BACKGROUND[0] = None
    first, second, empty = frame(_scene(ego)), frame(moved), frame(())
    assert R._LAST_BACKGROUND[0] is not None
    for actors, reused in ((_scene(ego), first), (moved, second), ((), empty)):
        R._LAST_BACKGROUND[0] = None
        assert np.array_equal(frame(actors), reused)
    other = Pose(ego.x + 0.5, ego.y, ego.yaw)
    assert not np.array_equal(frame((), other), empty)  # the ego moved: a new background
    R._LAST_BACKGROUND[0] = None
    assert np.array_equal(frame((), other), frame((), other))


def test_background_layers_match_the_per_frame_formulas(tjunction_geometry) -> None:
    """Fog and haze from the cached layers equal Beer-Lambert computed on the frame."""
    geometry, ego = tjunction_geometry
    small = CameraSpec(width=CAM.width // 2, height=CAM.height // 2)
    cond = conditions_from_values({"fog_density": 50, "fog_distance": 5})
    w = R._weather(cond)
    zen, hor = R._sky_colors(w)
    img = R._background(small, ego, w, zen, hor, ground_texture(geometry))
    fwd, right, dist, haze, first, hazy = R._ground_rays(small)
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    cx, cy = ego.x + small.mount_x * c, ego.y + small.mount_x * s
    ground = ground_texture(geometry).sample(cx + fwd * c + right * s, cy + fwd * s - right * c)[0]
    ground[:hazy] = ground[:hazy] * (1 - haze) + hor.astype(np.float32) * haze
    t = np.exp(-w["beta"] * np.maximum(dist.astype(np.float64) - w["fog_start"], 0))[..., None]
    want = ground * t + R._fog_color(w, hor) * (1 - t)
    got = img[first : first + ground.shape[0]]
    assert np.abs(got - want).max() < 1e-3  # float32 vs float64 rounding only


def test_expose_is_the_clipped_affine_map() -> None:
    rng = np.random.default_rng(0)
    img = (rng.random((9, 7, 3)) * 400 - 50).astype(np.float32)
    gain = np.array([1.3, 0.9, 1.05], dtype=np.float32)
    offset = np.array([-4.0, 2.5, 10.0], dtype=np.float32)
    want = np.clip(img * gain + offset, 0, 255).astype(np.uint8)
    assert np.array_equal(R._expose(img.copy(), gain, offset), want)


def test_texture_lookup_skips_what_the_weather_does_not_use(tjunction_geometry) -> None:
    geometry, _ = tjunction_geometry
    tex = ground_texture(geometry)
    wx = np.linspace(tex.x0 - 5.0, tex.x0 + 60.0, 40, dtype=np.float32)[None, :]
    wy = np.full_like(wx, tex.y0 + 30.0)
    color, kind, puddle = tex.sample(wx, wy)
    color2, kind2, puddle2 = tex.sample(wx, wy, kind=False, puddle=False)
    assert kind2 is None and puddle2 is None
    assert np.array_equal(color, color2)
    assert kind is not None and puddle is not None and (kind[:, :5] == 0).all()


@pytest.mark.parametrize("shape", [(450, 800), (800, 450), (300, 300), (37, 121)])
def test_letterbox_equals_pasting_on_a_grey_canvas(shape) -> None:
    from PIL import Image

    from sitcov.perception import SSDDetector

    image = np.random.default_rng(1).integers(0, 256, (*shape, 3), dtype=np.uint8)
    scale, px, py = SSDDetector.letterbox(image.shape)
    size = (max(1, round(shape[1] * scale)), max(1, round(shape[0] * scale)))
    canvas = Image.new("RGB", (300, 300), (128, 128, 128))
    canvas.paste(Image.fromarray(image).resize(size, Image.BILINEAR), (round(px), round(py)))
    want = (np.asarray(canvas, dtype=np.float32) * (2.0 / 255.0) - 1.0)[None]
    assert np.array_equal(SSDDetector.preprocess(image), want)


def test_scores_are_the_best_member_sigmoid(ssd_detector) -> None:
    logits = np.random.default_rng(2).normal(0.0, 4.0, (1917, 24)).astype(np.float32)
    scores, groups = ssd_detector._scores(logits)
    sig = 1.0 / (1.0 + np.exp(-logits.astype(np.float64)))
    want = np.concatenate([sig[:, idx].max(axis=1) for _, idx in ssd_detector._groups])
    assert np.array_equal(scores, want)
    assert np.array_equal(groups, np.repeat(np.arange(len(ssd_detector._groups)), 1917))


def test_texture_lookup_equals_the_plain_gather(tjunction_geometry) -> None:
    """Packed texels and the off-map grass texel give the colours, kinds and puddle values
    (and dtypes) of indexing the texture's arrays, on and off the map."""
    geometry, _ = tjunction_geometry
    tex = ground_texture(geometry)
    h, w = tex.kind.shape
    rng = np.random.default_rng(4)
    wx = rng.uniform(tex.x0 - 30.0, tex.x0 + w * tex.res + 30.0, (60, 70)).astype(np.float32)
    wy = rng.uniform(tex.y0 - 30.0, tex.y0 + h * tex.res + 30.0, (60, 70)).astype(np.float32)
    ix = ((wx - tex.x0) / tex.res).astype(np.int64)
    iy = ((wy - tex.y0) / tex.res).astype(np.int64)
    inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
    assert 0 < inside.mean() < 1
    ixc, iyc = np.clip(ix, 0, w - 1), np.clip(iy, 0, h - 1)
    color = tex.color[iyc, ixc].astype(np.float32)
    color[~inside] = (78, 104, 58)
    kind = np.where(inside, tex.kind[iyc, ixc], 0)
    puddle = np.where(inside, tex.puddle[iyc, ixc], 1.0)
    for got, want in zip(tex.sample(wx, wy), (color, kind, puddle), strict=True):
        assert got is not None and got.dtype == want.dtype and np.array_equal(got, want)
    inner = tex.sample(wx[inside][:, None], wy[inside][:, None])[0]
    assert np.array_equal(inner, color[inside][:, None])


@pytest.mark.parametrize("margin", [R._EXP_MARGIN, 2.0**-12])
def test_fog_transmittance32_is_the_scalar_law_rounded(monkeypatch, margin) -> None:
    """Per element, the float32 of :func:`fog_transmittance`; a wide margin sends many
    elements through the scalar fallback, with the same result."""
    from sitcov.weather import fog_transmittance

    monkeypatch.setattr(R, "_EXP_MARGIN", margin)
    dist = R._ground_rays(CameraSpec(width=400, height=225))[2]
    for beta, start in ((0.0391, 0.0), (0.13, 40.0), (0.0078, 4.5), (0.3, 80.0)):
        want = np.array([fog_transmittance(beta, start, float(d)) for d in dist.ravel()])
        got = R.fog_transmittance32(beta, start, dist)
        assert got.dtype == np.float32 and got.shape == dist.shape
        assert np.array_equal(got.ravel(), want.astype(np.float32))


@pytest.mark.parametrize("rain", [0.2, 0.73, 1.0])
def test_rain_blend_table_and_in_place_composite_equal_pillow(rain) -> None:
    from PIL import Image

    rng = np.random.default_rng(6)
    img = Image.fromarray(rng.integers(0, 256, (45, 80, 3), dtype=np.uint8))
    w = {"rain": rain, "wind": 0.4}
    got = np.asarray(R._rain(img, w, np.random.default_rng(9)))
    r = np.random.default_rng(9)
    tile = R._rain_tile(45, 80, max(1, round(10 * rain)), 4)
    oy, ox = int(r.integers(0, 45)), int(r.integers(0, 80))
    mask = Image.fromarray(tile[oy : oy + 45, ox : ox + 80])
    washed = Image.blend(img, Image.new("RGB", img.size, (190,) * 3), 0.12 * rain)
    want = Image.composite(Image.new("RGB", img.size, (215,) * 3), washed, mask)
    assert np.array_equal(got, np.asarray(want))
    assert np.asarray(mask).any()


@pytest.mark.parametrize("values", [{"wetness": 80}, {"precipitation_deposits": 80, "wetness": 60}])
def test_wet_ground_equals_the_plain_formulas(tjunction_geometry, values) -> None:
    """The per-kind-and-channel darkening table and the whole-array puddle blend give
    what gathering the puddle pixels and a per-kind factor give."""
    geometry, ego = tjunction_geometry
    small = CameraSpec(width=CAM.width // 2, height=CAM.height // 2)
    w = R._weather(conditions_from_values(values))
    zen, hor = R._sky_colors(w)
    layers = R._layers(small, tuple(sorted(w.items())), tuple(zen), tuple(hor))
    assert layers.wet is not None
    lut = layers.wet[0]
    assert lut.shape == (4, 3) and (lut == lut[:, :1]).all()
    fwd, right, _, _, _, _ = R._ground_rays(small)
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    ground, kind, puddle = ground_texture(geometry).sample(
        ego.x + fwd * c + right * s, ego.y + fwd * s - right * c
    )
    assert kind is not None and puddle is not None and len(np.unique(kind)) > 1
    m = layers.wet[1].shape[0]
    road = kind >= 1
    want = ground * lut[:, 0][kind][..., None]
    sheen = layers.wet[1] * np.repeat(road[:m, :, None], 3, axis=2)
    want[:m] = want[:m] * (1 - sheen) + layers.wet[2] * sheen
    if layers.puddle_level is not None:
        r, cc = np.nonzero((puddle < layers.puddle_level) & road)
        assert r.size > 100
        want[r, cc] = want[r, cc] * 0.35 + layers.puddle_sky[r, 0]
    assert np.array_equal(R._wet_ground(ground.copy(), kind, puddle, layers), want)
    dry = replace(layers, wet=None, puddle_level=None)
    assert R._wet_ground(ground, kind, puddle, dry) is ground


def test_network_input_table_is_the_pixel_formula() -> None:
    from sitcov.perception import _detector as D

    values = np.arange(256, dtype=np.uint8)
    assert np.array_equal(D._INPUT_OF[values], values.astype(np.float32) * (2.0 / 255.0) - 1.0)


@pytest.mark.parametrize("values", [{}, WET_FOG, {"cloudiness": 100, "fog_density": 80}])
def test_upscale_with_cached_sky_rows_equals_pillows_resize(tjunction_geometry, values) -> None:
    """Frames of one weather and exposure share their upscaled sky rows: the cached rows
    plus a cropped resize of the rest give Pillow's resize of the whole image."""
    from PIL import Image

    geometry, ego = tjunction_geometry
    small = CameraSpec(width=CAM.width // 2, height=CAM.height // 2)
    w = R._weather(conditions_from_values(values))
    zen, hor = R._sky_colors(w)
    gain = np.full(3, 1.25, dtype=np.float32)
    offset = np.zeros(3, dtype=np.float32)
    R._SKY_TOP.clear()
    for k, step in enumerate((0.0, 3.0, 7.5)):
        pose = Pose(ego.x + step * math.cos(ego.yaw), ego.y + step * math.sin(ego.yaw), ego.yaw)
        img = R._background(small, pose, w, zen, hor, ground_texture(geometry))
        half = Image.fromarray(R._expose(img, gain, offset))
        got = R._upscale(half, CAM, small, tuple(w.items()), gain, offset)
        assert len(R._SKY_TOP) == 1  # the first frame filled it, the others reused it
        want = half.resize((CAM.width, CAM.height), Image.BILINEAR)
        assert np.array_equal(np.asarray(got), np.asarray(want)), k


def test_a_cropped_bilinear_upscale_keeps_rows_below_the_crop_edge() -> None:
    """What :func:`R._upscale` relies on: Pillow's 2x bilinear resize of rows ``c:`` gives
    the whole image's output rows from ``2 c + 2`` on, to the bit, and the output rows
    above those (the cached sky rows) only read input rows above ``c + _SKY_MARGIN``
    (the first ground row)."""
    from PIL import Image

    rng = np.random.default_rng(8)
    for h, w in ((225, 400), (37, 64), (120, 91)):
        a = rng.integers(0, 256, (h, w, 3), dtype=np.uint8)
        full = np.asarray(Image.fromarray(a).resize((2 * w, 2 * h), Image.BILINEAR))
        for c in range(1, h - 3, 7):
            part = Image.fromarray(a).crop((0, c, w, h))
            part = part.resize((2 * w, 2 * (h - c)), Image.BILINEAR)
            assert np.array_equal(np.asarray(part)[2:], full[2 * c + 2 :]), (h, w, c)
            b = a.copy()
            b[c + R._SKY_MARGIN :] = rng.integers(0, 256, b[c + R._SKY_MARGIN :].shape)
            other = np.asarray(Image.fromarray(b).resize((2 * w, 2 * h), Image.BILINEAR))
            assert np.array_equal(other[: 2 * c + 2], full[: 2 * c + 2]), (h, w, c)
