"""A cyclist's two detections, rider and bicycle, on the same recorded frames.

The rider's and the bicycle's recordings of one seed (``pem-frames-rider-seedN`` and
``pem-frames-bicycle-seedN``: the same runs, frames and features, scored by the top
``person`` and the top ``bicycle`` box on the cyclist) give, per distance band and θ, the
detector's share of frames where either box scores >= θ against the PEM's, whose two
detections are drawn independently (per frame ``1 - (1 - p_rider)(1 - p_bicycle)`` with
each ``pass_probability``), and the correlation of the two scores' residuals (logit score
minus each law's noise-free logit) on frames where both are reported (>= 0.3): what a
noise shared between the two would have to carry. docs/pem.md, "The cyclist's two
detections".

    python benchmarks/pem_cyclist_pair.py --seed 3
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

import numpy as np

from sitcov.calibration._frames import read_frames
from sitcov.perception._pem import pass_probability, pem_logit
from sitcov.perception._pem_classes import load_class_params

DATA = Path(__file__).resolve().parents[1] / "docs" / "data"
BANDS = ((0.0, 10.0), (10.0, 20.0), (20.0, 40.0))
THETAS = (0.3, 0.5, 0.6, 0.7)
#: Frames with fewer than this many in a band are not reported.
MIN_FRAMES = 30
#: Both detections reported: the detector's usual output floor.
FLOOR = 0.3


def paired_frames(seed: int) -> list[tuple]:
    """(rider frame, bicycle frame) of every recorded frame of the seed, checked to be the
    same frame of the same run."""
    rider = read_frames(DATA / f"pem-frames-rider-seed{seed}.jsonl.gz")["cyclist"].runs
    bike = read_frames(DATA / f"pem-frames-bicycle-seed{seed}.jsonl.gz")["bicycle"].runs
    out = []
    for rr, rb in zip(rider, bike, strict=True):
        if rr.index != rb.index or len(rr.frames) != len(rb.frames):
            raise SystemExit(f"seed {seed}: run {rr.index} differs between the recordings")
        for fr, fb in zip(rr.frames, rb.frames, strict=True):
            if fr.features != fb.features:
                raise SystemExit(f"seed {seed}: run {rr.index} frame {fr.frame} differs")
            out.append((fr, fb))
    return out


def _logit(p: float) -> float:
    p = min(max(p, 1e-4), 1.0 - 1e-4)
    return math.log(p / (1.0 - p))


def summarise(pairs: list[tuple], pem_classes: str | None = None) -> dict:
    """Per band and θ the either-box rates, and the residuals' correlation."""
    classes = load_class_params(pem_classes)
    p_rider, p_bike = classes["cyclist"][1], classes["bicycle"][1]
    both = [(fr, fb) for fr, fb in pairs if fr.score >= FLOOR and fb.score >= FLOOR]
    res = np.array([
        (_logit(fr.score) - pem_logit(fr.features, p_rider),
         _logit(fb.score) - pem_logit(fb.features, p_bike))
        for fr, fb in both
    ]).reshape(-1, 2)  # fmt: skip
    corr = float(np.corrcoef(res[:, 0], res[:, 1])[0, 1]) if len(res) > 2 else None
    cells = []
    for lo, hi in BANDS:
        band = [(fr, fb) for fr, fb in pairs if lo <= fr.distance < hi]
        if len(band) < MIN_FRAMES:
            continue
        for theta in THETAS:
            pr = np.array([pass_probability(fr.features, p_rider, theta) for fr, _ in band])
            pb = np.array([pass_probability(fb.features, p_bike, theta) for _, fb in band])
            cells.append({
                "band": f"{lo:g}-{hi:g} m", "theta": theta, "frames": len(band),
                "detector_either": round(float(np.mean(
                    [fr.score >= theta or fb.score >= theta for fr, fb in band])), 3),
                "pem_either": round(float(np.mean(1.0 - (1.0 - pr) * (1.0 - pb))), 3),
                "detector_rider": round(float(np.mean([fr.score >= theta for fr, _ in band])), 3),
                "pem_rider": round(float(pr.mean()), 3),
                "detector_bicycle": round(float(np.mean([fb.score >= theta for _, fb in band])), 3),
                "pem_bicycle": round(float(pb.mean()), 3),
            })  # fmt: skip
    return {
        "frames": len(pairs),
        "both_reported": len(both),
        "residual_correlation": None if corr is None else round(corr, 3),
        "cells": cells,
    }


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=3, help="the recordings' seed")
    parser.add_argument("--pem-classes", help="per-class PEM file (default: shipped)")
    parser.add_argument("--out", help="JSON file to write (default: print only)")
    args = parser.parse_args()
    out = summarise(paired_frames(args.seed), args.pem_classes)
    print(f"{out['frames']} frames, {out['both_reported']} with both boxes >= {FLOOR}; "
          f"residual correlation {out['residual_correlation']}")  # fmt: skip
    print("band      theta  frames  either det / PEM   rider det / PEM   bicycle det / PEM")
    for c in out["cells"]:
        print(f"{c['band']:<9} {c['theta']:>5}  {c['frames']:>6}  {c['detector_either']:>10.3f} /"
              f" {c['pem_either']:.3f}  {c['detector_rider']:>8.3f} / {c['pem_rider']:.3f}"
              f"  {c['detector_bicycle']:>9.3f} / {c['pem_bicycle']:.3f}")  # fmt: skip
    if args.out:
        Path(args.out).write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
