"""SSD anchor boxes of the SSD-MobileNetV2 detector (the standard multi-scale generator).

Six feature maps (19, 10, 5, 3, 2, 1 cells for a 300x300 input), scales spread linearly
from 0.2 to 0.95, aspect ratios 1, 2, 1/2, 3, 1/3 plus one interpolated square anchor per
cell; the lowest layer carries only three anchors (a small 0.1 square, and scale 0.2 at
ratios 2 and 1/2). 19*19*3 + (100 + 25 + 9 + 4 + 1)*6 = 1917 anchors, which matches the
model's output tensor.
"""

from __future__ import annotations

import math

import numpy as np

#: Feature-map sizes [cells] of the six prediction layers.
FEATURE_MAPS = (19, 10, 5, 3, 2, 1)
#: Smallest and largest anchor scale, as a fraction of the input side.
MIN_SCALE, MAX_SCALE = 0.2, 0.95
#: Aspect ratios (width / height) of the anchors of every layer but the lowest.
ASPECT_RATIOS = (1.0, 2.0, 0.5, 3.0, 1.0 / 3.0)


def _scale(index: int, layers: int) -> float:
    return MIN_SCALE + (MAX_SCALE - MIN_SCALE) * index / (layers - 1)


def ssd_anchors(feature_maps: tuple[int, ...] = FEATURE_MAPS) -> np.ndarray:
    """All anchors, in the order the model emits its predictions.

    Returns:
        (N, 4) float32 array of (y_center, x_center, height, width), normalised to [0, 1].
    """
    layers = len(feature_maps)
    rows: list[tuple[float, float, float, float]] = []
    for layer, size in enumerate(feature_maps):
        scale = _scale(layer, layers)
        if layer == 0:
            shapes = [(0.1, 1.0), (scale, 2.0), (scale, 0.5)]
        else:
            shapes = [(scale, ar) for ar in ASPECT_RATIOS]
            nxt = 1.0 if layer == layers - 1 else _scale(layer + 1, layers)
            shapes.append((math.sqrt(scale * nxt), 1.0))
        hw = [(s / math.sqrt(ar), s * math.sqrt(ar)) for s, ar in shapes]
        for iy in range(size):
            yc = (iy + 0.5) / size
            for ix in range(size):
                xc = (ix + 0.5) / size
                rows.extend((yc, xc, h, w) for h, w in hw)
    return np.asarray(rows, dtype=np.float32)


def decode_boxes(
    raw: np.ndarray, anchors: np.ndarray, scales: tuple[float, float, float, float] = (10, 10, 5, 5)
) -> np.ndarray:
    """Decode the box regressions (dy, dx, dh, dw) against the anchors.

    Args:
        raw: (N, 4) model output in (y, x, h, w) order.
        anchors: (N, 4) from :func:`ssd_anchors`.
        scales: the box coder's (y, x, h, w) scale factors.

    Returns:
        (N, 4) boxes (x_min, y_min, x_max, y_max), normalised to the input frame.
    """
    ya, xa, ha, wa = anchors.T
    yc = raw[:, 0] / scales[0] * ha + ya
    xc = raw[:, 1] / scales[1] * wa + xa
    h = np.exp(raw[:, 2] / scales[2]) * ha
    w = np.exp(raw[:, 3] / scales[3]) * wa
    return np.stack([xc - w / 2, yc - h / 2, xc + w / 2, yc + h / 2], axis=1)
