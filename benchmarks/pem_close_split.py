"""The held-out check's close cells split by truncation: where the PEM's close misses are.

For each class's held-out recording, the frames below 10 m split into those whose box is
cut by the image edge (``truncation`` > 0.05) and the others; for each part and θ the
detector's share of frames with a score >= θ against the PEM's probability of it (the
check's ``pass_probability``, :mod:`sitcov.calibration._frame_check`), with the part's
median noise scale below the median (``noise_sigma`` times its size factor).

    python benchmarks/pem_close_split.py docs/data/pem-frames-top-seed3.jsonl.gz:car \\
        docs/data/pem-frames-pedestrian-seed3.jsonl.gz:pedestrian \\
        docs/data/pem-frames-rider-seed3.jsonl.gz:cyclist

``--by-height`` splits each part further by box height (below 150, 150-250, 250 px and
up) and adds the cut frames by truncation (10-30 %, 30-50 %); ``--pem FILE`` takes the car
parameters from that file instead of the shipped one (e.g. an earlier ``pem.yaml`` from
git, to compare):

    python benchmarks/pem_close_split.py docs/data/pem-frames-top-seed3.jsonl.gz:car --by-height
"""

from __future__ import annotations

import argparse

import numpy as np

from sitcov.calibration._frame_check import CUT, THETAS, pass_probability
from sitcov.calibration._frames import KIND_LABEL, read_frames
from sitcov.perception._pem import noise_scale
from sitcov.perception._pem_classes import load_class_params
from sitcov.perception._pem_params import load_pem_params

#: The close band [m].
NEAR_M = 10.0
#: Fewer frames than this in a part: not printed.
MIN_FRAMES = 15


#: Box height bins of ``--by-height`` [px].
HEIGHT_BINS = ((0.0, 150.0), (150.0, 250.0), (250.0, float("inf")))
#: Truncation bins of the cut frames under ``--by-height`` [-].
TRUNCATION_BINS = ((0.1, 0.3), (0.3, 0.5))


def split_rows(path: str, kind: str, by_height: bool = False, pem: str | None = None) -> list[str]:
    """The two parts' lines (cut by the edge or not) of ``kind``'s close frames in ``path``
    (``by_height``: each part and the cut frames' truncation bins by box height too;
    ``pem``: the car's parameters from that file)."""
    params = load_pem_params(pem) if kind == "car" else load_class_params()[kind][1]
    frames = [
        f for r in read_frames(path)[kind].runs for f in r.frames if 0.0 <= f.distance < NEAR_M
    ]
    cut = np.asarray([f.features.truncation > CUT for f in frames])
    score = np.asarray([f.score for f in frames])
    scale = np.asarray([
        params.noise_sigma * noise_scale(params.noise_size_gain, f.features.height_px,
                                         params.size_min_px, params.noise_size_max_px,
                                         params.size_ref_px)
        for f in frames
    ])  # fmt: skip
    parts = [("whole", ~cut), ("cut", cut)]
    if by_height:
        heights = np.asarray([f.features.height_px for f in frames])
        trunc = np.asarray([f.features.truncation for f in frames])
        cuts = [(f"cut {lo:g}-{hi:g}", (trunc >= lo) & (trunc < hi)) for lo, hi in TRUNCATION_BINS]
        parts = [
            (f"{name} {lo:g}-{hi:g}px", part & (heights >= lo) & (heights < hi))
            for name, part in (*parts, *cuts)
            for lo, hi in HEIGHT_BINS
        ]
    lines = []
    for name, part in parts:
        idx = np.flatnonzero(part)
        if len(idx) < MIN_FRAMES:
            continue
        cells = []
        for theta in THETAS:
            pem = float(np.mean([pass_probability(params, frames[i].features, theta) for i in idx]))
            cells.append(f"θ{theta:g} {np.mean(score[idx] >= theta):.3f}/{pem:.3f}")
        head = f"{KIND_LABEL[kind]:<8} {name:<6} {len(idx):>5} frames"
        lines.append(f"{head}, scale {np.median(scale[idx]):.2f}  " + "  ".join(cells))
    return lines


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("files", nargs="+", help="FILE:KIND (car, pedestrian, cyclist)")
    parser.add_argument("--by-height", action="store_true", help="split by box height too")
    parser.add_argument("--pem", default=None, help="car PEM file (default: the shipped one)")
    args = parser.parse_args()
    print(f"below {NEAR_M:g} m, detector/PEM P(score >= θ); cut = truncation > {CUT:g}")
    for item in args.files:
        path, kind = item.rsplit(":", 1)
        for line in split_rows(path, kind, args.by_height, args.pem):
            print(line)


if __name__ == "__main__":
    main()
