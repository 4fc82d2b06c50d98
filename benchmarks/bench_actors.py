"""Cost of a run of the embedded world by number of actors (ego included): 2, 3, 5, 9.

Usage: python benchmarks/bench_actors.py [--runs N] [--seed S] [--counts 2,3,5,9]

Random default-hyperspace situations (the ``random`` generator, as ``sitcov bench``),
reference stack, PEM; the extra actors are the first ``count - 2`` of :data:`EXTRA`
(pedestrians on crosswalks, cyclists, scripted cars). CPU time of this process
(``time.process_time``), so other load on the machine counts less; per run and per
simulated step (runs end at different times). The first ``--warmup`` situations of each
count run once untimed first (imports, compiled kernels, per-route caches: paid once per
process, not per run).
"""

from __future__ import annotations

import argparse
import time

from sitcov._seeding import ask_rng, run_seed
from sitcov.av import make_stack
from sitcov.generation import make_generator
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim.embedded import EmbeddedBackend

#: Extra actor slots, in the order they are added.
EXTRA = [
    {"kind": "pedestrian", "route": "XBL", "behaviour": "cross"},
    {"kind": "cyclist", "route": "B-L", "behaviour": "cruise"},
    {"kind": "car", "route": "R-L", "behaviour": "cruise"},
    {"kind": "pedestrian", "route": "XRR", "behaviour": "kerb"},
    {"kind": "pedestrian", "route": "XLL", "behaviour": "hesitate"},
    {"kind": "car", "route": "B-R", "behaviour": "cruise"},
    {"kind": "cyclist", "route": "L-R", "behaviour": "timed"},
]


def with_actors(situation: Situation, count: int) -> Situation:
    """``situation`` with ``count - 2`` extra actor slots."""
    bins, values = dict(situation.bins), dict(situation.values)
    for i, slot in enumerate(EXTRA[: count - 2]):
        bins[f"actor{i + 2}"] = f"{slot['kind']}-{slot['route']}"
        values[f"actor{i + 2}"] = slot
    return Situation(bins=bins, values=values)


def measure(count: int, runs: int, seed: int, warmup: int = 5) -> dict[str, float]:
    """CPU ms per run and us per step for scenes of ``count`` actors."""
    generator = make_generator("random", load_hyperspace())
    situations = [with_actors(generator.ask(ask_rng(seed, i)), count) for i in range(runs)]
    backend, stack = EmbeddedBackend(), make_stack("reference")
    for i, s in enumerate(situations[:warmup]):
        backend.run(s, stack, run_seed(seed, i))
    steps = 0
    cpu0 = time.process_time()
    for i, s in enumerate(situations):
        steps += backend.run(s, stack, run_seed(seed, i)).metrics["steps"]
    cpu = time.process_time() - cpu0
    return {
        "actors": count,
        "runs_per_s": runs / cpu,
        "ms_per_run": 1000.0 * cpu / runs,
        "us_per_step": 1e6 * cpu / steps,
        "mean_steps": steps / runs,
    }


def main() -> None:
    """Print one line per actor count."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--counts", default="2,3,5,9")
    parser.add_argument("--warmup", type=int, default=5)
    args = parser.parse_args()
    for count in (int(c) for c in args.counts.split(",")):
        r = measure(count, args.runs, args.seed, args.warmup)
        print(
            f"actors={r['actors']} runs/s={r['runs_per_s']:.1f} ms/run={r['ms_per_run']:.2f} "
            f"us/step={r['us_per_step']:.1f} mean_steps={r['mean_steps']:.1f}"
        )


if __name__ == "__main__":
    main()
