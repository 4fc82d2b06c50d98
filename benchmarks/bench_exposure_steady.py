"""Why the renderer meters each frame at its steady state (docs/camera.md#auto-exposure).

For runs 0..N-1 of a seed (random situations, PEM mode, trajectories recorded), it finds
the frames camera mode would render (the reference stack's frame gate) and reports:
when the first one comes (the camera has been adapting since t = 0), and how much the
metered scene luminance changes between consecutive rendered frames [EV], against what
CARLA's adaptation speeds (3 EV/s up, 1 EV/s down) follow in 0.1 s.

    python benchmarks/bench_exposure_steady.py --runs 100 --seed 1
"""

from __future__ import annotations

import argparse
import math
from dataclasses import replace

import numpy as np

from sitcov._seeding import ask_rng, run_seed
from sitcov.av import ReferenceStack
from sitcov.generation import make_generator
from sitcov.hyperspace import load_hyperspace
from sitcov.perception import ActorView, CameraSpec, Pose, project_box
from sitcov.perception import _renderer as R
from sitcov.perception._texture import ground_texture
from sitcov.sim import conditions_from_values
from sitcov.sim.embedded import EmbeddedBackend


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=1)
    args = parser.parse_args()
    cam = CameraSpec()
    stack = ReferenceStack()
    gate = 0.5 * stack.min_box_width * cam.width
    backend = EmbeddedBackend(perception="pem")
    tex = ground_texture(backend.map.render_geometry())
    small = replace(cam, width=cam.width // 2, height=cam.height // 2)
    gen = make_generator("random", load_hyperspace())
    vp = backend.vehicle
    first, steps = [], []
    for i in range(args.runs):
        sit = gen.ask(ask_rng(args.seed, i))
        out = backend.run(sit, stack, run_seed(args.seed, i), record=True)
        w = R._weather(conditions_from_values(sit.values))
        zen, hor = R._sky_colors(w)
        ov = {round(r[0], 2): r for r in out.trace.ov}
        evs, times = [], []
        for t, x, y, yaw, _ in out.trace.ego[::5]:  # 10 Hz
            o = ov.get(round(t, 2))
            if o is None:
                continue
            ego = Pose(x, y, yaw)
            proj = project_box(
                cam, ego, ActorView(Pose(o[1], o[2], o[3]), vp.length, vp.width, vp.height)
            )
            if proj is None or not proj.visible or proj.width < gate:
                continue
            img = R._background(small, ego, w, zen, hor, tex)
            g, off = R._light(img, w)
            evs.append(math.log2(R.metered_luminance(img[::4, ::4] * g + off)))
            times.append(t)
        if times:
            first.append(times[0])
            steps += np.abs(np.diff(evs)).tolist()
    first_a, steps_a = np.asarray(first), np.asarray(steps)
    print(f"runs with a rendered frame: {len(first_a)} of {args.runs}")
    lo, med = np.percentile(first_a, 5), np.median(first_a)
    print(f"first rendered frame [s]: min {first_a.min():.1f}, 5% {lo:.1f}, median {med:.1f}")
    med, p99 = np.median(steps_a), np.percentile(steps_a, 99)
    print(
        f"metered change between rendered frames [EV]: median {med:.3f}, 99% {p99:.3f}, "
        f"max {steps_a.max():.3f}"
    )


if __name__ == "__main__":
    main()
