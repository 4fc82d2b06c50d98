"""Extra terms for the frame model, each through the model choice and the per-cell check.

For each kind, the model the shipped file chose (``meta``'s ``model_choice.chosen``) and
that model with each of :data:`sitcov.calibration._frame_model.EXTRA_SETS` (side by
distance band, side times offset, the lane, a close-range intercept, a close-range noise
scale, a cubic size term, bends of the size term, the size in the detection term alone)
are

1. fitted on the fit frames and scored by their sequence log-likelihood per frame on the
   held-out file's even-index runs (the model choice of ``sitcov calibrate --frames-from
   ... --heldout ...``, :func:`~sitcov.calibration._frame_model.held_out_choice`);
2. refitted on the fit frames and those runs (as ``sitcov calibrate`` refits the chosen
   one) and checked on the odd-index runs: P(score >= θ), PEM vs detector, per distance
   band and θ (the check of ``sitcov calibrate --check ... --check-runs odd``,
   :mod:`sitcov.calibration._frame_check`), and the same per approach side (left, right,
   ahead) for θ 0.3, 0.5, 0.7 (``benchmarks/pem_side_check.py``).

The extra terms enter the PEM's logit (and so its detection term) as an offset per frame,
the close-range noise factor its score noise's scale; nothing is chosen on a stack's
verdicts. Prints one block per (kind, candidate) and writes the rows as JSON: with the
log-likelihood per frame on the odd runs too, and with every frame alone
(:func:`marginal_loglik`), and the cells of the fit before the refit. ``--starts``,
``--restarts``, ``--extras-from-zero`` and ``--stages`` are the fits' optimiser options
(:func:`sitcov.calibration._frame_model.fit_tracks`; ``--stages 2``: the two-stage fit
``sitcov calibrate`` uses, whose model choice is by the frames-alone held-out
log-likelihood, ``heldout_marginal_loglik_per_frame``; 1, the default here, the
single-stage sequence fit the rows before it were measured with).

    python benchmarks/pem_cell_candidates.py docs/data/pem-frames-seed1.jsonl.gz \\
        docs/data/pem-frames-seed2.jsonl.gz --kinds car --out /tmp/cells-car.json
"""

from __future__ import annotations

import argparse
import json
import math
import time
from dataclasses import replace
from typing import Any

import numpy as np

from sitcov.calibration import _frame_model as fm
from sitcov.calibration._frame_check import BANDS, MIN_FRAMES, THETAS, TOLERANCE
from sitcov.calibration._frames import KIND_LABEL, KindFrames, read_frames
from sitcov.perception._pem import pass_probability

SIDE_THETAS = (0.3, 0.5, 0.7)
SIDE_NAMES = {1.0: "left", -1.0: "right", 0.0: "ahead"}


def shipped(kind: str) -> tuple[Any, str]:
    """(the shipped parameters, the chosen candidate's name) of ``kind``."""
    import yaml

    from sitcov.perception._pem_classes import load_class_params
    from sitcov.perception._pem_params import PEM_PARAMS_FILE, load_pem_params

    if kind == "car":
        meta = yaml.safe_load(PEM_PARAMS_FILE.read_text())["meta"]["car"]
        return load_pem_params(), meta["model_choice"]["chosen"]
    classes_file = PEM_PARAMS_FILE.with_name("pem_classes.yaml")
    meta = yaml.safe_load(classes_file.read_text())["meta"][kind]
    return load_class_params()[kind][1], meta["model_choice"]["chosen"]


def pass_rates(fit: fm.FrameFit, params: Any, t: fm.Tracks, theta: float) -> np.ndarray:
    """The PEM's P(score >= θ) per frame of ``t``: ``params`` (the fit as PEM parameters,
    with its side gain) plus the fit's extra terms as an intercept offset per frame and
    its close-range noise factor; the detection-only terms (``det_``) as a shift of the
    detection term's bias per frame."""
    offset = np.broadcast_to(np.asarray(fit.extra(t), dtype=float), (len(t.score),))
    det = np.broadcast_to(np.asarray(fit.extra(t, detection=True), dtype=float), offset.shape)
    near = fm.near_of(t)
    out = np.empty(len(t.score))
    for i, f in enumerate(t.feats):
        p = params
        if offset[i] != 0.0 or det[i] != 0.0 or (fit.noise.kn != 0.0 and near[i]):
            sig = params.noise_sigma * math.exp(fit.noise.kn * near[i])
            p = replace(params, bias=params.bias + float(offset[i]), noise_sigma=sig,
                        detect_bias=params.detect_bias + float(det[i]))  # fmt: skip
        out[i] = pass_probability(f, p, theta)
    return out


def marginal_loglik(fit: fm.FrameFit, t: fm.Tracks) -> float:
    """The frames' log-likelihood per frame, each frame alone (its AR state integrated
    over its prior, not filtered from the track's earlier frames): how well the model
    gives each frame's score distribution, which is what the check compares. The
    sequence likelihood of the model choice also rewards predicting a frame from the
    ones before it, which a persistent AR state does even when the mean is off."""
    return fit.marginal_loglik(t) / max(1, len(t.score))


def cells(fit: fm.FrameFit, params: Any, t: fm.Tracks) -> list[dict[str, Any]]:
    """The held-out check's rows (band, θ) and the side table's (side, band, θ)."""
    rates = {th: pass_rates(fit, params, t, th) for th in THETAS}
    rows = []
    appr = t.approach if t.approach is not None else np.zeros(len(t.score))
    for lo, hi in BANDS:
        band = (t.distance >= lo) & (t.distance < hi)
        for th in THETAS:
            row: dict[str, Any] = {"band": f"{lo:g}-{hi:g} m", "theta": th, "n": int(band.sum())}
            if band.sum() >= MIN_FRAMES:
                det = float(np.mean(t.score[band] >= th))
                pem = float(np.mean(rates[th][band]))
                row.update(detector=round(det, 4), pem=round(pem, 4), diff=round(pem - det, 4),
                           ok=abs(pem - det) <= TOLERANCE)  # fmt: skip
            rows.append(row)
        for side, name in SIDE_NAMES.items():
            sel = band & (appr == side)
            if not sel.any():
                continue
            for th in SIDE_THETAS:
                rows.append({"side": name, "band": f"{lo:g}-{hi:g} m", "theta": th,
                             "n": int(sel.sum()),
                             "detector": round(float(np.mean(t.score[sel] >= th)), 4),
                             "pem": round(float(np.mean(rates[th][sel])), 4)})  # fmt: skip
    return rows


def run_kind(
    kind: str, fit_data: KindFrames, held: KindFrames, sets: list[str] | None = None,
    **opts: Any,
) -> list[dict[str, Any]]:  # fmt: skip
    """Every candidate of ``kind`` (the shipped model and it with each extra set, or the
    ``sets`` named: ``base`` the shipped model): held-out log-likelihood, the fit, the
    check's rows. ``opts``: the fits' optimiser options (:func:`fm.fit_tracks`:
    ``extras_from_zero``, ``restarts``, ``starts``, ``stages``)."""
    base_params, chosen = shipped(kind)
    base = next(c for c in fm.candidates_for(kind) if c[0] == chosen)
    cands = [base] + [fm.extended(base, *s) for s in fm.EXTRA_SETS]
    if sets is not None:
        cands = [c for c in cands if (c[0].split("+") + ["base"])[1] in sets]
    t = fm.tracks_of(fit_data)
    even, odd = fm.split_runs(held, "even"), fm.split_runs(held, "odd")
    te, to = fm.tracks_of(even), fm.tracks_of(odd)
    refit_data = KindFrames(sweep=list(fit_data.sweep), runs=[*fit_data.runs, *even.runs])
    tr = fm.tracks_of(refit_data)
    out = []
    for cand in cands:
        clock = time.perf_counter()
        fit = fm.fit_candidate(t, cand, base_params.size_ref_px, **opts)
        ll = fit.loglik(te) / max(1, len(te.score))
        ll_fit = fit.loglik(t) / max(1, len(t.score))
        full = fm.fit_candidate(tr, cand, base_params.size_ref_px, **opts)
        plain = replace(full, extras=(), gains=(), noise=replace(full.noise, kn=0.0))
        params = fm.to_params(plain, base_params, tr, refit_data.runs)
        rows = cells(full, params, to)
        judged = [r for r in rows if "ok" in r]
        # the fit on the fit frames alone (the one scored held out), checked the same way
        bare = replace(fit, extras=(), gains=(), noise=replace(fit.noise, kn=0.0))
        judged1 = [r for r in cells(fit, fm.to_params(bare, base_params, t, fit_data.runs), to)
                   if "ok" in r]  # fmt: skip
        res = {"kind": kind, "label": KIND_LABEL[kind], "candidate": cand[0],
               "heldout_loglik_per_frame": round(ll, 4), "heldout_frames": len(te.score),
               "fit_loglik_per_frame": round(ll_fit, 4),
               "odd_loglik_per_frame": round(full.loglik(to) / max(1, len(to.score)), 4),
               "heldout_marginal_loglik_per_frame": round(marginal_loglik(fit, te), 4),
               "odd_marginal_loglik_per_frame": round(marginal_loglik(full, to), 4),
               "cells_ok_fit_only": sum(r["ok"] for r in judged1),
               "cells_ok": sum(r["ok"] for r in judged), "cells": len(judged),
               "extras": dict(zip(full.extras, [round(g, 4) for g in full.gains],
                                  strict=True)),
               "side_gain": round(full.side_gain, 4), "kn": round(full.noise.kn, 4),
               "options": {k: v for k, v in opts.items() if v},
               "noise": {k: round(float(getattr(full.noise, k)), 4)
                         for k in ("sigma", "up", "share", "rho", "lam", "d0", "d1", "dt",
                                   "df", "k", "po", "ro", "ku", "tl")},
               "wall_s": round(time.perf_counter() - clock, 1),
               "rows": rows}  # fmt: skip
        out.append(res)
        print(report(res), flush=True)
    return out


def report(res: dict[str, Any]) -> str:
    """One candidate's block: log-likelihood, cells, failing cells, side table."""
    lines = [f"== {res['label']} {res['candidate']}: held-out loglik/frame "
             f"{res['heldout_loglik_per_frame']:+.4f} ({res['heldout_frames']} frames; "
             f"on the fit frames {res['fit_loglik_per_frame']:+.4f}; refit on the odd runs "
             f"{res['odd_loglik_per_frame']:+.4f}; frames alone: held out "
             f"{res['heldout_marginal_loglik_per_frame']:+.4f}, odd "
             f"{res['odd_marginal_loglik_per_frame']:+.4f}); "
             f"cells {res['cells_ok']}/{res['cells']} "
             f"(the fit before the refit: {res['cells_ok_fit_only']}); extras {res['extras']} "
             f"side_gain {res['side_gain']} kn {res['kn']}; noise {res['noise']}; "
             f"{res['wall_s']} s"]  # fmt: skip
    fails = [f"{r['band']} θ{r['theta']} {r['diff']:+.3f}"
             for r in res["rows"] if "ok" in r and not r["ok"]]  # fmt: skip
    lines.append("   failing: " + (", ".join(fails) or "none"))
    for r in res["rows"]:
        if "side" in r and r["theta"] == SIDE_THETAS[0]:
            parts = [f"   {r['side']:>6} {r['band']:>8} n={r['n']:5d}"]
            for s in res["rows"]:
                if s.get("side") == r["side"] and s["band"] == r["band"]:
                    parts.append(f"θ{s['theta']}: det {s['detector']:.2f} PEM {s['pem']:.2f}")
            lines.append("  ".join(parts))
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fit", help="fit frames file (.jsonl.gz)")
    parser.add_argument("heldout", help="held-out frames file (even runs choose, odd check)")
    parser.add_argument("--kinds", default="car,pedestrian,cyclist")
    parser.add_argument("--sets", default=None,
                        help="only these (comma-separated EXTRA_SETS names, base: the shipped "
                        "model); default all")  # fmt: skip
    parser.add_argument("--out", default=None, help="write the results as JSON here")
    parser.add_argument("--restarts", type=int, default=0,
                        help="restart each fit's L-BFGS-B this many times from where it "
                        "stopped (kept if better)")  # fmt: skip
    parser.add_argument("--starts", type=int, default=1,
                        help="fit each candidate from this many starts (the others moved "
                        "at random, seeded), keep the best")  # fmt: skip
    parser.add_argument("--stages", type=int, default=1, choices=(1, 2),
                        help="1: every parameter by the sequence likelihood; 2: the two-stage "
                        "fit (marginal terms by the frames alone, then the AR part)")  # fmt: skip
    parser.add_argument("--extras-from-zero", action="store_true",
                        help="start the extra terms at 0 and the rest where the model "
                        "without them starts")  # fmt: skip
    args = parser.parse_args()
    fit_frames, held_frames = read_frames(args.fit), read_frames(args.heldout)
    results = []
    for kind in args.kinds.split(","):
        sets = args.sets.split(",") if args.sets else None
        opts = {"restarts": args.restarts, "extras_from_zero": args.extras_from_zero,
                "starts": args.starts, "stages": args.stages}  # fmt: skip
        results += run_kind(kind, fit_frames[kind], held_frames[kind], sets, **opts)
    if args.out:
        with open(args.out, "w") as fh:  # one candidate a line
            fh.write("[\n" + ",\n".join(json.dumps(r) for r in results) + "\n]\n")


if __name__ == "__main__":
    main()
