"""The frame model's held-out check split by the side the road user comes from.

For each recorded camera run of a frames file (``sitcov calibrate --record-frames``), the
situation's approach side (``left``, ``right``, ``ahead``: :func:`sitcov.campaign._agreement.
approach_side`) and, per side and distance band, the detector's share of frames whose score
reaches θ against the PEM's probability of it (the same comparison as
``sitcov calibrate --check``, :mod:`sitcov.calibration._frame_check`). The PEM's features are
symmetric in left and right; this shows whether the detector is (docs/pem.md, "Where the
PEM differs").

    python benchmarks/pem_side_check.py docs/data/pem-frames-seed2.jsonl.gz --kind car
"""

from __future__ import annotations

import argparse
from collections import defaultdict

import numpy as np

from sitcov.calibration._frame_check import BANDS, pass_probability
from sitcov.calibration._frames import read_frames
from sitcov.campaign._agreement import approach_side
from sitcov.perception._pem_params import load_pem_params

THETAS = (0.3, 0.5, 0.7)


def _band(distance: float) -> str:
    for lo, hi in BANDS:
        if lo <= distance < hi:
            return f"{lo:g}-{hi:g} m"
    return f">= {BANDS[-1][1]:g} m"


def side_table(path: str, kind: str, pem_file: str | None = None) -> list[str]:
    """One printed line per (side, band): frames, then detector and PEM rates per θ."""
    params = load_pem_params(pem_file)
    cells: dict[tuple[str, str], list] = defaultdict(list)
    for run in read_frames(path)[kind].runs:
        side = approach_side(run.situation.get("bins", {}), run.situation.get("values", {}))
        for f in run.frames:
            if f.distance >= 0.0 and f.features.height_px >= 1.0:
                cells[side, _band(f.distance)].append((f.features, f.score))
    lines = []
    for (side, band), sel in sorted(cells.items()):
        parts = [f"{side:>6} {band:>9} n={len(sel):5d}"]
        for theta in THETAS:
            det = np.mean([s >= theta for _, s in sel])
            pem = np.mean([pass_probability(params, feats, theta) for feats, _ in sel])
            parts.append(f"θ {theta}: detector {det:.2f} PEM {pem:.2f}")
        lines.append("  ".join(parts))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", help="a frames file (.jsonl.gz)")
    parser.add_argument("--kind", default="car", help="car (the PEM of pem.yaml)")
    parser.add_argument("--pem", default=None, help="PEM file (default: the shipped one)")
    args = parser.parse_args()
    print("\n".join(side_table(args.frames, args.kind, args.pem)))


if __name__ == "__main__":
    main()
