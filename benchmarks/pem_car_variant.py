"""A car PEM file for one frame-model candidate, by the shipped command's protocol.

`sitcov calibrate --frames-from FIT --heldout HELD --kinds car` chooses among every car
candidate; this fits one: a car candidate (``--model``, by default the side-on-bend
model the lower tail was offered on) with the extra logit terms, outlier frames and
lower tail named here, fitted on ``FIT``,
scored on ``HELD``'s even runs, refitted on both (``fit_kind`` with that one candidate)
and written as a ``pem.yaml`` for ``sitcov experiment agreement --pem FILE`` or
``sitcov calibrate --check ... --pem FILE``: what a term would change in verdicts,
measured before it becomes a candidate. Extra terms need a PEM parameter
(``EXTRA_TERM_PARAMS``), e.g. ``cut`` (``cut_gain``).

    python benchmarks/pem_car_variant.py docs/data/pem-frames-top-seed1.jsonl.gz \\
        docs/data/pem-frames-top-seed2.jsonl.gz --extras hinge40,hinge80,view_hinge40,cut \\
        --tail --out /tmp/pem-cut.yaml
"""

from __future__ import annotations

import argparse
from pathlib import Path

from pem_fit_check import candidate

from sitcov.calibration import _frame_model as fm
from sitcov.calibration._frames import read_frames
from sitcov.perception._pem_params import load_pem_params


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("fit", help="fit frames file (.jsonl.gz)")
    parser.add_argument("held", help="held-out frames file: its even runs score, then join")
    parser.add_argument("--model", default="ar1_edge_scale_image_size_hinge_view",
                        help="the car candidate to start from")  # fmt: skip
    parser.add_argument(
        "--extras",
        default="hinge40,hinge80,view_hinge40",
        help="extra logit terms, comma-separated (in place of the model's)",
    )
    parser.add_argument("--outliers", action="store_true", help="with outlier frames")
    parser.add_argument("--tail", action="store_true", help="with the lower tail")
    parser.add_argument("--starts", type=int, default=1, help="stage 1's starts")
    parser.add_argument("--out", required=True, help="the pem.yaml to write")
    args = parser.parse_args()
    cand = candidate("car", args.extras, args.outliers, args.tail, args.model)
    data, held = read_frames(args.fit)["car"], read_frames(args.held)["car"]
    params, summary = fm.fit_kind(data, load_pem_params(), held=held, candidates=[cand],
                                  starts=args.starts)  # fmt: skip
    command = "python benchmarks/pem_car_variant.py " + " ".join(
        [args.fit, args.held, "--model", args.model]
        + ["--extras", args.extras] * (args.extras is not None)
        + ["--outliers"] * args.outliers + ["--tail"] * args.tail
        + ["--starts", str(args.starts), "--out", args.out]
    )  # fmt: skip
    Path(args.out).write_text(fm.frame_yaml({"car": (params, summary)}, command, [1],
                                            classes=False))  # fmt: skip
    held_out = summary["model_choice"]["table"][cand[0]]["heldout_marginal_loglik_per_frame"]
    print(
        f"{cand[0]} {fm._extras(cand)}: held-out frames alone {held_out:+.4f} per frame; "
        f"cut_gain {params.cut_gain}, noise_low_tail {params.noise_low_tail}; wrote {args.out}"
    )


if __name__ == "__main__":
    main()
