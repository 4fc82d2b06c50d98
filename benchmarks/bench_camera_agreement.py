"""Camera mode vs PEM mode: failure agreement on the same situations and seeds, and speed.

Usage::

    python benchmarks/bench_camera_agreement.py                     # 200 runs (slow: camera)
    python benchmarks/bench_camera_agreement.py --runs 40 --out agreement.json
    python benchmarks/bench_camera_agreement.py --pem-params other_pem.yaml

For runs 0..N-1 of a random-generator campaign (``--seed``; situations from
``ask_rng(seed, i)``, simulation seeds ``run_seed(seed, i)``) the reference stack (no fault)
drives the embedded backend three times: with the shipped PEM, optionally with another PEM
parameter file, and in camera mode (renderer + SSD detector). Prints, as one JSON object:

- agreement on failure / no failure between camera mode and each PEM,
- failure rates and, per element, the largest per-bin difference of the failure rate,
- camera-mode CPU time per run and frames rendered per run (wall time too, which depends on
  the other load of the machine).

Per-run results are appended to ``--log`` (JSON lines) as they finish, so a long run that
is interrupted still leaves its data. Needs the detector model (``sitcov models fetch``).
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import defaultdict
from pathlib import Path
from typing import Any


def _rates(rows: list[dict[str, Any]], key: str) -> dict[str, dict[str, float]]:
    table: dict[str, dict[str, list[int]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        for el, b in r["bins"].items():
            table[el][b].append(int(r[key]))
    return {el: {b: sum(v) / len(v) for b, v in bins.items()} for el, bins in table.items()}


def _compare(rows: list[dict[str, Any]], key: str) -> dict[str, Any]:
    n = len(rows)
    agree = sum(r[key] == r["camera"] for r in rows)
    cam_rates, pem_rates = _rates(rows, "camera"), _rates(rows, key)
    per_element = {
        el: round(max(abs(cam_rates[el][b] - pem_rates[el][b]) for b in cam_rates[el]), 3)
        for el in cam_rates
    }
    return {
        "agreement": round(agree / n, 3),
        "failure_rate_pem": round(sum(r[key] for r in rows) / n, 3),
        "failure_rate_camera": round(sum(r["camera"] for r in rows) / n, 3),
        "camera_fails_pem_passes": sum(r["camera"] and not r[key] for r in rows),
        "pem_fails_camera_passes": sum(r[key] and not r["camera"] for r in rows),
        "max_bin_failure_rate_difference": per_element,
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--pem-params", type=Path, default=None, help="A second PEM to compare.")
    parser.add_argument("--log", type=Path, default=Path("camera_agreement.jsonl"))
    parser.add_argument("--out", type=Path, default=None)
    args = parser.parse_args(argv)

    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception import PEMSensor, SSDDetector
    from sitcov.sim.embedded import EmbeddedBackend

    hs = load_hyperspace()
    gen = make_generator("random", hs)
    pem = EmbeddedBackend(perception="pem", sensor=PEMSensor())
    other = (
        EmbeddedBackend(perception="pem", sensor=PEMSensor(args.pem_params))
        if args.pem_params
        else None
    )
    cam = EmbeddedBackend(perception="camera")
    frames = {"n": 0}
    original = cam._frame

    def counting(*a: Any, **k: Any) -> Any:
        frames["n"] += 1
        return original(*a, **k)

    cam._frame = counting  # type: ignore[method-assign]
    stack = ReferenceStack()
    cam_stack = ReferenceStack(detector=SSDDetector())
    rows: list[dict[str, Any]] = []
    cpu = wall = 0.0
    with open(args.log, "w") as log:
        for i in range(args.runs):
            sit = gen.ask(ask_rng(args.seed, i))
            seed = run_seed(args.seed, i)
            row: dict[str, Any] = {"index": i, "bins": dict(sit.bins), "seed": seed}
            row["pem"] = pem.run(sit, stack, seed).failed
            if other is not None:
                row["pem_other"] = other.run(sit, stack, seed).failed
            c0, w0 = time.process_time(), time.perf_counter()
            out = cam.run(sit, cam_stack, seed)
            cpu += time.process_time() - c0
            wall += time.perf_counter() - w0
            row["camera"] = out.failed
            row["camera_status"] = out.status
            row["camera_sim_time"] = out.sim_time
            rows.append(row)
            log.write(json.dumps(row) + "\n")
            log.flush()
            print(f"{i + 1}/{args.runs} agree so far "
                  f"{sum(r['pem'] == r['camera'] for r in rows) / len(rows):.2f}",
                  file=sys.stderr)  # fmt: skip
    result: dict[str, Any] = {
        "runs": len(rows),
        "seed": args.seed,
        "shipped_pem": _compare(rows, "pem"),
        "camera_cpu_s_per_run": round(cpu / len(rows), 3),
        "camera_wall_s_per_run": round(wall / len(rows), 3),
        "camera_frames_rendered_per_run": round(frames["n"] / len(rows), 1),
    }
    if other is not None:
        result["other_pem"] = {"file": str(args.pem_params), **_compare(rows, "pem_other")}
    text = json.dumps(result, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return result


if __name__ == "__main__":
    main()
