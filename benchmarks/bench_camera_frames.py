"""Camera-mode frames to the bit: record the renderer's inputs once, replay them on any
checkout, compare the frames' and detector inputs' hashes.

Usage:
    python benchmarks/bench_camera_frames.py record FILE.pkl [--runs N] [--seed S]
    PYTHONPATH=<checkout> python benchmarks/bench_camera_frames.py replay FILE.pkl OUT.json
    python benchmarks/bench_camera_frames.py compare A.json B.json

``record`` runs camera-mode runs of ``bench_camera.py``'s scenes (``two-cars`` and
``three-actors``, runs 0..N-1 of each) and stores every ``render_frame`` call's inputs
(camera, ego pose, road users, conditions, the rng's state; the map geometry once), then
adds a fixed set of synthetic frames: a car, a pedestrian and a cyclist at several
distances in clear air, fog, rain, wet roads with puddles and full cloud. ``replay``
renders them in order with the checkout on ``PYTHONPATH`` (so the reused-background and
repeated-frame paths run as in a campaign) and writes the SHA-256 of every frame and of
the detector's input for it (``SSDDetector.preprocess``). Two checkouts that give the
same hashes give the same pixels, hence the same detections and verdicts; ``compare``
prints how many differ (exit status 1 if any).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import pickle
import sys
from pathlib import Path
from typing import Any

import numpy as np

#: Synthetic weathers (CARLA units): clear, fog, rain on a wet road with puddles, cloud.
WEATHERS = (
    {},
    {"fog_density": 60, "fog_distance": 4},
    {"fog_density": 100},
    {"precipitation": 70, "precipitation_deposits": 80, "wetness": 60, "wind_intensity": 50},
    {"wetness": 100, "precipitation_deposits": 40},
    {"cloudiness": 100, "fog_density": 20, "precipitation": 20},
)


def _record(path: Path, runs: int, seed: int) -> None:
    sys.path.insert(0, str(Path(__file__).resolve().parent))
    import bench_camera

    import sitcov.perception as P
    from sitcov._seeding import run_seed
    from sitcov.av import ReferenceStack
    from sitcov.perception import ActorView, Pose, SSDDetector
    from sitcov.sim import conditions_from_values
    from sitcov.sim.embedded import EmbeddedBackend

    calls: list[tuple[Any, ...]] = []
    real = P.render_frame
    geometry: list[Any] = [None]

    def spy(camera, pose, actors, conditions, geom, rng, **kw):
        geometry[0] = geom
        calls.append((camera, pose, tuple(actors), conditions, rng.bit_generator.state))
        return real(camera, pose, actors, conditions, geom, rng, **kw)

    P.render_frame = spy
    backend = EmbeddedBackend(perception="camera")
    stack = ReferenceStack(detector=SSDDetector())
    for scene in ("two-cars", "three-actors"):
        for i in range(runs):
            backend.run(bench_camera.situation(scene, seed, i), stack, run_seed(seed, i))
    P.render_frame = real
    camera, ego = calls[0][0], calls[0][1]
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    rng = np.random.default_rng(11)
    for values in WEATHERS:
        cond = conditions_from_values(values)
        for fwd in (6.0, 12.0, 25.0, 45.0):
            for side, kind, dims in ((1.5, "car", (4.5, 1.9, 1.5)),
                                     (-2.0, "pedestrian", (0.5, 0.5, 1.75)),
                                     (3.0, "cyclist", (1.8, 0.6, 1.7))):  # fmt: skip
                pose = Pose(ego.x + fwd * c - side * s, ego.y + fwd * s + side * c, ego.yaw + 0.7)
                view = ActorView(pose, *dims, speed=1.5, kind=kind, color=(40, 70, 150))
                calls.append((camera, ego, (view,), cond, rng.bit_generator.state))
    with path.open("wb") as fh:
        pickle.dump({"geometry": geometry[0], "calls": calls}, fh)
    print(f"{len(calls)} frames recorded to {path}")


def _replay(path: Path, out: Path) -> None:
    import sitcov
    from sitcov.perception import SSDDetector, render_frame

    with path.open("rb") as fh:
        data = pickle.load(fh)
    geom, rows = data["geometry"], []
    for camera, pose, actors, conditions, state in data["calls"]:
        rng = np.random.default_rng()
        rng.bit_generator.state = state
        frame = render_frame(camera, pose, actors, conditions, geom, rng)
        net_in = SSDDetector.preprocess(frame)
        rows.append((hashlib.sha256(frame.tobytes()).hexdigest()[:16],
                     hashlib.sha256(net_in.tobytes()).hexdigest()[:16]))  # fmt: skip
    out.write_text(json.dumps({"sitcov": sitcov.__file__, "frames": rows}))
    print(f"{len(rows)} frames replayed with {sitcov.__file__} -> {out}")


def _compare(a: Path, b: Path) -> int:
    ra, rb = json.loads(a.read_text())["frames"], json.loads(b.read_text())["frames"]
    if len(ra) != len(rb):
        print(f"different frame counts: {len(ra)} vs {len(rb)}")
        return 1
    frames = sum(x[0] != y[0] for x, y in zip(ra, rb, strict=True))
    inputs = sum(x[1] != y[1] for x, y in zip(ra, rb, strict=True))
    print(f"{len(ra)} frames: {frames} frames differ, {inputs} detector inputs differ")
    return 1 if frames or inputs else 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = p.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("file", type=Path)
    r.add_argument("--runs", type=int, default=4)
    r.add_argument("--seed", type=int, default=0)
    rp = sub.add_parser("replay")
    rp.add_argument("file", type=Path)
    rp.add_argument("out", type=Path)
    c = sub.add_parser("compare")
    c.add_argument("a", type=Path)
    c.add_argument("b", type=Path)
    args = p.parse_args(argv)
    if args.cmd == "record":
        _record(args.file, args.runs, args.seed)
    elif args.cmd == "replay":
        _replay(args.file, args.out)
    else:
        return _compare(args.a, args.b)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
