"""Cloudiness alone vs fog alone: effect on the camera-mode failure rate (issue 11).

Runs 0..N-1 of ``--seed`` (intersection situation from the random generator's situation,
simulation seed ``run_seed(seed, i)``) are driven by the reference stack (no fault) in
camera mode three times, with every weather element at its mildest bin (0, friction 1.0)
except: nothing (baseline), cloudiness 100, fog_density 100. ``fog_distance`` is 0 in all
three (fog starts at the camera; it does nothing without fog). Same situations and seeds in
each arm, so the differences are paired. Prints failure rates with Wilson 95 % intervals,
and the paired changes with their discordant counts.

    python benchmarks/bench_cloud_vs_fog.py --runs 100 --seed 7 --workers 1
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp

ARMS = {"baseline": {}, "cloudiness_100": {"cloudiness": 100.0}, "fog_100": {"fog_density": 100.0}}
MILD = {
    "cloudiness": 0.0, "precipitation": 0.0, "precipitation_deposits": 0.0,
    "wind_intensity": 0.0, "fog_density": 0.0, "fog_distance": 0.0, "wetness": 0.0,
    "friction": 1.0,
}  # fmt: skip
_STATE: dict = {}


def _run(job: tuple[int, int]) -> dict:
    seed, i = job
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import Situation, load_hyperspace
    from sitcov.sim.embedded import EmbeddedBackend

    if not _STATE:
        _STATE["gen"] = make_generator("random", load_hyperspace())
        _STATE["backend"] = EmbeddedBackend(perception="camera")
        _STATE["stack"] = ReferenceStack()
    base = _STATE["gen"].ask(ask_rng(seed, i))
    out = {"index": i}
    for arm, change in ARMS.items():
        values = {**MILD, **change, "intsit": base.values["intsit"]}
        sit = Situation(dict.fromkeys(values, "-"), values)
        out[arm] = bool(_STATE["backend"].run(sit, _STATE["stack"], run_seed(seed, i)).failed)
    return out


def main() -> None:
    from sitcov.analysis._stats import wilson_interval

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--workers", type=int, default=1)
    args = parser.parse_args()
    jobs = [(args.seed, i) for i in range(args.runs)]
    if args.workers > 1:
        with mp.get_context("spawn").Pool(args.workers) as pool:
            rows = list(pool.imap_unordered(_run, jobs))
    else:
        rows = [_run(j) for j in jobs]
    n = len(rows)
    report: dict = {"runs": n, "seed": args.seed}
    for arm in ARMS:
        k = sum(r[arm] for r in rows)
        lo, hi = wilson_interval(k, n)
        report[arm] = {"failure_rate": round(k / n, 3), "wilson95": [round(lo, 3), round(hi, 3)]}
    for arm in ("cloudiness_100", "fog_100"):
        up = sum(r[arm] and not r["baseline"] for r in rows)
        down = sum(r["baseline"] and not r[arm] for r in rows)
        report[f"{arm}_vs_baseline"] = {"change": round((up - down) / n, 3),
                                        "fail_only_here": up, "pass_only_here": down}  # fmt: skip
    print(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
