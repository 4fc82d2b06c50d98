"""Detection rate of rendered pedestrians and cyclists by the shipped SSD (issue 13).

Frames: one actor at 6, 8, ..., 20 m from the camera, bearings -20/0/20 deg, headings every
45 deg relative to the line of sight (seen from every side), from the ego at the start of
leg B of the T-junction; only frames whose projected box is at least 10 % of the image
height are kept. Appearance (shirt colour, height) is drawn per frame from a seeded rng;
the walking / pedalling phase follows from the position. A frame counts as detected when
a detection of an accepted class (pedestrian: person; cyclist: bicycle or person) with
score >= 0.3 overlaps the projected box with IoU >= 0.3 (``>= 0.5``: the reference AEB's
threshold). The same frames are re-rendered per fog bin (fog_density, fog from the camera).

    python benchmarks/bench_person_detection.py [--fog 0,20,40,60,80,100] [--seed 0]
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from sitcov.perception import ActorView, CameraSpec, Pose, SSDDetector, project_box, render_frame
from sitcov.perception._detector import KIND_LABELS
from sitcov.perception._nms import iou
from sitcov.perception._person import SHIRTS
from sitcov.sim import conditions_from_values
from sitcov.sim.embedded._map import load_map

CAM = CameraSpec()
DISTANCES = tuple(float(d) for d in range(6, 21, 2))
BEARINGS = (-20.0, 0.0, 20.0)
HEADINGS = tuple(range(0, 360, 45))
#: kind -> (length, width, speed, heights drawn from) [m, m, m/s, m].
KINDS = {
    "pedestrian": (0.5, 0.5, 1.4, (1.55, 1.65, 1.75, 1.85)),
    "cyclist": (1.8, 0.6, 5.0, (1.6, 1.7, 1.8)),
}
MIN_SCORE = 0.3
MIN_IOU = 0.3


def _ego_pose() -> tuple[Pose, object]:
    """The ego at the start of leg B of the T-junction, and the map's drawable geometry."""
    jmap = load_map("t-junction")
    x, y, h = jmap.route("B", "L").point_at(0.0)
    return Pose(x, y, h), jmap.render_geometry()


def frames(kind: str, rng: np.random.Generator) -> list[ActorView]:
    """The actors of the sweep whose box is at least 10 % of the image height."""
    length, width, speed, heights = KINDS[kind]
    ego, _ = _ego_pose()
    cx = ego.x + CAM.mount_x * math.cos(ego.yaw)
    cy = ego.y + CAM.mount_x * math.sin(ego.yaw)
    out = []
    for dist in DISTANCES:
        for bearing in BEARINGS:
            for heading in HEADINGS:
                los = ego.yaw + math.radians(bearing)
                pose = Pose(cx + dist * math.cos(los), cy + dist * math.sin(los),
                            los + math.radians(heading))  # fmt: skip
                shirt = SHIRTS[int(rng.integers(len(SHIRTS)))]
                height = float(heights[int(rng.integers(len(heights)))])
                actor = ActorView(pose, length, width, height, speed, shirt, kind)
                proj = project_box(CAM, ego, actor)
                if proj is not None and proj.height >= 0.1 * CAM.height:
                    out.append(actor)
    return out


def best_score(detector: SSDDetector, image: np.ndarray, box, labels) -> float:
    """Best score of an accepted-label detection overlapping ``box`` by IoU >= MIN_IOU."""
    dets = [d for d in detector(image) if d.label in labels]
    if not dets:
        return 0.0
    ov = iou(np.asarray(box, dtype=np.float64), np.asarray([d.box for d in dets]))
    return max((d.score for d, o in zip(dets, ov, strict=True) if o >= MIN_IOU), default=0.0)


def sweep(kind: str, fog: float, detector: SSDDetector, seed: int) -> np.ndarray:
    """Best matching score per frame of ``kind`` at fog density ``fog``."""
    ego, geometry = _ego_pose()
    cond = conditions_from_values({"fog_density": fog, "fog_distance": 0.0})
    scores = []
    for actor in frames(kind, np.random.default_rng(seed)):
        img = render_frame(CAM, ego, (actor,), cond, geometry, np.random.default_rng(0))
        box = project_box(CAM, ego, actor).box
        scores.append(best_score(detector, img, box, KIND_LABELS[kind]))
    return np.asarray(scores)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--fog", default="0,20,40,60,80,100", help="fog_density bins")
    parser.add_argument("--seed", type=int, default=0, help="appearance seed")
    args = parser.parse_args()
    detector = SSDDetector(min_score=0.05)
    t0, c0 = time.perf_counter(), time.process_time()
    print("| kind | fog_density | frames | detected (score >= 0.3) | score >= 0.5 | median score |")
    print("|---|---|---|---|---|---|")
    for kind in KINDS:
        for fog in (float(f) for f in args.fog.split(",")):
            s = sweep(kind, fog, detector, args.seed)
            rate, strong = 100 * np.mean(s >= MIN_SCORE), 100 * np.mean(s >= 0.5)
            print(f"| {kind} | {fog:.0f} | {len(s)} | {rate:.1f} % | "
                  f"{strong:.1f} % | {np.median(s):.2f} |", flush=True)  # fmt: skip
    print(f"wall {time.perf_counter() - t0:.0f} s, CPU {time.process_time() - c0:.0f} s")


if __name__ == "__main__":
    main()
