"""Where a road user is in the image when the reference AEB fires, by approach side, and how
often a stack blind right of a given fraction of the image fails from each side (PEM mode).

Why examples/aeb_stacks.py's ``RightBlind`` is blind from 0.4 of the image width and not
from its centre (docs/pem.md, "Agreement across stacks"). Situations 0..N-1 of ``--seed``
(the random generator, run seed ``run_seed(seed, i)``, as ``sitcov experiment agreement``'s
stream A), the shipped PEM:

    python benchmarks/bench_blind_side.py --seed 8 --situations 300

prints, per approach side (``sitcov.campaign._agreement.approach_side``), the 10/25/50/75/90th
percentiles of the box centre (over the image width) of the reference AEB's first firing
detection, then per blind edge the failures from the left, the right and ahead with the
one-sided Fisher exact p of "fails more often from the right".
"""

from __future__ import annotations

import argparse

import numpy as np


def main() -> None:
    from scipy.stats import fisher_exact

    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import ReferenceStack
    from sitcov.av._aeb import aeb_test
    from sitcov.campaign._agreement import approach_side
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    parser = argparse.ArgumentParser()
    parser.add_argument("--seed", type=int, default=8)
    parser.add_argument("--situations", type=int, default=300)
    parser.add_argument("--edges", default="1.01,0.5,0.45,0.4")
    args = parser.parse_args()

    class Probe(ReferenceStack):
        """The reference stack, recording its first firing detections' box centres, and
        blind right of ``edge`` of the image width."""

        edge = 1.01

        def _reset_state(self) -> None:
            super()._reset_state()
            self.first: list[float] | None = None

        def _perceive(self, detections, image) -> bool:  # type: ignore[no-untyped-def]
            w = self.camera.width
            seen = [d for d in detections or () if 0.5 * (d.box[0] + d.box[2]) < self.edge * w]
            passing = [
                d for d in seen
                if aeb_test(d, w, self._threshold, self._centering, self._distance, self._classes)
            ]  # fmt: skip
            if passing and self.first is None:
                self.first = [0.5 * (d.box[0] + d.box[2]) / w for d in passing]
            return bool(passing)

    gen = make_generator("random", load_hyperspace())
    backend = EmbeddedBackend(perception="pem", sensor=PEMSensor())
    sits = [gen.ask(ask_rng(args.seed, i)) for i in range(args.situations)]
    sides = [approach_side(s.bins, s.values) for s in sits]
    for edge in (float(e) for e in args.edges.split(",")):
        stack = Probe()
        stack.edge = edge
        fails = {k: [0, 0] for k in ("left", "right", "ahead")}
        mids: dict[str, list[float]] = {k: [] for k in fails}
        for i, (sit, side) in enumerate(zip(sits, sides, strict=True)):
            outcome = backend.run(sit, stack, run_seed(args.seed, i))
            if side in fails:
                fails[side][0] += 1
                fails[side][1] += bool(outcome.failed)
                if stack.first:
                    mids[side].append(min(stack.first))
        if edge > 1.0:
            for side, v in mids.items():
                q = np.round(np.quantile(v, [0.1, 0.25, 0.5, 0.75, 0.9]), 2).tolist() if v else []
                print(
                    f"reference, first firing box centre from the {side}: {list(q)} (n = {len(v)})"
                )
        (nl, kl), (nr, kr) = fails["left"], fails["right"]
        p = fisher_exact([[kr, nr - kr], [kl, nl - kl]], alternative="greater")[1]
        cells = ", ".join(f"{k} {v[1]}/{v[0]}" for k, v in fails.items())
        print(f"blind from {edge:g}: failures {cells}; p(right fails more) = {p:.4f}")


if __name__ == "__main__":
    main()
