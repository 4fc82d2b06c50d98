"""Throughput of the embedded backend with the reference stack and PEM (one core).

Usage: python benchmarks/bench_embedded.py [--runs N] [--seed S] [--profile]

Same figures as ``sitcov bench``; ``--profile`` prints the cProfile top 20 by own time.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats

from sitcov.campaign._bench import bench


def main() -> None:
    """Parse arguments, run the benchmark, print runs/s, ms/run and mean steps."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fault", default=None)
    parser.add_argument("--profile", action="store_true")
    args = parser.parse_args()
    if args.profile:
        profiler = cProfile.Profile()
        result = profiler.runcall(bench, args.runs, args.seed, fault=args.fault)
        pstats.Stats(profiler).sort_stats("tottime").print_stats(20)
    else:
        result = bench(args.runs, args.seed, fault=args.fault)
    print(
        f"runs={result['runs']} runs/s={result['runs_per_s']:.1f} "
        f"ms/run={result['ms_per_run']:.2f} mean_steps={result['mean_steps']:.1f} "
        f"failures={result['failures']} end_reasons={result['end_reasons']}"
    )


if __name__ == "__main__":
    main()
