"""How many perception draws make a PEM verdict reproducible: the choice of
``sitcov run --perception-draws``, made without the camera.

One PEM run's verdict is a draw (docs/pem.md, "Perception draws"). The majority of K
draws of the same world is a verdict too, and two such majorities from disjoint draws
agree more often as K grows. This script runs each situation's world (the agreement
experiment's situations and stream-A run seeds of ``--seed``) with ``2 * max(K)``
perception draws (draw 0 the run itself, draw j its ``draw_seed(run seed, j)``, as
:class:`sitcov.campaign._draws.PerceptionDraws` does) and prints, per stack and odd K,
the agreement of the majority of draws 0..K-1 with the majority of draws K..2K-1, with
its Wilson 95 % interval, and the failure rate of the first majority. No camera run and
no camera verdict enters the choice; the camera's own reproducibility with the world
shared (docs/pem.md, "Where the ceiling comes from") is the level to reach.

    PYTHONPATH=. python benchmarks/pem_draws_choice.py --seed 9 --situations 1000 \\
        --max-draws 15 --workers 2 --stack reference,examples.aeb_stacks:Threshold07,\\
examples.aeb_stacks:ThreeFrames,examples.aeb_stacks:RightBlind
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

_WORKER: dict[str, Any] = {}


def _draws(job: tuple[str, int, int, int]) -> tuple[int, list[int]]:
    """The verdicts (1 = fail) of ``n`` perception draws of situation ``index``."""
    from sitcov._seeding import ask_rng, draw_seed
    from sitcov.av import make_stack
    from sitcov.campaign._agreement import stream_seed
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim.embedded import EmbeddedBackend

    stack_name, seed, index, n = job
    if _WORKER.get("stack_name") != stack_name:
        _WORKER.update(stack_name=stack_name, stack=make_stack(stack_name),
                       backend=EmbeddedBackend(perception="pem"),
                       generator=make_generator("random", load_hyperspace()))  # fmt: skip
    situation = _WORKER["generator"].ask(ask_rng(seed, index))
    run_seed = stream_seed("A", seed, index)
    backend, stack = _WORKER["backend"], _WORKER["stack"]
    verdicts = []
    for j in range(n):
        sense = None if j == 0 else draw_seed(run_seed, j)
        outcome = backend.run(situation, stack, run_seed, perception_seed=sense)
        verdicts.append(int(outcome.failed))
    return index, verdicts


def choice_table(verdicts: np.ndarray, max_draws: int) -> list[dict[str, Any]]:
    """Per odd K up to ``max_draws``: the agreement of two majorities of K disjoint draws
    (columns 0..K-1 and K..2K-1 of ``verdicts``, situations x draws) and the first
    majority's failure rate."""
    from sitcov.analysis import wilson_interval

    rows = []
    n = len(verdicts)
    for k in range(1, max_draws + 1, 2):
        first = verdicts[:, :k].sum(axis=1) * 2 > k
        second = verdicts[:, k : 2 * k].sum(axis=1) * 2 > k
        agree = int((first == second).sum())
        lo, hi = wilson_interval(agree, n)
        rows.append({"draws": k, "agreement": agree / n, "ci95": [lo, hi],
                     "failure_rate": float(first.mean())})  # fmt: skip
    return rows


def main() -> None:
    """Parse the arguments, run the draws, print one table per stack."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seed", type=int, default=9, help="evaluation seed (not a PEM fit's)")
    parser.add_argument("--situations", type=int, default=1000)
    parser.add_argument("--max-draws", type=int, default=15, help="largest K (odd)")
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--stack", default="reference", help="comma-separated stacks")
    parser.add_argument("--json", type=Path, default=None, help="write the tables here")
    args = parser.parse_args()
    if args.max_draws < 1 or args.max_draws % 2 == 0:
        raise SystemExit("--max-draws: an odd whole number >= 1")
    start = time.perf_counter()
    tables: dict[str, Any] = {}
    for stack in args.stack.split(","):
        jobs = [(stack, args.seed, i, 2 * args.max_draws) for i in range(args.situations)]
        with ProcessPoolExecutor(args.workers) as pool:
            done = dict(pool.map(_draws, jobs, chunksize=20))
        verdicts = np.asarray([done[i] for i in range(args.situations)])
        tables[stack] = choice_table(verdicts, args.max_draws)
        print(f"== {stack} (seed {args.seed}, {args.situations} situations)")
        for row in tables[stack]:
            lo, hi = row["ci95"]
            print(f"  K {row['draws']:>2}: two majorities agree {100 * row['agreement']:5.1f}% "
                  f"[{100 * lo:4.1f}, {100 * hi:4.1f}], failing {100 * row['failure_rate']:5.1f}%",
                  flush=True)  # fmt: skip
    print(f"{time.perf_counter() - start:.0f} s wall on {args.workers} worker(s)")
    if args.json is not None:
        args.json.write_text(json.dumps(tables, indent=2) + "\n")


if __name__ == "__main__":
    main()
