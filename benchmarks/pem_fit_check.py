"""One frame-model candidate fitted on one recording and checked on all runs of another.

The quick form of ``benchmarks/pem_cell_candidates.py``: the class's shipped model
(``meta``'s ``model_choice.chosen``), or it with other extra logit terms, the outlier
frames or the lower tail, is fitted on ``FIT`` (the two-stage fit of ``sitcov
calibrate``, one start) and scored on every run of ``HELD``: the frames-alone
log-likelihood per frame and the held-out check's cells (P(score >= θ), PEM vs
detector, per distance band), then the close frames (< 10 m) by truncation. No refit,
no model choice: a measurement of one candidate, not a shipped fit.

    python benchmarks/pem_fit_check.py docs/data/pem-frames-pedestrian-seed1.jsonl.gz \\
        docs/data/pem-frames-pedestrian-seed3.jsonl.gz --kind pedestrian --tail

``--held-terms A,B`` (repeatable) then adds those terms to the fitted model with the
rest held (``fit_held_terms``, as ``sitcov calibrate --held-term`` does) and prints, per
set, the fit's and each held-out file's frames-alone likelihood per frame, cells and
close (< 10 m) θ 0.5 / 0.6 differences; ``HELD`` may name several files
(comma-separated, each with its ``#even``/``#odd``):

    D=docs/data; python benchmarks/pem_fit_check.py $D/pem-frames-top-seed1.jsonl.gz \\
        "$D/pem-frames-top-seed2.jsonl.gz#even,$D/pem-frames-top-seed2.jsonl.gz#odd" \\
        --held-terms cut_tent150 --held-terms cut_tent180 --held-terms cut_tent220
"""

from __future__ import annotations

import argparse
import time
from dataclasses import replace

import numpy as np
from pem_cell_candidates import cells, marginal_loglik, pass_rates, shipped

from sitcov.calibration import _frame_model as fm
from sitcov.calibration._frames import read_frames

#: Truncation bins of the close frames' table.
TRUNCATION_BINS = ((0.0, 0.001), (0.001, 0.1), (0.1, 0.2), (0.2, 0.3), (0.3, 0.5),
                   (0.5, 0.7), (0.7, 0.9), (0.9, 1.01))  # fmt: skip
THETAS = (0.2, 0.3, 0.5, 0.6, 0.7)


def candidate(
    kind: str, extras: str | None, outliers: bool, tail: bool, model: str | None = None,
    near_noise: bool = False, noise_bend: float | None = None,
) -> tuple:  # fmt: skip
    """The shipped model of ``kind`` (or the candidate named ``model``), or it with
    ``extras`` (comma-separated, in place of its own), the outlier frames, the lower tail,
    the noise scale's close-range factor (``Noise.kn``: below 10 m) and the noise's size
    bend (``Noise.kb``: at ``noise_bend`` px)."""
    chosen = model or shipped(kind)[1]
    base = next(c for c in fm.candidates_for(kind) if c[0] == chosen)
    if extras is None and not outliers and not tail and not near_noise and noise_bend is None:
        return base
    names = tuple(x for x in (extras or "").split(",") if x)
    if extras is None:
        names, *_ = fm._extras(base)
    return fm.extended(base, "x", names, near_noise, outliers, False, tail, noise_bend)


def frames_of(specs: list[str], kind: str) -> fm.KindFrames:
    """The ``kind``'s frames of the files ``specs``, merged; a ``#even``/``#odd`` suffix
    keeps that file's runs of even or odd index (as the shipped fit splits a held-out
    file: it is refitted on the even runs, the odd ones are left for the check)."""
    merged = fm.KindFrames()
    for spec in specs:
        path, _, part = spec.partition("#")
        data = read_frames(path)[kind]
        if part:
            data = fm.split_runs(data, part)
        merged.sweep.extend(data.sweep)
        merged.runs.extend(data.runs)
    return merged


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "fit",
        help="fit frames file (.jsonl.gz); several: comma-separated; FILE#even or FILE#odd: "
        "that file's runs of even or odd index only",
    )
    parser.add_argument(
        "held",
        help="held-out frames file: every run is checked (FILE#odd: its odd runs); several: "
        "comma-separated (the detailed table is the first's)",
    )
    parser.add_argument("--kind", default="car", choices=("car", "pedestrian", "cyclist"))
    parser.add_argument(
        "--extras",
        default=None,
        help="extra logit terms, comma-separated (default: the model's own)",
    )
    parser.add_argument("--outliers", action="store_true", help="with outlier frames")
    parser.add_argument("--tail", action="store_true", help="with the lower tail")
    parser.add_argument(
        "--near-noise", action="store_true", help="with the noise scale's close-range factor"
    )
    parser.add_argument(
        "--noise-bend",
        type=float,
        default=None,
        metavar="PX",
        help="with the noise's size bend at PX px (Noise.kb)",
    )
    parser.add_argument(
        "--model", default=None, help="the candidate to start from (default: the shipped one)"
    )
    parser.add_argument(
        "--held-terms",
        action="append",
        default=[],
        metavar="A,B",
        help="extra terms added to the fitted model with the rest held (repeatable: one set each)",
    )
    args = parser.parse_args()
    params0, _ = shipped(args.kind)
    cand = candidate(
        args.kind,
        args.extras,
        args.outliers,
        args.tail,
        args.model,
        args.near_noise,
        args.noise_bend,
    )
    fit_data = frames_of(args.fit.split(","), args.kind)
    t = fm.tracks_of(fit_data)
    helds = {spec: fm.tracks_of(frames_of([spec], args.kind)) for spec in args.held.split(",")}
    held = next(iter(helds.values()))
    clock = time.perf_counter()
    fit = fm.fit_candidate(t, cand, params0.size_ref_px, stages=2)
    bare = replace(fit, extras=(), gains=(), noise=replace(fit.noise, kn=0.0))
    params = fm.to_params(bare, params0, t, fit_data.runs)
    rows = [r for r in cells(fit, params, held) if "ok" in r]
    print(
        f"{args.kind} {cand[0]} {fm._extras(cand)}: held-out frames alone "
        f"{marginal_loglik(fit, held):+.4f} per frame, cells "
        f"{sum(r['ok'] for r in rows)}/{len(rows)}, {time.perf_counter() - clock:.0f} s"
    )
    print("  extras", dict(zip(fit.extras, [round(g, 3) for g in fit.gains], strict=True)),
          {k: round(float(getattr(fit.noise, k)), 3)
           for k in ("sigma", "up", "d0", "d1", "dt", "df", "k", "kn", "kb", "po",
                     "ro", "tl")})  # fmt: skip
    for r in rows:
        print(
            f"  {r['band']:>8} θ{r['theta']} detector {r['detector']:.3f} PEM {r['pem']:.3f}"
            f" {r['diff']:+.3f} {'ok' if r['ok'] else 'NO'}"
        )
    near = (held.distance >= 0) & (held.distance < 10)
    trunc = np.asarray([f.truncation for f in held.feats])
    rates = {th: pass_rates(fit, params, held, th) for th in THETAS}
    print("  below 10 m by truncation, P(score >= θ) detector/PEM:")
    for lo, hi in TRUNCATION_BINS:
        sel = near & (trunc >= lo) & (trunc < hi)
        if sel.sum() >= 20:
            cols = " ".join(f"{th}:{np.mean(held.score[sel] >= th):.2f}/"
                            f"{np.mean(rates[th][sel]):.2f}" for th in THETAS)  # fmt: skip
            print(f"  truncation {lo}-{hi} n={int(sel.sum())} {cols}")
    if args.held_terms:
        print("held terms (the rest held), frames alone per frame, cells, close θ 0.5 / 0.6:")
        print(held_line("none", fit, params, t, helds))
    for names in args.held_terms:
        more = fm.fit_held_terms(fit, t, tuple(n for n in names.split(",") if n))
        gains = ", ".join(f"{n} {g:+.3f}" for n, g in zip(more.extras, more.gains, strict=True)
                          if n not in fit.extras)  # fmt: skip
        print(held_line(gains, more, params, t, helds))


def held_line(
    name: str, fit: fm.FrameFit, params: object, t: fm.Tracks, helds: dict[str, fm.Tracks]
) -> str:
    """One line of the held terms' table: the fit's own frames and each held-out file's."""
    parts = [f"  {name}: fit {marginal_loglik(fit, t):+.4f}"]
    for spec, h in helds.items():
        rows = [r for r in cells(fit, params, h) if "ok" in r]
        close = {r["theta"]: r["diff"] for r in rows if r["band"] == "0-10 m"}
        parts.append(
            f"{spec.rsplit('/', 1)[-1]} {marginal_loglik(fit, h):+.4f} "
            f"{sum(r['ok'] for r in rows)}/{len(rows)} "
            f"({close.get(0.5, float('nan')):+.3f} / {close.get(0.6, float('nan')):+.3f})"
        )
    return "  ".join(parts)


if __name__ == "__main__":
    main()
