"""How much of the PEM's disagreement with the camera is its noise, how much its bias.

``sitcov experiment agreement`` compares one PEM run per situation with one camera run.
The camera is (almost) a fixed function of the world: with the world shared it flips 4-9
verdicts in 100 (docs/pem.md, "Where the ceiling comes from"). The PEM is not: its noise
is drawn per run. This script runs every situation's world (run seed of stream A) with
``--draws`` perception seeds of the PEM and estimates, per situation, the PEM's failure
probability ``p``; against the camera's verdict ``c`` at stream A (stored rows, no camera
run here) it prints, per stack:

- ``expected``: the mean of ``1 - |c - p|``, the agreement one PEM run per situation
  gives on average (what ``pem-camera-shared-seed`` measures once);
- ``majority``: the agreement of the PEM's majority verdict (``p > 0.5``) with the camera,
  with its Wilson interval: what a PEM with the same per-situation tendencies but no
  verdict noise would reach;
- ``noise`` = majority − expected: the points the PEM's own randomness costs;
  ``bias`` = 1 − majority: the points no noise level recovers (the PEM leans the wrong
  way in those situations);
- the failure rates of both modes (a gap between them is bias that shows on average).

Usage (a stack set as in docs/pem.md; ~25 CPU-s for 4 stacks × 100 situations × 20
draws)::

    PYTHONPATH=. python benchmarks/pem_agreement_bound.py \\
        --camera-rows docs/data/agreement-stacks-seed8-100-camera.csv --draws 20 \\
        --stack reference,examples.aeb_stacks:Threshold07,\\
examples.aeb_stacks:ThreeFrames,examples.aeb_stacks:RightBlind

``--pem-file`` evaluates another car PEM (e.g. a refit's output) on the same footing.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from sitcov._seeding import ask_rng
from sitcov.analysis import wilson_interval
from sitcov.campaign._agreement import SideRunner, SideSettings, read_rows, stream_seed

#: Seed-sequence stream of the perception draws (the agreement experiment uses 0-2).
_DRAW_STREAM = 99


def camera_verdicts(paths: list[Path], seed: int) -> dict[tuple[str, int], bool]:
    """(stack, index) -> the camera's verdict at stream A, first file first."""
    verdicts: dict[tuple[str, int], bool] = {}
    for path in paths:
        for row in read_rows(path):
            if row["perception"] != "camera" or row["stream"] != "A" or row["seed"] != seed:
                continue
            if row["status"] in ("error", "timeout"):
                continue
            verdicts.setdefault((row["stack"], row["index"]), bool(row["failed"]))
    return verdicts


def failure_probabilities(
    runner: SideRunner, stack: str, seed: int, indices: list[int], draws: int
) -> np.ndarray:
    """Per situation, the share of ``draws`` PEM runs (world of stream A, perception seeds
    from their own seed sequence) that fail."""
    backend, av = runner._side("pem", stack)
    p = np.zeros(len(indices))
    for k, index in enumerate(indices):
        situation = runner.generator.ask(ask_rng(seed, index))
        world = stream_seed("A", seed, index)
        seeds = np.random.SeedSequence([_DRAW_STREAM, seed, index]).generate_state(
            draws, dtype=np.uint32
        )
        fails = [backend.run(situation, av, world, perception_seed=int(s)).failed for s in seeds]
        p[k] = float(np.mean(fails))
    return p


def decompose(p: np.ndarray, c: np.ndarray) -> dict[str, Any]:
    """The figures of the module docstring from per-situation ``p`` and camera ``c``."""
    n = len(p)
    majority_agree = int(np.sum((p > 0.5) == c.astype(bool)))
    expected = float(np.mean(1.0 - np.abs(c - p)))
    majority = majority_agree / n
    ci = wilson_interval(majority_agree, n)
    return {
        "n": n,
        "camera_failure_rate": round(float(c.mean()), 4),
        "pem_failure_rate": round(float(p.mean()), 4),
        "expected": round(expected, 4),
        "majority": round(majority, 4),
        "majority_ci95": None if ci is None else [round(ci[0], 4), round(ci[1], 4)],
        "noise": round(majority - expected, 4),
        "bias": round(1.0 - majority, 4),
        "pem_pem_shared_world": round(float(np.mean(1.0 - 2.0 * p * (1.0 - p))), 4),
        "uncertain_situations": int(np.sum((p > 0.1) & (p < 0.9))),
        "pem_fails_camera_passes": int(np.sum((p > 0.5) & (c == 0))),
        "camera_fails_pem_passes": int(np.sum((p <= 0.5) & (c == 1))),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--camera-rows", type=Path, action="append", required=True)
    parser.add_argument("--stack", default="reference", help="comma-separated stacks")
    parser.add_argument("--seed", type=int, default=8, help="evaluation seed of the rows")
    parser.add_argument("--situations", type=int, default=100)
    parser.add_argument("--draws", type=int, default=20, help="PEM runs per situation")
    parser.add_argument("--pem-file", default=None, help="car PEM file (default: shipped)")
    parser.add_argument("--json", type=Path, default=None, help="write figures and p here")
    args = parser.parse_args(argv)
    for path in args.camera_rows:
        if not path.exists():
            print(f"pem_agreement_bound: {path}: no such rows file", file=sys.stderr)
            return 2
    verdicts = camera_verdicts(args.camera_rows, args.seed)
    runner = SideRunner(SideSettings(pem_file=args.pem_file))
    result: dict[str, Any] = {"seed": args.seed, "draws": args.draws, "stacks": {}}
    for stack in [s.strip() for s in args.stack.split(",") if s.strip()]:
        indices = [i for i in range(args.situations) if (stack, i) in verdicts]
        if not indices:
            print(f"pem_agreement_bound: no camera rows of stack {stack!r}", file=sys.stderr)
            return 2
        p = failure_probabilities(runner, stack, args.seed, indices, args.draws)
        c = np.array([verdicts[stack, i] for i in indices], dtype=float)
        row = decompose(p, c)
        result["stacks"][stack] = {**row, "p": [round(float(x), 4) for x in p]}
        print(
            f"{stack}: camera {row['camera_failure_rate']:.1%} PEM {row['pem_failure_rate']:.1%}"
            f" failures; expected {row['expected']:.1%}, majority {row['majority']:.1%}"
            f" {row['majority_ci95']}; noise {row['noise']:+.1%}, bias {row['bias']:.1%}"
            f" (PEM fails/camera passes {row['pem_fails_camera_passes']},"
            f" camera fails/PEM passes {row['camera_fails_pem_passes']});"
            f" {row['uncertain_situations']} situations with 0.1 < p < 0.9"
        )
    if args.json:
        args.json.write_text(json.dumps(result, indent=1) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
