"""Body colours of the other vehicle (OV): a palette with real-world shares, and contrast.

The OV's colour is drawn once per run from :data:`PALETTE`, whose shares are the global
colour distribution of new light vehicles in the BASF Color Report 2021 for Automotive
OEM Coatings (global overview: white 37 %, black 17 %, grey 15 %, blue 9 %, red 6 %,
brown 2 %, beige, gold, orange, green and yellow about 1 % each; silver is the rest,
9 %). A hyperspace that declares an ``ov_color`` element fixes it instead (a palette
name or an ``[R, G, B]`` list).

The draw has its own random stream, ``default_rng(SeedSequence(seed,
spawn_key=(OV_COLOR_KEY,)))``: adding it shifts no other stream of the run, and it
cannot coincide with the per-frame streams ``default_rng([seed, k])`` (a spawn key is
mixed in after the seed's zero-padded entropy pool; plain entropy lists never are).

:func:`body_contrast` is the PEM's colour feature: the Michelson luminance contrast of
the body against the scene behind and around it (road below the horizon, sky above),
under the scene's light; :func:`detail_contrast` is that of the body against the car's own
dark parts (glass, tyres, trim), which outline it. Both are luminance contrasts; the
detector also prefers some hues to others at the same luminance (saturated red and blue
over beige and gold, docs/camera.md), which :func:`chroma_features` carries: the body's
CIELAB chroma and its two opponent axes (red-green ``a*``, yellow-blue ``b*``), defined
for any RGB colour, so a custom ``ov_color`` gets a value as well as a palette one.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from sitcov.errors import ConfigError

if TYPE_CHECKING:
    from sitcov.weather import Conditions

RGB = tuple[int, int, int]

#: name -> (RGB body colour, share of new vehicles [-]); shares sum to 1.
PALETTE: dict[str, tuple[RGB, float]] = {
    "white": ((226, 226, 222), 0.37),
    "black": ((24, 24, 27), 0.17),
    "grey": ((96, 99, 104), 0.15),
    "silver": ((168, 171, 175), 0.09),
    "blue": ((35, 62, 128), 0.09),
    "red": ((150, 30, 35), 0.06),
    "brown": ((96, 66, 46), 0.02),
    "beige": ((192, 177, 146), 0.01),
    "gold": ((180, 150, 82), 0.01),
    "orange": ((210, 100, 30), 0.01),
    "green": ((40, 86, 56), 0.01),
    "yellow": ((222, 190, 40), 0.01),
}
#: Spawn key of the OV colour's random stream (see the module docstring). "COL" in ASCII.
OV_COLOR_KEY = 0x434F4C
#: The colour of an actor that declares none (the OV of earlier versions).
DEFAULT_COLOR: RGB = PALETTE["red"][0]

#: Relative luminance of the road (asphalt) and of the sky (clear, overcast) the body is
#: seen against, in the renderer's units (linear 0..1); see sitcov/perception/_texture.py.
ROAD_LUMINANCE = 0.10
SKY_CLEAR_LUMINANCE = 0.55
SKY_OVERCAST_LUMINANCE = 0.40
#: Relative luminance of the car's dark parts (glass, tyres, trim; _vehicle.GLASS).
DARK_PARTS_LUMINANCE = 0.027


def palette_names() -> tuple[str, ...]:
    """The palette's colour names, most common first."""
    return tuple(PALETTE)


def color_rng(seed: int) -> np.random.Generator:
    """The OV colour's own random stream of run ``seed``."""
    return np.random.default_rng(np.random.SeedSequence(int(seed), spawn_key=(OV_COLOR_KEY,)))


def _palette_cdf() -> np.ndarray:
    """The palette's cumulative shares, as ``Generator.choice(n, p=shares)`` builds them
    (``p.cumsum()`` divided by its last entry)."""
    shares = np.asarray([share for _, share in PALETTE.values()])
    cdf = (shares / shares.sum()).cumsum()
    cdf /= cdf[-1]
    return cdf


_NAMES, _CDF = tuple(PALETTE), _palette_cdf()


def draw_color(rng: np.random.Generator) -> str:
    """A palette name drawn by the palette's shares: ``rng.choice(len(PALETTE), p=shares)``
    done as that call does it (one ``rng.random()`` placed in the cumulative shares), the
    same draw and name, without its per-call checks (it runs once per run)."""
    return _NAMES[int(_CDF.searchsorted(rng.random(), side="right"))]


def resolve_color(value: Any, *, field: str = "ov_color") -> RGB:
    """An RGB triple from a palette name or an ``[R, G, B]`` list (0..255 each)."""
    if isinstance(value, str):
        key = value.strip().lower().replace("gray", "grey")
        if key in PALETTE:
            return PALETTE[key][0]
    elif isinstance(value, Sequence) and len(value) == 3:
        try:
            rgb = tuple(int(v) for v in value)
        except (TypeError, ValueError):
            rgb = ()
        if len(rgb) == 3 and all(0 <= v <= 255 for v in rgb):
            return rgb  # type: ignore[return-value]
    raise ConfigError(
        field=field,
        value=value,
        expected=f"a colour name ({', '.join(PALETTE)}) or [R, G, B] with 0..255",
    )


def ov_color(values: Mapping[str, Any], seed: int) -> RGB:
    """The OV's colour in a run: the situation's ``ov_color`` if any, else drawn by shares."""
    declared = values.get("ov_color")
    if declared is not None:
        return resolve_color(declared)
    return PALETTE[draw_color(color_rng(seed))][0]


def luminance(rgb: Sequence[float]) -> float:
    """Relative luminance (Rec. 709 weights) of an sRGB colour 0..255, linearised."""
    lin = [(max(0.0, float(c)) / 255.0) ** 2.2 for c in rgb]
    return 0.2126 * lin[0] + 0.7152 * lin[1] + 0.0722 * lin[2]


def body_contrast(rgb: Sequence[float] | None, conditions: Conditions | None) -> float:
    """Michelson contrast in [0, 1] of the body against its surroundings under the light.

    The body is lit by the sun and the sky (its direct part fades with cloud, as in the
    renderer's shading); the background is half road (darkened when wet) and half sky
    (greyer under cloud). Overall light level cancels out, as it does under the camera's
    auto-exposure; what remains is the colour's own contrast and the share of direct light.
    """
    cloud = wet = 0.0
    if conditions is not None:
        raw = conditions.raw
        cloud = _unit(raw.get("cloudiness", 0.0))
        wet = max(_unit(raw.get("wetness", 0.0)), 0.6 * _unit(raw.get("precipitation", 0.0)))
    body = luminance(rgb if rgb is not None else DEFAULT_COLOR) * (0.75 + 0.35 * (1 - 0.8 * cloud))
    road = ROAD_LUMINANCE * (1.0 - 0.4 * wet)
    sky = SKY_CLEAR_LUMINANCE * (1 - cloud) + SKY_OVERCAST_LUMINANCE * cloud
    back = 0.5 * (road + sky)
    return abs(body - back) / (body + back)


def detail_contrast(rgb: Sequence[float] | None) -> float:
    """Signed Michelson contrast in [-1, 1] of the body against the car's own dark parts
    (glass, tyres, trim): the contrast that outlines windows, wheels and bumpers. Black
    and dark bodies lose it (negative or near 0); light bodies keep it (near 1)."""
    body = luminance(rgb if rgb is not None else DEFAULT_COLOR)
    return (body - DARK_PARTS_LUMINANCE) / (body + DARK_PARTS_LUMINANCE)


def color_features(
    rgb: Sequence[float] | None, conditions: Conditions | None
) -> tuple[float, float]:
    """The PEM's colour features of a body colour under ``conditions``:
    (:func:`body_contrast`, :func:`detail_contrast`)."""
    return body_contrast(rgb, conditions), detail_contrast(rgb)


def srgb_to_lab(rgb: Sequence[float]) -> tuple[float, float, float]:
    """CIELAB (L*, a*, b*) of an sRGB colour 0..255 (D65 white, IEC 61966-2-1 transfer)."""
    lin = []
    for c in rgb:
        v = min(max(float(c), 0.0), 255.0) / 255.0
        lin.append(v / 12.92 if v <= 0.04045 else ((v + 0.055) / 1.055) ** 2.4)
    r, g, b = lin
    x = (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047
    y = 0.2126 * r + 0.7152 * g + 0.0722 * b
    z = (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883
    fx, fy, fz = _lab_f(x), _lab_f(y), _lab_f(z)
    return 116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)


def _lab_f(t: float) -> float:
    eps = (6.0 / 29.0) ** 3
    return t ** (1.0 / 3.0) if t > eps else t / (3.0 * (6.0 / 29.0) ** 2) + 4.0 / 29.0


def chroma_features(rgb: Sequence[float] | None) -> tuple[float, float, float]:
    """The PEM's hue features of a body colour: (chroma, red_green, yellow_blue), the
    CIELAB ``C*``, ``a*`` and ``b*`` over 100 (greys are (0, 0, 0); red is about
    (0.57, 0.49, 0.29), blue (0.43, 0.14, -0.40), gold (0.40, 0.03, 0.40)). They let the
    fit tell hues of equal luminance apart, which the contrast features cannot."""
    _, a, b = srgb_to_lab(rgb if rgb is not None else DEFAULT_COLOR)
    return math.hypot(a, b) / 100.0, a / 100.0, b / 100.0


def _unit(value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        return 0.0
    return 0.0 if math.isnan(v) else min(100.0, max(0.0, v)) / 100.0
