"""A top-down raster of the road map that the renderer's ground pixels sample.

Rasterised once per map geometry with Pillow (road polygons, kerbs, lane markings), plus a
smooth value-noise field deciding where puddles form as deposits rise. Cached by the
geometry object's identity, so a campaign builds it once per process.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

#: Texture resolution [m/px] (coarsened for very large maps).
RESOLUTION = 0.1
#: Largest texture side [px].
MAX_SIDE = 4096
#: Margin around the map geometry [m].
MARGIN = 40.0
#: Surface colours.
GRASS = (78, 104, 58)
ROAD = (92, 92, 96)
KERB = (165, 165, 160)
WHITE = (225, 225, 220)
YELLOW = (220, 180, 40)
#: Marking width [m], kerb width [m], dash and gap lengths [m].
MARK_W, KERB_W, DASH, GAP = 0.15, 0.3, 3.0, 6.0

_NAMED = {"white": WHITE, "yellow": YELLOW}


@dataclass
class GroundTexture:
    """The rasterised map: colour, surface kind (0 grass, 1 road, 2 marking, 3 kerb) and a
    puddle field in [0, 1) (a pixel is a puddle when its value is below the deposit level).

    For lookups the texels are also kept flat, with one extra texel at the end that stands
    for everything off the map (grass, kind 0, no puddle), and the colour packed as one
    32-bit word per texel: a lookup is then one gather of whole words per pixel."""

    x0: float
    y0: float
    res: float
    color: np.ndarray
    kind: np.ndarray
    puddle: np.ndarray
    _flat: tuple[np.ndarray, np.ndarray, np.ndarray] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        n = self.kind.size
        rgba = np.zeros((n + 1, 4), dtype=np.uint8)
        rgba[:n, :3] = self.color.reshape(-1, 3)
        rgba[n, :3] = GRASS
        kinds = np.append(self.kind.reshape(-1), np.zeros(1, self.kind.dtype))
        puddles = np.append(self.puddle.reshape(-1), np.ones(1, self.puddle.dtype))
        self._flat = (rgba.view(np.uint32).reshape(-1), kinds, puddles)

    def sample(
        self, wx: np.ndarray, wy: np.ndarray, *, kind: bool = True, puddle: bool = True
    ) -> tuple[np.ndarray, np.ndarray | None, np.ndarray | None]:
        """Nearest-texel colour (float32), kind and puddle value at world points [m];
        points off the map are grass (kind 0, puddle value 1).

        ``kind=False`` / ``puddle=False`` skip looking those up (None is returned in their
        place): a dry road needs neither, a road without deposits no puddles.
        """
        h, w = self.kind.shape
        ix = ((wx - self.x0) / self.res).astype(np.int64)
        iy = ((wy - self.y0) / self.res).astype(np.int64)
        inside = (ix >= 0) & (ix < w) & (iy >= 0) & (iy < h)
        flat = iy * w + ix
        if not inside.all():
            flat = np.where(inside, flat, h * w)
        rgba, kinds, puddles = self._flat
        color = rgba[flat].view(np.uint8).reshape(*flat.shape, 4)[..., :3].astype(np.float32)
        return (
            color,
            kinds[flat] if kind else None,
            puddles[flat] if puddle else None,
        )


_CACHE: dict[int, tuple[Any, GroundTexture]] = {}


def ground_texture(geometry: Mapping[str, Any] | None) -> GroundTexture:
    """The texture of ``geometry`` (built on first use, then cached)."""
    key = id(geometry)
    hit = _CACHE.get(key)
    if hit is not None and hit[0] is geometry:
        return hit[1]
    tex = build_texture(geometry)
    if len(_CACHE) >= 4:
        _CACHE.pop(next(iter(_CACHE)))
    _CACHE[key] = (geometry, tex)
    return tex


def _points(seq: Any) -> list[tuple[float, float]]:
    return [(float(p[0]), float(p[1])) for p in seq]


def _color(value: Any) -> tuple[int, int, int]:
    if isinstance(value, str):
        return _NAMED.get(value.lower(), WHITE)
    if isinstance(value, (list, tuple)) and len(value) >= 3:
        return (int(value[0]), int(value[1]), int(value[2]))
    return WHITE


def _dashes(pts: list[tuple[float, float]]) -> list[list[tuple[float, float]]]:
    """Split a polyline into dash segments of DASH metres every DASH+GAP metres."""
    out: list[list[tuple[float, float]]] = []
    period = DASH + GAP
    s = 0.0
    cur: list[tuple[float, float]] = []
    for (x0, y0), (x1, y1) in zip(pts[:-1], pts[1:], strict=False):
        seg = math.hypot(x1 - x0, y1 - y0)
        if seg <= 0:
            continue
        t = 0.0
        while t < seg:
            phase = (s + t) % period
            on = phase < DASH
            step = min(seg - t, (DASH - phase) if on else (period - phase))
            step = max(step, 1e-6)
            a = (x0 + (x1 - x0) * t / seg, y0 + (y1 - y0) * t / seg)
            b = (x0 + (x1 - x0) * (t + step) / seg, y0 + (y1 - y0) * (t + step) / seg)
            if on:
                if not cur:
                    cur = [a]
                cur.append(b)
            elif cur:
                out.append(cur)
                cur = []
            t += step
        s += seg
    if cur:
        out.append(cur)
    return out


def _value_noise(h: int, w: int, cell: int, seed: int = 7) -> np.ndarray:
    """Smooth noise in [0, 1): bilinear upsampling of a coarse random grid (fixed seed)."""
    rng = np.random.default_rng(seed)
    gh, gw = h // cell + 2, w // cell + 2
    grid = Image.fromarray((rng.random((gh, gw)) * 255).astype(np.uint8))
    big = grid.resize((gw * cell, gh * cell), Image.BICUBIC)
    return (np.asarray(big, dtype=np.float32)[:h, :w] / 256.0).astype(np.float16)


def build_texture(geometry: Mapping[str, Any] | None) -> GroundTexture:
    """Rasterise road polygons, kerbs and markings of ``render_geometry()``."""
    geometry = geometry or {}
    polys = [_points(p) for p in geometry.get("road_polygons", [])]
    kerbs = [_points(k) for k in geometry.get("kerbs", [])]
    marks = [(m, _points(m.get("points", []))) for m in geometry.get("markings", [])]
    allpts = [p for poly in polys for p in poly] + [p for k in kerbs for p in k]
    allpts += [p for _, pts in marks for p in pts]
    if not allpts:
        allpts = [(-1.0, -1.0), (1.0, 1.0)]
    xs = [p[0] for p in allpts]
    ys = [p[1] for p in allpts]
    x0, y0 = min(xs) - MARGIN, min(ys) - MARGIN
    span = max(max(xs) + MARGIN - x0, max(ys) + MARGIN - y0)
    res = max(RESOLUTION, span / MAX_SIDE)
    w = int(math.ceil((max(xs) + MARGIN - x0) / res))
    h = int(math.ceil((max(ys) + MARGIN - y0) / res))

    def px(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
        return [((x - x0) / res, (y - y0) / res) for x, y in pts]

    color = Image.new("RGB", (w, h), GRASS)
    kind = Image.new("L", (w, h), 0)
    dc, dk = ImageDraw.Draw(color), ImageDraw.Draw(kind)
    for poly in polys:
        if len(poly) >= 3:
            dc.polygon(px(poly), fill=ROAD)
            dk.polygon(px(poly), fill=1)
    kw = max(1, round(KERB_W / res))
    for k in kerbs:
        if len(k) >= 2:
            dc.line(px(k), fill=KERB, width=kw)
            dk.line(px(k), fill=3, width=kw)
    mw = max(1, round(MARK_W / res))
    for m, pts in marks:
        if len(pts) < 2:
            continue
        col = _color(m.get("color", "white"))
        parts = _dashes(pts) if m.get("style") == "dashed" else [pts]
        for part in parts:
            dc.line(px(part), fill=col, width=mw)
            dk.line(px(part), fill=2, width=mw)
    carr = np.asarray(color, dtype=np.uint8)
    # Slight asphalt grain so the road is not a flat colour (fixed seed: a map property).
    grain = np.random.default_rng(3).integers(-6, 7, size=(h, w, 1), dtype=np.int16)
    karr = np.asarray(kind, dtype=np.uint8)
    carr = np.clip(carr.astype(np.int16) + grain, 0, 255).astype(np.uint8)
    puddle = _value_noise(h, w, cell=max(4, round(2.5 / res)))
    return GroundTexture(x0=x0, y0=y0, res=res, color=carr, kind=karr, puddle=puddle)
