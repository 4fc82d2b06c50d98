"""The wind in the rain, on the car's recorded camera frames (issue 24).

In camera mode the wind slants the rendered rain streaks, and the threshold-0.7 stack
fails less often in windy rain; the PEM's rain terms take ``rain_noise``, which has no
wind (docs/weather.md, "The wind in the rain"). Does a wind term belong in the PEM? This
script asks the frames:

1. the car's shipped frame model is fitted again on the fit file (its chosen candidate
   and held logit terms, from ``pem.yaml``'s meta: the model without the windy rain's
   noise term; ``--base`` reads a pickled fit instead);
2. held terms (``fit_held_terms``, everything else held): ``rain`` (a change of the rain
   gain), ``rain_wind`` (the run's precipitation times its wind) and ``rain_wind_size``
   (that times the log size), and the noise term ``up_rain_wind`` (the upper scale in
   windy rain on a box of 100 px or more, shipped since 28 Nov 2026), fitted on the fit
   file;
3. their gain in frames-alone log-likelihood per frame on the fit file and on three
   held-out files; a term belongs in the PEM when it gains on all of them;
4. P(score >= theta) per frame, observed and by the shipped PEM, by box height, in heavy
   rain and dry weather, calm and windy, with the runs each cell's frames come from;
5. that noise term profiled: the score noise's scale above the median times ``exp(g *
   rain_wind * [h >= H])`` (a wider upper spread for a close car in windy rain), for a
   few ``g`` and ``H``, with the rest held; the gain in log-likelihood per frame on every
   file (:func:`upper_scale_profile`; the profile chose the knot, the held fit the gain).

    PYTHONPATH=. python benchmarks/pem_rain_wind.py --json docs/data/pem-rain-wind.json
"""

from __future__ import annotations

import argparse
import json
import pickle
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "docs" / "data"
FIT_FILE = DATA / "pem-frames-top-seed1.jsonl.gz"
HELD_FILES = (
    ("seed 2, odd runs", DATA / "pem-frames-top-seed2.jsonl.gz", "odd"),
    ("seed 3", DATA / "pem-frames-top-seed3.jsonl.gz", "all"),
    ("seed 4", DATA / "pem-frames-top-seed4.jsonl.gz", "all"),
)
THRESHOLDS = (0.5, 0.7)
BANDS = (("< 40 px", 40.0), ("40-100 px", 100.0), (">= 100 px", float("inf")))
TERM_SETS = (("rain", "rain_wind"), ("rain", "rain_wind", "rain_wind_size"), ("up_rain_wind",))
UPPER_GAINS = (0.2, 0.4, 0.6)
UPPER_KNOTS_PX = (60.0, 100.0)
HEAVY_RAIN = 50.0  # precipitation from which a run counts as heavy rain
WINDY = 50.0  # wind_intensity from which a run counts as windy


def held_order() -> list[str]:
    """The car's held terms in ``pem.yaml``'s order (its meta's ``held_terms``)."""
    from sitcov.perception._pem_params import PEM_PARAMS_FILE, read_yaml

    meta = read_yaml(Path(PEM_PARAMS_FILE), "PEM parameters")["meta"]["car"]
    return list(meta.get("held_terms", {}).get("gains", {}))


def before(term: str | None) -> list[str]:
    """The held terms of :func:`held_order` fitted before ``term`` (all without one, or
    when the shipped file does not have it)."""
    order = held_order()
    return order[: order.index(term)] if term in order else order


def base_fit(path: Path, starts: int, until: str | None = None) -> Any:
    """The car's shipped frame model fitted again on ``path`` (pem.yaml's meta), with the
    held logit terms fitted before ``until`` (:func:`before`; all without it)."""
    from sitcov.calibration._frame_model import (
        NOISE_HELD_TERMS,
        candidates_for,
        fit_candidate,
        fit_held_terms,
        tracks_of,
    )
    from sitcov.calibration._frames import read_frames
    from sitcov.perception._pem_params import PEM_PARAMS_FILE, load_pem_params, read_yaml

    meta = read_yaml(Path(PEM_PARAMS_FILE), "PEM parameters")["meta"]["car"]
    chosen = meta["model_choice"]["chosen"]
    held = tuple(n for n in before(until) if n not in NOISE_HELD_TERMS)
    t = tracks_of(read_frames(path)["car"])
    cand = next(c for c in candidates_for("car") if c[0] == chosen)
    fit = fit_candidate(t, cand, load_pem_params().size_ref_px, stages=2, starts=starts)
    return fit_held_terms(fit, t, held)


def wind_table(paths: list[Path], params: Any) -> list[dict[str, Any]]:
    """Observed and modelled P(score >= theta) per frame of ``paths``' car runs, by box
    height band, heavy rain or dry, calm or windy (the frames and the runs they are of)."""
    from sitcov.calibration._frames import read_frames
    from sitcov.perception._pem import pass_probability

    cells: dict[tuple[str, str, str], list[list[float]]] = {}
    runs: dict[tuple[str, str, str], set[tuple[int, int]]] = {}
    for n, path in enumerate(paths):
        for run in read_frames(path)["car"].runs:
            values = (run.situation or {}).get("values", {})
            rain = float(values.get("precipitation", 0.0))
            if 0.0 < rain < HEAVY_RAIN:
                continue
            weather = "heavy rain" if rain >= HEAVY_RAIN else "dry"
            wind = "windy" if float(values.get("wind_intensity", 0.0)) >= WINDY else "calm"
            for fr in run.frames:
                f = fr.features
                if f.height_px < 1.0:
                    continue
                band = next(b for b, hi in BANDS if f.height_px < hi)
                key = (band, weather, wind)
                cells.setdefault(key, []).append(
                    [fr.score, *(pass_probability(f, params, th) for th in THRESHOLDS)]
                )
                runs.setdefault(key, set()).add((n, run.index))
    out = []
    for (band, weather, wind), rows in sorted(cells.items()):
        a = np.asarray(rows)
        row: dict[str, Any] = {
            "height": band,
            "weather": weather,
            "wind": wind,
            "frames": len(a),
            "runs": len(runs[(band, weather, wind)]),
        }
        for k, th in enumerate(THRESHOLDS):
            row[f"observed_{th}"] = round(float(np.mean(a[:, 0] >= th)), 4)
            row[f"pem_{th}"] = round(float(np.mean(a[:, 1 + k])), 4)
        out.append(row)
    return out


def upper_scale_profile(base: Any, tracks: dict[str, Any]) -> list[dict[str, Any]]:
    """Per knot H and gain g: the change in frames-alone log-likelihood per frame of
    ``tracks`` (name -> Tracks) when the upper scale grows by ``exp(g * rain_wind *
    [h >= H])`` (``Noise.uw``, ``Noise.uw_px``), the rest of ``base`` held."""
    out = []
    for knot in UPPER_KNOTS_PX:
        for gain in UPPER_GAINS:
            row: dict[str, Any] = {"knot_px": knot, "gain": gain}
            fit = replace(base, noise=replace(base.noise, uw=gain, uw_px=knot))
            for name, t in tracks.items():
                n = max(1, len(t.score))
                row[name] = round((fit.marginal_loglik(t) - base.marginal_loglik(t)) / n, 4)
            out.append(row)
    return out


def add_base_options(ap: argparse.ArgumentParser) -> None:
    """The options of the scripts that start from the shipped car model fitted again
    (this one's :func:`base_fit`): its starts, a pickled base fit instead, the JSON out."""
    ap.add_argument("--starts", type=int, default=3, help="the base fit's starts (pem.yaml: 3)")
    ap.add_argument("--base", type=Path, help="a pickled base fit (skips its refit)")
    ap.add_argument("--json", type=Path, help="write the result here")


def load_base(args: argparse.Namespace, until: str | None = None) -> Any:
    """The base fit :func:`add_base_options`' ``args`` ask for: pickled, or fitted again
    (with the held logit terms before ``until``, :func:`base_fit`)."""
    if args.base:
        return pickle.loads(args.base.read_bytes())
    return base_fit(FIT_FILE, args.starts, until)


def car_tracks() -> dict[str, Any]:
    """The car's tracks of the fit file (``"fit file"``) and of each of :data:`HELD_FILES`."""
    from sitcov.calibration._frame_model import split_runs, tracks_of
    from sitcov.calibration._frames import read_frames

    tracks = {"fit file": tracks_of(read_frames(FIT_FILE)["car"])}
    return tracks | {name: tracks_of(split_runs(read_frames(path)["car"], part))
                     for name, path, part in HELD_FILES}  # fmt: skip


def write_result(result: dict[str, Any], path: Path | None) -> None:
    """Print ``result`` as JSON and write it to ``path`` too (when given)."""
    text = json.dumps(result, indent=2, ensure_ascii=False)
    print(text)
    if path is not None:
        path.write_text(text + "\n")


def _shown(path: Path) -> str:
    """``path`` relative to the checkout when it is inside it (the JSON names no host)."""
    full = path.resolve()
    return str(full.relative_to(ROOT)) if full.is_relative_to(ROOT) else str(path)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=Path, default=FIT_FILE, help="the fit's frames file")
    ap.add_argument("--starts", type=int, default=3, help="the base fit's starts (pem.yaml: 3)")
    ap.add_argument("--base", type=Path, help="a pickled base fit (skips step 1)")
    ap.add_argument("--save-base", type=Path, help="pickle the base fit here")
    ap.add_argument("--json", type=Path, help="write the result here")
    args = ap.parse_args(argv)

    from sitcov.calibration._frame_model import (
        UP_RAIN_WIND,
        fit_held_terms,
        split_runs,
        tracks_of,
    )
    from sitcov.calibration._frames import read_frames
    from sitcov.perception._pem_params import load_pem_params

    t0 = time.process_time()
    if args.base is not None:
        base = pickle.loads(args.base.read_bytes())
    else:
        base = base_fit(args.frames, args.starts)
        if args.save_base is not None:
            args.save_base.write_bytes(pickle.dumps(base))
    t = tracks_of(read_frames(args.frames)["car"])
    held = {name: tracks_of(split_runs(read_frames(path)["car"], part))
            for name, path, part in HELD_FILES}  # fmt: skip

    def per_frame(fit: Any, tracks: Any) -> float:
        return fit.marginal_loglik(tracks) / max(1, len(tracks.score))

    fits = []
    for names in TERM_SETS:
        fit = fit_held_terms(base, t, names)
        gains = dict(zip(fit.extras, fit.gains, strict=True)) | {UP_RAIN_WIND: fit.noise.uw}
        gains = {n: gains[n] for n in names}
        gain = {"fit file": round(per_frame(fit, t) - per_frame(base, t), 4)}
        gain |= {k: round(per_frame(fit, h) - per_frame(base, h), 4) for k, h in held.items()}
        fits.append({"terms": list(names), "gains": {k: round(v, 4) for k, v in gains.items()},
                     "loglik_gain_per_frame": gain})  # fmt: skip
    result = {
        "fit_file": _shown(args.frames),
        "base_loglik_per_frame": {"fit file": round(per_frame(base, t), 4)}
        | {k: round(per_frame(base, h), 4) for k, h in held.items()},
        "held_frames": {k: len(h.score) for k, h in held.items()},
        "held_terms": fits,
        "upper_scale": upper_scale_profile(base, {"fit file": t, **held}),
        "table": wind_table([args.frames, *(p for _, p, _ in HELD_FILES[1:])], load_pem_params()),
        "cpu_s": round(time.process_time() - t0, 1),
    }  # fmt: skip
    write_result(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
