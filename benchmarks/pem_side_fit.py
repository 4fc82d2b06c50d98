"""Does the frame model's side term pay? Each candidate with and without ``side_gain``.

Fits, on the car frames of ``FRAMES`` (recorded since ``side`` is stored: ``sitcov
calibrate --record-frames``), the model-choice candidates given (default: the shipped
one's and the best of the small sample's, each without and with the side term), scores
each by its sequence log-likelihood per frame on the even-index runs of ``HELDOUT`` (as
``sitcov calibrate --frames-from ... --heldout ...`` does), and prints the fitted
``side_gain`` and, on ``HELDOUT``'s odd-index runs (neither fitted nor chosen on), the
detector's and each fit's P(score >= 0.5) per approach side and distance band (as
``benchmarks/pem_side_check.py``).

    python benchmarks/pem_side_fit.py FRAMES HELDOUT [--candidates ar1_edge_scale,...]
"""

from __future__ import annotations

import argparse
import json
from collections import defaultdict
from typing import Any

import numpy as np

from sitcov.calibration import _frame_model as fm
from sitcov.calibration._frame_check import BANDS, pass_probability
from sitcov.calibration._frames import read_frames
from sitcov.campaign._agreement import approach_side
from sitcov.perception._pem_params import load_pem_params

BASES = ("ar1_edge_scale", "ar1_edge_scale_image_size")


def candidates(bases: list[str]) -> list[tuple[Any, ...]]:
    """Each named :data:`~sitcov.calibration._frame_model.CANDIDATES` entry and the same
    with the side term (``NAME_side``; an entry that has it already stays alone)."""
    known = {c[0]: c for c in fm.CANDIDATES}
    out = []
    for name in bases:
        c = known[name]
        flags = fm._flags(c)
        out += [c] if flags[5] else [c, (f"{name}_side", *flags[:5], True)]
    return list({c[0]: c for c in out}.values())


def side_rates(data: Any, params: Any, theta: float = 0.5) -> dict[str, tuple[int, float, float]]:
    """'side band' -> (frames, detector share >= theta, the PEM's mean probability)."""
    cells: dict[str, list] = defaultdict(list)
    for run in data.runs:
        side = approach_side(run.situation.get("bins", {}), run.situation.get("values", {}))
        for f in run.frames:
            if f.distance < 0.0 or f.features.height_px < 1.0:
                continue
            band = next((f"{lo:g}-{hi:g} m" for lo, hi in BANDS if lo <= f.distance < hi), None)
            if band is not None:
                cells[f"{side} {band}"].append((f.features, f.score))
    return {
        k: (len(v), float(np.mean([s >= theta for _, s in v])),
            float(np.mean([pass_probability(params, x, theta) for x, _ in v])))
        for k, v in sorted(cells.items())
    }  # fmt: skip


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", help="frames file to fit on (.jsonl.gz)")
    parser.add_argument("heldout", help="frames file: even runs choose, odd runs check")
    parser.add_argument("--candidates", default=",".join(BASES), help="candidate names")
    args = parser.parse_args()
    data = read_frames(args.frames)["car"]
    held = read_frames(args.heldout)["car"]
    base = load_pem_params()
    t = fm.tracks_of(data)
    even = fm.tracks_of(fm.split_runs(held, "even"))
    cands = candidates(args.candidates.split(","))
    _, table, fits = fm.held_out_choice(t, even, size_ref=base.size_ref_px, candidates=cands)
    odd = fm.split_runs(held, "odd")
    out: dict[str, Any] = {"frames": len(t.score), "heldout_even_frames": len(even.score)}
    for name, fit in fits.items():
        params = fm.to_params(fit, base, t, data.runs)  # side_gain included
        out[name] = {
            "heldout_loglik_per_frame": table[name]["heldout_loglik_per_frame"],
            "side_gain": round(fit.side_gain, 4),
            "odd_runs_p05_by_side": {
                k: [n, round(d, 3), round(p, 3)] for k, (n, d, p) in side_rates(odd, params).items()
            },
        }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
