"""The dash-cam strip of an animation: the ego's camera view at a trace row.

For runs of camera-mode campaigns (``--perception camera``) the animation shows, under the
top-down view, what the ego's camera saw: the embedded renderer's frame
(:func:`sitcov.perception.render_frame`, the one the backend drew in the run) of the
recorded poses of every road user, in the run's weather, and optionally the boxes the
detector (:class:`sitcov.perception.SSDDetector`) finds in it, labelled with class and
score. The frame is rendered again from the trace (the run does not store its frames), so
it shows the detector's view of the same scene, with the same weather; the rain streaks'
randomness is drawn per row, not the run's own.

Cost (``sitcov animate`` of a camera-mode run): ~0.075 CPU-s per frame for the frame and
the detector (docs/report.md); the report's animations draw no boxes.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def camera_mode(config: Any) -> bool:
    """Whether a stored campaign config ran the embedded backend with camera perception."""
    if not isinstance(config, dict):
        return False
    options = config.get("backend_options") or {}
    mode = options.get("perception") if isinstance(options, dict) else None
    return str(mode or config.get("perception") or "pem") == "camera"


class DashCam:
    """Renders the ego's camera view at any row of a recorded trace.

    Args:
        outcome: the run's outcome with its trace.
        values: the run's situation values (the weather of the frame).
        seed: the run's seed (the rain streaks' randomness, per row).
        boxes: draw the detector's boxes (needs the camera extra; ~0.16 s per frame).

    Raises:
        ImportError: the camera renderer (Pillow) or, with ``boxes``, the detector is
            unavailable.
    """

    def __init__(self, outcome: Any, values: dict[str, Any], seed: int, *, boxes: bool) -> None:
        from sitcov.perception import CameraSpec, render_frame
        from sitcov.sim.embedded import load_map
        from sitcov.weather import conditions_from_values

        trace = outcome.trace
        meta = trace.meta or {}
        self._render = render_frame
        self.camera = CameraSpec()
        self.geometry = load_map(str(meta.get("map", "t-junction"))).render_geometry()
        metrics = outcome.metrics or {}
        physics = metrics.get("physics")
        self.conditions = conditions_from_values(
            values,
            wind_direction=float(metrics.get("wind_direction") or 0.0),
            profile=physics if physics in ("carla", "physical") else "carla",
        )
        self.seed = int(seed)
        self.ego = trace.ego
        sizes = meta.get("actors") or {}
        actors = dict(trace.actors or {}) or ({"ov": trace.ov} if trace.ov else {})
        self.actors = [
            (
                sizes.get(name, {}),
                {round(row[0], 6): row for row in rows},
            )
            for name, rows in actors.items()
        ]
        self.length = float(meta.get("length", 4.5))
        self.width = float(meta.get("width", 1.8))
        self.detector = None
        if boxes:
            from sitcov.perception import SSDDetector

            self.detector = SSDDetector()

    @property
    def shape(self) -> tuple[int, int]:
        """(height, width) of a frame [px]."""
        return self.camera.height, self.camera.width

    def frame(self, i: int) -> np.ndarray:
        """The camera view at ego row ``i`` (HxWx3 uint8), the detector's boxes drawn."""
        from sitcov.perception._base import ActorView, Pose

        t, x, y, yaw, _ = self.ego[i][:5]
        views = []
        for info, rows in self.actors:
            row = rows.get(round(t, 6))
            if row is None:  # not on the road at this instant
                continue
            color = info.get("color")
            views.append(
                ActorView(
                    Pose(row[1], row[2], row[3]),
                    float(info.get("length", self.length)),
                    float(info.get("width", self.width)),
                    float(info.get("height", 1.5)),
                    float(row[4]),
                    None if color is None else tuple(int(c) for c in color),
                    str(info.get("kind", "car")),
                )
            )
        rng = np.random.default_rng([self.seed, int(round(t * 1000))])
        image = self._render(
            self.camera, Pose(x, y, yaw), views, self.conditions, self.geometry, rng
        )
        if self.detector is not None:
            image = _draw_boxes(image, self.detector(image))
        return image

    def close(self) -> None:
        """Release the detector."""
        if self.detector is not None:
            self.detector.close()


def _draw_boxes(image: np.ndarray, detections: Any) -> np.ndarray:
    """``image`` with each detection's box and ``label score`` drawn (Pillow)."""
    from PIL import Image, ImageDraw, ImageFont

    pil = Image.fromarray(image)
    draw = ImageDraw.Draw(pil)
    try:  # large enough to read when the strip is shown at half size
        font = ImageFont.load_default(size=LABEL_PX)
    except TypeError:  # Pillow < 10.1: the fixed bitmap font
        font = ImageFont.load_default()
    for d in detections:
        x0, y0, x1, y1 = d.box
        draw.rectangle((x0, y0, x1, y1), outline=BOX_COLOUR, width=4)
        text = f"{d.label} {d.score:.2f}"
        left, top, right, bottom = draw.textbbox((0, 0), text, font=font)
        h = bottom - top + 6
        ty = y0 - h if y0 >= h else y1 + 2
        tx = min(x0, pil.width - (right - left) - 6)
        draw.rectangle((tx, ty, tx + right - left + 6, ty + h), fill=(0, 0, 0))
        draw.text((tx + 3, ty + 3 - top), text, fill=BOX_COLOUR, font=font)
    return np.asarray(pil, dtype=np.uint8)


#: Colour of the detector's boxes and labels, and the labels' height [px of the frame].
BOX_COLOUR = (255, 235, 59)
LABEL_PX = 26
