"""The held-out check's close cells split by truncation: where the PEM's close misses are.

For each class's held-out recording, the frames below 10 m split into those whose box is
cut by the image edge (``truncation`` > 0.05) and the others; for each part and θ the
detector's share of frames with a score >= θ against the PEM's probability of it (the
check's ``pass_probability``, :mod:`sitcov.calibration._frame_check`), with the part's
median noise scale below the median (``noise_sigma`` times its size factor).

    python benchmarks/pem_close_split.py docs/data/pem-frames-top-seed3.jsonl.gz:car \\
        docs/data/pem-frames-pedestrian-seed3.jsonl.gz:pedestrian \\
        docs/data/pem-frames-rider-seed3.jsonl.gz:cyclist
"""

from __future__ import annotations

import argparse

import numpy as np

from sitcov.calibration._frame_check import THETAS, pass_probability
from sitcov.calibration._frames import KIND_LABEL, read_frames
from sitcov.perception._pem import noise_scale
from sitcov.perception._pem_classes import load_class_params
from sitcov.perception._pem_params import load_pem_params

#: Truncation above which a frame counts as cut by the image edge [-].
CUT = 0.05
#: The close band [m].
NEAR_M = 10.0


def split_rows(path: str, kind: str) -> list[str]:
    """The two parts' lines (cut by the edge or not) of ``kind``'s close frames in ``path``."""
    params = load_pem_params() if kind == "car" else load_class_params()[kind][1]
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
    lines = []
    for name, part in (("whole", ~cut), ("cut", cut)):
        idx = np.flatnonzero(part)
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
    args = parser.parse_args()
    print(f"below {NEAR_M:g} m, detector/PEM P(score >= θ); cut = truncation > {CUT:g}")
    for item in args.files:
        path, kind = item.rsplit(":", 1)
        for line in split_rows(path, kind):
            print(line)


if __name__ == "__main__":
    main()
