"""Where the shipped car PEM's P(score >= θ) misses the detector's, binned finer than the check.

On a frames file's car frames (the held-out recording's odd or even runs, or the fit
recording's sweep or runs), the detector's share of frames scoring >= 0.3 and >= 0.5
against the shipped PEM's probability (``pass_probability``, averaged over the same
frames), binned by distance, by box height, by distance band at fixed height and by view
angle at fixed height, close boxes (80-350 px) seen side-on against end-on with the
rate at θ 0.7 too (what a threshold-0.7 stack brakes on); and the spread of the
detector's logit score around the PEM's mean per distance band against the PEM's noise
scale there (docs/pem.md, "Terms tried for the per-cell check" and "The side-on bend":
is the miss the mean's shape in the box size, a distance term the size does not carry,
the view, or the noise?). Seconds.

    python benchmarks/pem_car_diagnosis.py docs/data/pem-frames-seed2.jsonl.gz --part odd
    python benchmarks/pem_car_diagnosis.py docs/data/pem-frames-seed1.jsonl.gz --part runs
"""

from __future__ import annotations

import argparse

import numpy as np

from sitcov.calibration import _frame_model as fm
from sitcov.calibration._frames import KindFrames, read_frames
from sitcov.perception._pem import pass_probability, pem_logit
from sitcov.perception._pem_params import load_pem_params

HEIGHTS = (10, 20, 30, 40, 50, 60, 80, 120, 200, 350, 3000)
DISTANCES = (0, 5, 10, 12.5, 15, 17.5, 20, 25, 30, 40)
BANDS = ((0, 10), (10, 20), (20, 60))
VIEWS = (0.0, 0.4, 0.8, 1.2, 1.6)
CLOSE_HEIGHTS = ((80, 120), (120, 200), (200, 350))
SIDE_ON = 0.7  # sine of the view angle from which a car counts as seen side-on


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", help="frames file (.jsonl.gz)")
    parser.add_argument("--part", default="odd", choices=("odd", "even", "all", "runs", "sweep"))
    parser.add_argument("--pem", default=None, help="car PEM file (default: the shipped one)")
    args = parser.parse_args()
    car = read_frames(args.frames)["car"]
    data = {"runs": KindFrames(runs=car.runs), "sweep": KindFrames(sweep=car.sweep)}.get(
        args.part
    ) or fm.split_runs(car, args.part)
    params = load_pem_params(args.pem) if args.pem else load_pem_params()
    t = fm.tracks_of(data)
    h = np.asarray([f.height_px for f in t.feats])
    view = np.asarray([f.view_angle for f in t.feats])
    d = t.distance
    rates = {
        th: np.asarray([pass_probability(f, params, th) for f in t.feats]) for th in (0.3, 0.5, 0.7)
    }
    print(f"{args.frames} ({args.part}): {len(h)} car frames")

    def row(label: str, sel: np.ndarray, thetas: tuple[float, ...] = (0.3, 0.5)) -> None:
        if sel.sum() < 20:
            return
        parts = [f"{label:<24} n={int(sel.sum()):5d}"]
        for th in thetas:
            p = rates[th]
            det, pem = float(np.mean(t.score[sel] >= th)), float(np.mean(p[sel]))
            parts.append(f"θ{th}: det {det:.3f} PEM {pem:.3f} ({pem - det:+.3f})")
        parts.append(f"h~{np.median(h[sel]):.0f} px, d~{np.median(d[sel]):.1f} m, "
                     f"view~{np.median(view[sel]):.2f}")  # fmt: skip
        print("  ".join(parts))

    print("-- by distance [m]")
    for lo, hi in zip(DISTANCES[:-1], DISTANCES[1:], strict=True):
        row(f"{lo:g}-{hi:g} m", (d >= lo) & (d < hi))
    print("-- by box height [px], and within it by distance band")
    for lo, hi in zip(HEIGHTS[:-1], HEIGHTS[1:], strict=True):
        sel = (h >= lo) & (h < hi)
        row(f"{lo}-{hi} px", sel)
        for a, b in BANDS:
            if (d[sel] >= 0).any() and ((d >= a) & (d < b) & sel).sum() < sel.sum():
                row(f"  {lo}-{hi} px, {a}-{b} m", sel & (d >= a) & (d < b))
    print("-- 25-60 px by view angle [rad] (0 end-on, pi/2 side-on)")
    for lo, hi in zip(VIEWS[:-1], VIEWS[1:], strict=True):
        row(f"25-60 px, view {lo}-{hi}", (h >= 25) & (h < 60) & (view >= lo) & (view < hi))
    print("-- 80-350 px by the sine of the view angle (side-on >= 0.7 > end-on), at 0.3/0.5/0.7")
    sine = np.sin(view)
    for lo, hi in CLOSE_HEIGHTS:
        for label, sel in (("side-on", sine >= SIDE_ON), ("end-on", sine < SIDE_ON)):
            row(f"{lo}-{hi} px, {label}", (h >= lo) & (h < hi) & sel, (0.3, 0.5, 0.7))
    print("-- logit score minus the PEM's mean (frames scoring >= 0.2) by distance")
    z = np.asarray([pem_logit(f, params) for f in t.feats])
    s = np.clip(t.score, 1e-6, 1 - 1e-6)
    resid = np.log(s / (1 - s)) - z
    for lo, hi in ((0, 5), (5, 10), (10, 15), (15, 20), (20, 30), (30, 40)):
        sel = (d >= lo) & (d < hi) & (t.score >= 0.2)
        if sel.sum() < 20:
            continue
        q = np.percentile(resid[sel], [10, 25, 50, 75, 90])
        hs = np.clip(np.median(h[sel]), params.size_min_px, params.noise_size_max_px)
        sig = params.noise_sigma * (hs / params.size_ref_px) ** params.noise_size_gain
        iqr = 0.6745 * sig * (1 + params.noise_up_ratio)  # the split normal's quartiles
        print(f"{lo}-{hi} m n={int(sel.sum()):4d} median {q[2]:+.2f} IQR {q[3] - q[1]:.2f} "
              f"(q10 {q[0]:+.2f}, q90 {q[4]:+.2f}); "
              f"PEM: sigma {sig:.3f}, IQR {iqr:.2f}")  # fmt: skip


if __name__ == "__main__":
    main()
