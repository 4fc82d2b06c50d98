"""How often ``sitcov explain`` calls a null element or pair significant: its family-wise
error on simulated campaigns whose truth has main effects only.

Usage: python benchmarks/explain_calibration.py [--runs 300,600,1000] [--campaigns 100]
       [--bootstrap 0] [--element-bootstrap 39] [--seed 0]

``PYTHONPATH=OLD ... --element-bootstrap -1`` measures a tree from before the element
tests' Bartlett factor (commit 1086c43 and earlier).

Each campaign draws ``runs`` situations of the default hyperspace, every bin uniform (as
the coverage generators make them), and fails each with a logistic truth that has two real
elements: friction (bins 0.1 and 0.2 fail with +4 logits, 1.0 with -2, as the reference
stack on the embedded backend) and the intersection situation (a slope of 0.15 logit per
situation). The seven other elements have no effect, and no pair interacts. Reported per
size: in how many campaigns some null element was significant (Holm, alpha 0.05), in how
many some pair was (``--bootstrap`` > 0; the pair tests' own bootstrap), and the mean
Bartlett factor of the element tests. Both should be near 5 % (docs/explain.md,
"Calibration").
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from sitcov.analysis import interaction_analysis
from sitcov.hyperspace import load_hyperspace

#: the elements with a real effect in the simulated truth
REAL = ("friction", "intsit")


def campaign(hs, runs: int, rng: np.random.Generator) -> list[dict]:
    """``runs`` judged runs with uniform bins, failing by the main-effects truth above."""
    names = hs.element_names
    friction, intsit = names.index("friction"), names.index("intsit")
    out = []
    for _ in range(runs):
        idx = [int(rng.integers(size)) for size in hs.sizes]
        z = -0.3 + (4.0 if idx[friction] <= 1 else 0.0) - (2.0 if idx[friction] == 5 else 0.0)
        z += 0.15 * (idx[intsit] - 5.5)
        fail = rng.random() < 1.0 / (1.0 + math.exp(-z))
        bins = {el.name: el.labels[i] for el, i in zip(hs.elements, idx, strict=True)}
        out.append({"bins": bins, "status": "fail" if fail else "pass"})
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", default="300,600,1000", help="campaign sizes, comma-separated")
    parser.add_argument("--campaigns", type=int, default=100, help="campaigns per size")
    parser.add_argument("--bootstrap", type=int, default=0, help="pair tests' replicates (0: none)")
    parser.add_argument(
        "--element-bootstrap",
        type=int,
        default=39,
        help="Bartlett replicates (0: none; -1: not passed, for trees before the factor)",
    )
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    hs = load_hyperspace()
    for runs in (int(r) for r in args.runs.split(",")):
        clock = time.perf_counter()
        elements = pairs = 0
        scales = []
        for c in range(args.campaigns):
            rng = np.random.default_rng([args.seed, runs, c])
            extra = (
                {} if args.element_bootstrap < 0 else {"element_bootstrap": args.element_bootstrap}
            )
            res = interaction_analysis(
                hs, campaign(hs, runs, rng), bootstrap=args.bootstrap, seed=c, **extra
            )
            elements += any(t["significant"] and t["element"] not in REAL for t in res["elements"])
            pairs += any(t["significant"] for t in res["pairs"])
            scales.append(res.get("element_lr_scale") or 1.0)
        print(
            f"{runs} runs, {args.campaigns} campaigns: a null element significant in "
            f"{elements} ({100 * elements / args.campaigns:.0f} %), a pair in {pairs}"
            f"{'' if args.bootstrap else ' (pairs not tested)'}; element Bartlett factor "
            f"{np.mean(scales):.3f}; {time.perf_counter() - clock:.0f} s",
            flush=True,
        )


if __name__ == "__main__":
    main()
