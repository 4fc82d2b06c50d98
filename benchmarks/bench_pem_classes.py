"""Per-class PEM against the SSD on held-out rendered frames (docs/camera.md#per-class-pem).

Renders frames of pedestrians and cyclists exactly as the per-class calibration does, but
from another seed, and compares per box-height bin the share of frames the SSD detects
(an accepted class, IoU >= 0.3) at score >= 0.3 and >= 0.5 with the PEM's probability of
the same event (``Phi((z - logit(t)) / noise_sigma)``, averaged over the bin's frames).

    python benchmarks/bench_pem_classes.py --frames 400 --seed 2
"""

from __future__ import annotations

import argparse
import math

import numpy as np
from scipy.stats import norm

from sitcov.calibration._class_fit import SWEEP_MIN_SCORE, class_sweep
from sitcov.perception import SSDDetector, pem_logit
from sitcov.perception._pem_classes import load_class_params

BINS = ((0, 30), (30, 45), (45, 70), (70, 1000))


def _p_above(features, params, t: float) -> float:
    """The PEM's probability that the actor is reported with a score >= t."""
    if features.height_px < params.size_min_px:
        return 0.0
    z = pem_logit(features, params) - math.log(t / (1 - t))
    return float(norm.cdf(z / params.noise_sigma))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=400)
    parser.add_argument("--seed", type=int, default=2)
    args = parser.parse_args()
    detector = SSDDetector(min_score=SWEEP_MIN_SCORE)
    classes = load_class_params()
    print("| kind | box height [px] | frames | SSD >= 0.3 | PEM >= 0.3 | SSD >= 0.5 | PEM >= 0.5 |")
    print("|---|---|---|---|---|---|---|")
    for kind in ("pedestrian", "cyclist"):
        _, params = classes[kind]
        samples = class_sweep(kind, args.frames, detector, seed=args.seed)
        for lo, hi in BINS:
            rows = [(f, s) for f, s in samples if lo <= f.height_px < hi]
            if not rows:
                continue
            cells = []
            for t in (0.3, 0.5):
                cam = np.mean([s >= t for _, s in rows])
                pem = np.mean([_p_above(f, params, t) for f, _ in rows])
                cells += [f"{100 * cam:.0f} %", f"{100 * pem:.0f} %"]
            print(f"| {kind} | {lo}-{hi} | {len(rows)} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    main()
