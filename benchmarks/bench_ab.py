"""Paired A/B of two source trees: `sitcov bench`'s runs, alternating in small batches.

Usage: python benchmarks/bench_ab.py TREE_A TREE_B [--runs 300] [--batch 10] [--rounds 60]
       [--seed 0]

Why paired: this kind of shared machine changes its own speed by up to 1.5x within
minutes, so two builds timed one after the other (``sitcov bench`` in alternating
processes) differ by more than most optimisations gain. Here one persistent process per
tree (``PYTHONPATH=TREE``) prepares ``sitcov bench``'s situations and run seeds (the
``random`` generator with ``ask_rng(seed, i)``, ``run_seed(seed, i)``, reference stack,
PEM, default judge) and runs its warm-up; then both run the same batch of ``--batch``
runs, one after the other, the order swapped every round, so each pair of batches sees
the same moment of the machine. Reported: each tree's median runs per CPU second over
the batches, and the median and interquartile range of the per-round ratio B/A.

The worker uses only names that every sitcov tree since session 5 has (it must run the
old tree too), so it builds the runs itself instead of calling ``sitcov.campaign._bench``.
``SITCOV_NO_JIT=1`` in the environment measures both trees without numba.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time


def worker(runs: int, seed: int, warmup: int = 5) -> None:
    """Serve batches: read ``lo hi`` lines on stdin, answer the batch's CPU seconds."""
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import make_stack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim._judge import Judge
    from sitcov.sim.embedded._backend import EmbeddedBackend

    generator = make_generator("random", load_hyperspace())
    situations = [generator.ask(ask_rng(seed, i)) for i in range(runs)]
    backend = EmbeddedBackend(perception="pem", physics="carla")
    verdict, stack = Judge.from_spec("default"), make_stack("reference")
    for i in range(warmup):
        backend.run(situations[i], stack, run_seed(seed, i))
    print("ready", flush=True)
    for line in sys.stdin:
        lo, hi = map(int, line.split())
        cpu0 = time.process_time()
        for i in range(lo, hi):
            verdict(backend.run(situations[i], stack, run_seed(seed, i)))
        print(time.process_time() - cpu0, flush=True)


class Tree:
    """A worker process running sitcov from one source tree."""

    def __init__(self, path: str, runs: int, seed: int) -> None:
        self.path = os.path.abspath(path)
        env = dict(os.environ, PYTHONPATH=self.path)
        cmd = [sys.executable, os.path.abspath(__file__), "--worker", str(runs), str(seed)]
        self.proc = subprocess.Popen(
            cmd, cwd=self.path, env=env, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )
        if self.proc.stdout.readline().strip() != "ready":
            raise SystemExit(f"{self.path}: the worker did not start (is it a sitcov tree?)")
        self.rates: list[float] = []

    def batch(self, lo: int, hi: int) -> float:
        """Run situations ``lo`` to ``hi - 1``; their runs per CPU second."""
        self.proc.stdin.write(f"{lo} {hi}\n")
        self.proc.stdin.flush()
        rate = (hi - lo) / float(self.proc.stdout.readline())
        self.rates.append(rate)
        return rate

    def close(self) -> None:
        self.proc.stdin.close()
        self.proc.wait()


def compare(a: Tree, b: Tree, runs: int, batch: int, rounds: int) -> list[float]:
    """Alternate the two trees over ``rounds`` batches; the per-round ratios B/A."""
    ratios = []
    for r in range(rounds):
        lo = (r * batch) % runs
        hi = min(lo + batch, runs)
        first, second = (a, b) if r % 2 == 0 else (b, a)
        first.batch(lo, hi)
        second.batch(lo, hi)
        ratios.append(b.rates[-1] / a.rates[-1])
    return ratios


def main() -> None:
    """Print each tree's median runs/s and the paired ratio."""
    if len(sys.argv) > 1 and sys.argv[1] == "--worker":
        worker(int(sys.argv[2]), int(sys.argv[3]))
        return
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("tree_a")
    parser.add_argument("tree_b")
    parser.add_argument("--runs", type=int, default=300)
    parser.add_argument("--batch", type=int, default=10)
    parser.add_argument("--rounds", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    if not 0 < args.batch <= args.runs:
        parser.error(f"--batch must be between 1 and --runs ({args.runs}), got {args.batch}")
    a, b = Tree(args.tree_a, args.runs, args.seed), Tree(args.tree_b, args.runs, args.seed)
    try:
        ratios = compare(a, b, args.runs, args.batch, args.rounds)
    finally:
        a.close()
        b.close()
    for tree in (a, b):
        rates = tree.rates
        print(
            f"{tree.path}: median {statistics.median(rates):.1f} runs/s per CPU second "
            f"(min {min(rates):.1f}, max {max(rates):.1f}, {len(rates)} batches)"
        )
    q1, _, q3 = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else (ratios * 3)
    print(f"B/A: median {statistics.median(ratios):.3f} (interquartile {q1:.3f}-{q3:.3f})")


if __name__ == "__main__":
    main()
