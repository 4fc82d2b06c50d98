"""The law over consecutive frames: how long the car's detector noise remembers (issue 24).

A stack brakes on the first frame that passes its test, so its verdicts follow the chance
that *some* frame of a road user's track reaches θ, which the per-frame check does not
see (``sitcov calibrate --check-tracks``; docs/pem.md, "The law over consecutive
frames"). This script asks the car's recorded frames two things:

1. the per-track check on the held-out files (seeds 3 and 4) for the PEM with its noise's
   time constant at a few fixed values (``noise_tau``, no size gain) and as shipped;
2. the size gain of the AR part's time constant (``noise_tau_size_gain``, the frame
   model's ``Noise.kt``) profiled on the sequence likelihood: per gain, the AR coefficient
   fitted on the fit file with everything else held, and the gain in log-likelihood per
   frame over the model without it on the fit file and three held-out files (a term
   belongs in the PEM when it gains on all of them). The base model is the shipped one
   fitted again from ``pem.yaml``'s meta (:func:`pem_rain_wind.base_fit`) with its windy
   rain's term; ``--base`` reads a pickled base fit instead.

    PYTHONPATH=. python benchmarks/pem_tau_size.py --json docs/data/pem-tau-size.json
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))
from pem_rain_wind import (  # noqa: E402
    FIT_FILE,
    HELD_FILES,
    _shown,
    add_base_options,
    car_tracks,
    load_base,
    write_result,
)

#: The time constants [s] of the per-track check's variants (no size gain).
TAUS = (0.25, 0.5, 1.0)
#: The size gains profiled on the sequence likelihood.
GAINS = (-0.5, 0.0, 0.15, 0.2, 0.25, 0.3, 0.35, 0.5, 1.0)
#: The held-out files of the per-track check.
CHECK_FILES = HELD_FILES[1:]


def track_cells(params: Any) -> list[dict[str, Any]]:
    """The per-track check of ``params`` on :data:`CHECK_FILES` (car), per file: each
    (band, θ) cell's detector and PEM shares and whether it is within the tolerance."""
    from sitcov.calibration import _frame_check as fc
    from sitcov.calibration._frames import read_frames

    out = []
    for name, path, _ in CHECK_FILES:
        rows = fc.check_tracks({"car": read_frames(path)["car"]}, {"car": params})
        judged = [r for r in rows if "ok" in r]
        out.append({
            "file": name,
            "within": f"{sum(r['ok'] for r in judged)}/{len(judged)}",
            "cells": {f"{r['band']} θ{r['theta']}": r["difference"] for r in judged},
        })  # fmt: skip
    return out


def profile(base: Any, tracks: dict[str, Any], gains: tuple[float, ...]) -> list[dict[str, Any]]:
    """Per size gain: the AR coefficient fitted on ``tracks["fit file"]`` by the sequence
    likelihood (the rest of ``base`` held) and the gain in sequence log-likelihood per
    frame over ``base`` on every file."""
    from sitcov.calibration import _frame_model as fm

    nll = fm.persistence_nll(base, tracks["fit file"])

    ref = {k: base.loglik(t) for k, t in tracks.items()}
    out = []
    for kt in gains:
        rho = fm.best_rho(nll, kt)[1]
        fit = replace(base, noise=replace(base.noise, rho=rho, kt=kt))
        row: dict[str, Any] = {"size_gain": kt, "rho": round(rho, 4),
                               "tau_s_at_ref": round(-0.1 / math.log(rho), 4)}  # fmt: skip
        for k, t in tracks.items():
            row[k] = round((fit.loglik(t) - ref[k]) / max(1, len(t.score)), 4)
        out.append(row)
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_base_options(ap)
    args = ap.parse_args(argv)

    from sitcov.perception._pem_params import load_pem_params

    t0 = time.process_time()
    shipped = load_pem_params()
    base = load_base(args)
    base = replace(base, noise=replace(base.noise, uw=shipped.noise_up_rain_wind_gain, kt=0.0))
    tracks = car_tracks()
    plain = replace(shipped, noise_tau_size_gain=0.0)
    checks = {f"noise_tau {tau}": track_cells(replace(plain, noise_tau=tau)) for tau in TAUS}
    checks["shipped"] = track_cells(shipped)
    result = {
        "fit_file": _shown(FIT_FILE),
        "shipped": {
            "noise_tau": shipped.noise_tau,
            "noise_tau_size_gain": shipped.noise_tau_size_gain,
        },  # fmt: skip
        "track_check": checks,
        "size_gain_profile": profile(base, tracks, GAINS),
        "frames": {k: len(t.score) for k, t in tracks.items()},
        "cpu_s": round(time.process_time() - t0, 1),
    }
    write_result(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
