"""Render the road-user frames of docs/camera.md (a pedestrian, a cyclist and a car).

One scene per weather (clear noon, fog, rain), seen from the ego at the start of leg B of
the T-junction; with ``--boxes`` the real SSD's detections (score >= 0.3) are drawn with
their class label, green for person, orange for bicycle, blue for car.

    python benchmarks/render_road_users.py --out docs/img [--boxes]
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import numpy as np
from PIL import Image, ImageDraw

from sitcov.perception import ActorView, CameraSpec, Pose, render_frame
from sitcov.sim import conditions_from_values
from sitcov.sim.embedded._map import load_map

CAM = CameraSpec()
WEATHERS = {
    "clear": {},
    "fog": {"fog_density": 40, "fog_distance": 0},
    "rain": {"precipitation": 80, "precipitation_deposits": 60, "wetness": 80, "cloudiness": 80},
}
COLORS = {"person": (40, 220, 60), "bicycle": (255, 150, 0), "car": (40, 120, 255)}


def scene(ego: Pose) -> tuple[ActorView, ...]:
    """A pedestrian crossing left of the lane, a cyclist ahead on the right, a car beyond."""
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)

    def at(fwd: float, left: float, yaw: float) -> Pose:
        f = CAM.mount_x + fwd
        return Pose(ego.x + f * c - left * s, ego.y + f * s + left * c, ego.yaw + yaw)

    return (
        ActorView(at(8.0, 1.8, -math.pi / 2), 0.5, 0.5, 1.75, 1.4, (40, 70, 160), "pedestrian"),
        ActorView(at(11.0, -1.5, 0.4), 1.8, 0.6, 1.7, 5.0, (200, 40, 40), "cyclist"),
        ActorView(at(22.0, 3.0, math.pi / 2), 4.5, 1.9, 1.5, 0.0, (230, 230, 225), "car"),
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="docs/img", help="output folder")
    parser.add_argument("--boxes", action="store_true", help="draw the SSD's detections")
    args = parser.parse_args()
    jmap = load_map("t-junction")
    x, y, h = jmap.route("B", "L").point_at(0.0)
    ego = Pose(x, y, h)
    detector = None
    if args.boxes:
        from sitcov.perception import SSDDetector

        detector = SSDDetector(min_score=0.3)
    for name, values in WEATHERS.items():
        cond = conditions_from_values(values)
        img = render_frame(CAM, ego, scene(ego), cond, jmap.render_geometry(),
                           np.random.default_rng(0))  # fmt: skip
        pil = Image.fromarray(img)
        if detector is not None:
            draw = ImageDraw.Draw(pil)
            for d in detector(img):
                draw.rectangle(d.box, outline=COLORS.get(d.label, (255, 0, 0)), width=2)
                draw.text(
                    (d.box[0], d.box[1] - 11), f"{d.label} {d.score:.2f}", fill=(255, 255, 255)
                )
        path = Path(args.out) / f"road_users_{name}.png"
        pil.save(path)
        print(path)


if __name__ == "__main__":
    main()
