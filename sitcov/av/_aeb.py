"""The reference stack's emergency brake as pure functions: the paper's three tests.

A detection of a road user makes the AEB fire when it passes the score, centering and
distance tests (Tahir & Alexander); how "close enough" is judged per class is
:data:`CLASS_SIZE`. The stack (:mod:`sitcov.av._reference`) and the mapping of fault F1
onto our detector (:mod:`sitcov.av._fault_map`) both use these functions.
"""

from __future__ import annotations

import math
from collections.abc import Collection

from sitcov.perception._base import CameraSpec, Detection

#: How the distance test judges "close enough" per detection class: which extent of the
#: box [px] stands for closeness, and the factor that makes it car-equivalent. A car's
#: box WIDTH is the paper's measure. A person's box is tall and narrow, and its width
#: hardly depends on the distance the way a car's does (0.5 m shoulders, arms swinging),
#: so its HEIGHT is used, scaled by car width / person height (1.61 m / 1.75 m): a person
#: then passes the test at the distance a car seen from behind would. A cyclist's width
#: changes with its heading (0.6 m head-on, 1.8 m side-on) but its height (1.7 m) does
#: not, so its height scaled by 1.61 / 1.7 is used. Other classes use the width.
CLASS_SIZE: dict[str, tuple[str, float]] = {
    "car": ("width", 1.0),
    "person": ("height", 1.61 / 1.75),
    "bicycle": ("height", 1.61 / 1.7),
}


def aeb_test(
    detection: Detection,
    image_width: float,
    threshold: float,
    centering: tuple[float, float],
    distance: float,
    label: str | Collection[str] = "car",
) -> bool:
    """The paper's three tests on one detection; True means "brake now".

    1. ``score >= threshold`` (and the detection's class is ``label`` or in it);
    2. ``lo < mid_x < hi`` with mid_x the box centre over the image width;
    3. ``round((1 - size / image_width) ** 4, 1) <= distance`` (a bigger box means a
       closer road user), ``size`` the box width for a car and the scaled box height for
       a person or a cyclist (:data:`CLASS_SIZE`).
    """
    cls = detection.label
    if (cls != label if isinstance(label, str) else cls not in label) or (
        detection.score < threshold
    ):
        return False
    x0, y0, x1, y1 = detection.box
    mid_x = 0.5 * (x0 + x1) / image_width
    if not centering[0] < mid_x < centering[1]:
        return False
    axis, scale = CLASS_SIZE.get(cls, ("width", 1.0))
    size = (x1 - x0) if axis == "width" else (y1 - y0) * scale
    ratio = size / image_width
    return round((1.0 - ratio) ** 4, 1) <= distance


def aeb_min_box_width(distance: float) -> float:
    """The narrowest box (fraction of the image width) that can pass the distance test.

    ``round((1 - r) ** 4, 1) <= distance`` needs ``(1 - r) ** 4 < q + 0.05`` with ``q``
    the distance rounded down to a tenth.
    """
    tenth = math.floor(distance * 10.0) / 10.0
    return max(0.0, 1.0 - min(tenth + 0.05, 1.0) ** 0.25)


def aeb_min_box_sizes(
    distance: float, classes: Collection[str], camera: CameraSpec
) -> dict[str, tuple[float, float]]:
    """Per class judged by height (:data:`CLASS_SIZE`): the smallest box (width, height
    fractions of the image) whose scaled height can pass the distance test."""
    width = aeb_min_box_width(distance)
    out: dict[str, tuple[float, float]] = {}
    for cls in classes:
        axis, scale = CLASS_SIZE.get(cls, ("width", 1.0))
        if axis == "height":
            out[cls] = (0.0, min(1.0, width * camera.width / (scale * camera.height)))
    return out
