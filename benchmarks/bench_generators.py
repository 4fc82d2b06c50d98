"""Situations per second of every generator on the default hyperspace, one core.

Usage: python benchmarks/bench_generators.py [-n 20000] [--seed 0] [--repeat 3] [--fresh-rng]

Prints one line per generator with the best of ``--repeat`` measurements (the machine may
be shared; the best run is the least disturbed). ``sitcov`` must reach 20,000 per second.
"""

from __future__ import annotations

import argparse
import os

from sitcov.generation._bench import bench_generators


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-n", type=int, default=20_000, help="situations per generator")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    parser.add_argument(
        "--fresh-rng", action="store_true", help="a new rng per ask, as campaigns do"
    )
    args = parser.parse_args()
    if hasattr(os, "sched_setaffinity"):
        os.sched_setaffinity(0, {min(os.sched_getaffinity(0))})  # one core
    best: dict[str, float] = {}
    for _ in range(args.repeat):
        for name, rate in bench_generators(args.n, args.seed, fresh_rng=args.fresh_rng).items():
            best[name] = max(best.get(name, 0.0), rate)
    for name, rate in best.items():
        print(f"{name:16s} {rate:12,.0f} situations/s")


if __name__ == "__main__":
    main()
