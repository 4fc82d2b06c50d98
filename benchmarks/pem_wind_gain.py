"""The windy rain's upper spread: what its gain buys in the check, and costs (issue 24).

The check split by wind (``sitcov calibrate --check FILE --check-by wind``) finds the
shipped PEM short of the detector on a close car in windy rain at θ 0.6 and 0.7, per
frame and more per track (docs/pem.md, "The check split by wind"). The term that widens
the score's upper spread there (``noise_up_rain_wind_gain``, the frame model's
``Noise.uw``) was fitted by the frames-alone likelihood. This script asks, per gain:

1. the held-out check below 10 m on seeds 3 and 4, split by wind, per frame and per
   track: the PEM's share minus the detector's, with the shipped PEM's gain replaced;
2. the gain in log-likelihood per frame over the model without the term (frames alone
   and sequence) on the fit file and three held-out files. The base model is the
   shipped one fitted again from ``pem.yaml``'s meta (:func:`pem_rain_wind.base_fit`)
   with the shipped time constant's size gain and its AR coefficient fitted on the fit
   file by the sequence likelihood; ``--base`` reads a pickled base fit instead.

A gain the check asks for and the likelihood refuses says the term's form, not its size,
is what is missing.

    PYTHONPATH=. python benchmarks/pem_wind_gain.py --json docs/data/pem-wind-gain.json
"""

from __future__ import annotations

import argparse
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

#: The upper spread's gains profiled (0: no term; the shipped gain is added).
GAINS = (0.0, 0.5, 0.8, 1.2)
#: The held-out files of the check.
CHECK_FILES = HELD_FILES[1:]
#: The check's cells reported: (group, θ) below 10 m.
CELLS = (("calm rain", 0.5), ("windy rain", 0.5), ("windy rain", 0.6), ("windy rain", 0.7))


def close_cells(params: Any) -> dict[str, Any]:
    """The check below 10 m split by wind on :data:`CHECK_FILES` (car), per frame and per
    track: PEM minus detector in each of :data:`CELLS`, per file."""
    from sitcov.calibration import _frame_check as fc
    from sitcov.calibration._frames import read_frames

    out: dict[str, Any] = {}
    for name, path, _ in CHECK_FILES:
        data = {"car": read_frames(path)["car"]}
        for how, check in (("frames", fc.check_frames), ("tracks", fc.check_tracks)):
            rows = check(data, {"car": params}, bands=((0.0, 10.0),), split="wind")
            diff = {(r["group"], r["theta"]): r.get("difference") for r in rows}
            out[f"{name}, {how}"] = {f"{g} θ{th}": diff.get((g, th)) for g, th in CELLS}
    return out


def likelihood_profile(
    base: Any, tracks: dict[str, Any], gains: tuple[float, ...]
) -> list[dict[str, Any]]:
    """Per gain: the change in log-likelihood per frame, frames alone and as sequences,
    over ``base`` without the term, on every file of ``tracks``."""
    plain = replace(base, noise=replace(base.noise, uw=0.0))
    ref = {k: (plain.marginal_loglik(t), plain.loglik(t)) for k, t in tracks.items()}
    out = []
    for gain in gains:
        fit = replace(base, noise=replace(base.noise, uw=gain))
        row: dict[str, Any] = {"gain": gain}
        for k, t in tracks.items():
            n = max(1, len(t.score))
            row[k] = {
                "frames_alone": round((fit.marginal_loglik(t) - ref[k][0]) / n, 4),
                "sequence": round((fit.loglik(t) - ref[k][1]) / n, 4),
            }
        out.append(row)
    return out


def with_shipped_persistence(base: Any, fit_tracks: Any, kt: float) -> Any:
    """``base`` with the shipped time constant's size gain ``kt`` and the AR coefficient
    fitted for it on ``fit_tracks`` by the sequence likelihood (the rest held)."""
    from sitcov.calibration import _frame_model as fm

    rho = fm.best_rho(fm.persistence_nll(base, fit_tracks), kt)[1]
    return replace(base, noise=replace(base.noise, rho=rho, kt=kt))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_base_options(ap)
    args = ap.parse_args(argv)

    from sitcov.perception._pem_params import load_pem_params

    t0 = time.process_time()
    shipped = load_pem_params()
    gains = tuple(sorted({*GAINS, shipped.noise_up_rain_wind_gain}))
    base = load_base(args)
    tracks = car_tracks()
    base = replace(base, noise=replace(base.noise, uw=shipped.noise_up_rain_wind_gain))
    base = with_shipped_persistence(base, tracks["fit file"], shipped.noise_tau_size_gain)
    result = {
        "fit_file": _shown(FIT_FILE),
        "shipped_gain": shipped.noise_up_rain_wind_gain,
        "close_check": {
            f"gain {g}": close_cells(replace(shipped, noise_up_rain_wind_gain=g)) for g in gains
        },
        "likelihood": likelihood_profile(base, tracks, gains),
        "frames": {k: len(t.score) for k, t in tracks.items()},
        "cpu_s": round(time.process_time() - t0, 1),
    }
    write_result(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
