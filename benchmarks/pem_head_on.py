"""The close car seen head-on from the front, on the car's recorded camera frames (issue 24).

Split by view angle (``sitcov calibrate --check FILE --check-by angle``), the shipped PEM
gives a car below 10 m seen head-on from the front a score of 0.5 or more in about twice
as many frames as the detector (docs/pem.md, "The check split by view angle"): its view
terms rise smoothly with the view's sine, the detector's score does not. This script
asks the frames whether the held term ``head_on`` (the PEM's ``head_on_gain``: a tent
in the view angle, 1 head-on and 0 at 22.5 degrees, on a front view of a box of 80-500 px)
belongs in the PEM:

1. the car's shipped frame model fitted again on the fit file (its chosen candidate and
   its held terms in ``pem.yaml``'s order; ``--base`` reads a pickled fit of the model
   without its held noise terms, as ``benchmarks/pem_rain_wind.py --save-base`` writes);
2. ``head_on`` added with the rest held (``fit_held_terms``, as ``sitcov calibrate
   --held-term head_on`` does);
3. its gain in frames-alone log-likelihood per frame on the fit file and on three
   held-out files; a term belongs in the PEM when it gains on all of them.

    PYTHONPATH=. python benchmarks/pem_head_on.py --json docs/data/pem-head-on.json
"""

from __future__ import annotations

import argparse
import sys
import time
from typing import Any

from pem_rain_wind import add_base_options, before, car_tracks, load_base, write_result


def shipped_fit(args: argparse.Namespace, fit_file: Any, until: str) -> Any:
    """The base fit of ``args`` with ``pem.yaml``'s held noise terms before ``until``
    fitted in turn on ``fit_file``'s tracks (the logit's held terms before it are in the
    base already): the shipped model as it was before the term ``until`` was added."""
    from sitcov.calibration._frame_model import NOISE_HELD_TERMS, fit_held_terms

    fit = load_base(args, until)
    for name in before(until):
        if name in NOISE_HELD_TERMS:
            fit = fit_held_terms(fit, fit_file, (name,))
    return fit


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_base_options(ap)
    args = ap.parse_args(argv)

    from sitcov.calibration._frame_model import fit_held_terms

    t0 = time.process_time()
    tracks = car_tracks()
    base = shipped_fit(args, tracks["fit file"], "head_on")
    fit = fit_held_terms(base, tracks["fit file"], ("head_on",))

    def per_frame(f: Any, t: Any) -> float:
        return f.marginal_loglik(t) / max(1, len(t.score))

    result = {
        "term": "head_on",
        "gain": round(dict(zip(fit.extras, fit.gains, strict=True))["head_on"], 4),
        "base_loglik_per_frame": {k: round(per_frame(base, t), 4) for k, t in tracks.items()},
        "loglik_gain_per_frame": {
            k: round(per_frame(fit, t) - per_frame(base, t), 4) for k, t in tracks.items()
        },
        "frames": {k: len(t.score) for k, t in tracks.items()},
        "cpu_s": round(time.process_time() - t0, 1),
    }
    write_result(result, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
