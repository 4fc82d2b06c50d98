"""Camera mode's frame skipping changes no verdict: stored camera rows re-simulated.

Usage (from the repository root, so ``examples`` imports)::

    PYTHONPATH=. python benchmarks/bench_camera_gate_verdicts.py \\
        [--rows docs/data/agreement-stacks-seed8-100-camera.csv] [--situations 25] \\
        [--skip 0] [--stream A] [--stacks NAME,...] [--out rows.json] [--compare other.json]

Takes the rows file of ``sitcov experiment agreement`` (camera rows: the four example
stacks x 100 situations of seed 8 x run-seed streams A and B, world model 4), and
re-simulates ``--situations`` situations of each stack on one stream (the first ones
after skipping ``--skip``), as the
experiment built them (``sitcov.campaign._agreement``: the random generator's
``ask_rng(seed, index)`` situation, the stream's run seed, the stack by its name, the SSD
detector). For each run it prints whether the verdict (``failed``), the status and the AEB
time equal the stored row's, and counts the frames rendered and the detector's network
runs, with the run's CPU time (``time.process_time``) next to the stored one.

``--out`` writes every run's outcome (verdict, AEB time, end reason, end time, minimum
distance, frames, CPU-s) as JSON; ``--compare FILE`` checks each against a file written
by another checkout (e.g. run once with ``PYTHONPATH=/path/to/main``, once with this
branch): end reasons, end times and minimum distances equal, not just verdicts. The
exit status is 1 if any verdict differs.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections import Counter
from pathlib import Path
from typing import Any

ROWS = Path("docs/data/agreement-stacks-seed8-100-camera.csv")


def select(
    rows: list[dict[str, Any]],
    situations: int,
    stream: str,
    stacks: list[str] | None,
    skip: int = 0,
) -> list[dict[str, Any]]:
    """The stored camera rows to re-simulate: per stack, ``situations`` situations on a
    stream, the first ones after skipping ``skip``."""
    out = []
    seen: Counter[str] = Counter()
    for row in sorted(rows, key=lambda r: (r["stack"], r["seed"], r["index"])):
        if row["perception"] != "camera" or row["stream"] != stream:
            continue
        if stacks and row["stack"] not in stacks:
            continue
        seen[row["stack"], "all"] += 1
        if seen[row["stack"], "all"] <= skip:
            continue
        if seen[row["stack"]] < situations:
            seen[row["stack"]] += 1
            out.append(row)
    return out


def simulate(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Re-run each row's (situation, run seed, stack) in camera mode; one result per row."""
    from sitcov._seeding import ask_rng
    from sitcov.campaign._agreement import Job, SideRunner, SideSettings, stream_seed
    from sitcov.perception import SSDDetector

    runner = SideRunner(SideSettings())
    counts = {"frames": 0, "network": 0}
    raw = SSDDetector.raw

    def counted_raw(self: Any, image: Any) -> Any:
        counts["network"] += 1
        return raw(self, image)

    SSDDetector.raw = counted_raw  # type: ignore[method-assign]
    results = []
    for row in rows:
        job = Job(row["seed"], row["index"], "camera", row["stream"], row["stack"])
        backend, stack = runner._side("camera", job.stack)
        if not getattr(backend, "_counted", False):
            frame = backend._frame

            def counted_frame(*args: Any, _frame: Any = frame) -> Any:
                counts["frames"] += 1
                return _frame(*args)

            backend._frame = counted_frame
            backend._counted = True
        situation = runner.generator.ask(ask_rng(job.seed, job.index))
        seed = stream_seed(job.stream, job.seed, job.index)
        assert seed == row["run_seed"], (row, seed)
        counts.update(frames=0, network=0)
        cpu = time.process_time()
        out = backend.run(situation, stack, seed)
        cpu = time.process_time() - cpu
        results.append(
            {
                "stack": job.stack,
                "index": job.index,
                "stream": job.stream,
                "situation_id": situation.id,
                "failed": bool(out.failed),
                "status": out.status,
                "aeb_time": None if out.aeb_time is None else round(out.aeb_time, 4),
                "end_reason": out.end_reason,
                "sim_time": out.sim_time,
                "min_distance": out.min_distance,
                "frames": counts["frames"],
                "network": counts["network"],
                "cpu_s": round(cpu, 4),
            }
        )
    return results


def main() -> int:
    """Re-simulate, compare with the stored rows (and another checkout's results)."""
    from sitcov.campaign._agreement import read_rows

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rows", type=Path, default=ROWS)
    parser.add_argument("--situations", type=int, default=25)
    parser.add_argument("--skip", type=int, default=0)
    parser.add_argument("--stream", default="A", choices=("A", "B"))
    parser.add_argument("--stacks", default=None, help="comma-separated stack names")
    parser.add_argument("--out", type=Path, default=None)
    parser.add_argument("--compare", type=Path, default=None)
    args = parser.parse_args()
    stacks = args.stacks.split(",") if args.stacks else None
    rows = select(read_rows(args.rows), args.situations, args.stream, stacks, args.skip)
    results = simulate(rows)
    other = json.loads(args.compare.read_text()) if args.compare else None
    bad = 0
    per_stack: dict[str, Counter[str]] = {}
    for i, (row, res) in enumerate(zip(rows, results, strict=True)):
        same = (
            res["failed"] == row["failed"]
            and res["status"] == row["status"]
            and res["aeb_time"] == row["aeb_time"]
        )
        c = per_stack.setdefault(res["stack"], Counter())
        c["runs"] += 1
        c["same"] += same
        c["frames"] += res["frames"]
        c["network"] += res["network"]
        c["cpu_new"] += res["cpu_s"]
        c["cpu_stored"] += row["cpu_s"] or 0.0
        note = ""
        if other is not None:
            o = other[i]
            keys = ("failed", "status", "aeb_time", "end_reason", "sim_time", "min_distance")
            diff = [k for k in keys if o[k] != res[k]]
            c["same_outcome"] += not diff
            c["frames_other"] += o["frames"]
            c["network_other"] += o["network"]
            c["cpu_other"] += o["cpu_s"]
            note = f" outcome differs in {diff}" if diff else " outcome identical"
        bad += not same
        print(
            f"{res['stack']} #{res['index']}{res['stream']}: failed {res['failed']} "
            f"(stored {row['failed']}), aeb {res['aeb_time']} (stored {row['aeb_time']}), "
            f"{res['end_reason']}, frames {res['frames']}, network {res['network']}, "
            f"{res['cpu_s']:.2f} CPU-s{' SAME' if same else ' DIFFERENT'}{note}",
            flush=True,
        )
    print()
    for name, c in per_stack.items():
        line = (
            f"{name}: {c['same']}/{c['runs']} verdicts and AEB times as stored; frames "
            f"{c['frames'] / c['runs']:.1f}/run, network runs {c['network'] / c['runs']:.1f}"
            f"/run, {c['cpu_new'] / c['runs']:.2f} CPU-s/run (stored rows "
            f"{c['cpu_stored'] / c['runs']:.2f})"
        )
        if other is not None:
            line += (
                f"; vs --compare: {c['same_outcome']}/{c['runs']} outcomes identical, frames "
                f"{c['frames_other'] / c['runs']:.1f}/run, network "
                f"{c['network_other'] / c['runs']:.1f}/run, "
                f"{c['cpu_other'] / c['runs']:.2f} CPU-s/run"
            )
        print(line)
    if args.out:
        args.out.write_text(json.dumps(results, indent=1))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
