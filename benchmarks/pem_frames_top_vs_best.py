"""Two recordings of the same frames, or the two scores of one: top score vs best overlap.

A frames file written since the recorded score became the top score among the boxes
overlapping a road user's (``sitcov/calibration/_camera_runs.py``, ``match()``) also holds
the best-overlapping box's score per frame (``score_best_iou``). Given such a file, this
prints per kind the frames at or above 0.5 and 0.7 by each score and the mean run of
consecutive frames >= 0.5. Given an older file too (``--old``, recorded with the same
command and seed), it checks that the new recording is the old one again: the same runs,
frames, features and verdicts, and ``score_best_iou`` equal to the old file's score in
every frame (exit 1 if not).

Usage (seconds)::

    PYTHONPATH=. python benchmarks/pem_frames_top_vs_best.py \\
        docs/data/pem-frames-top-seed2.jsonl.gz --old docs/data/pem-frames-seed2.jsonl.gz
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence

from sitcov.calibration._camera_runs import NOT_STORED, CameraRun
from sitcov.calibration._frames import read_frames


def mean_run(runs: Sequence[CameraRun], theta: float, best: bool) -> float:
    """Mean length of the runs of consecutive frames (one actor) scoring >= ``theta``."""
    lengths: list[int] = []
    for run in runs:
        by_actor: dict[int, list[tuple[int, float]]] = {}
        for f in run.frames:
            by_actor.setdefault(f.actor, []).append(
                (f.frame, f.score_best_iou if best else f.score)
            )
        for seq in by_actor.values():
            n, last = 0, None
            for frame, score in sorted(seq):
                if score >= theta and (n == 0 or last is None or frame == last + 1 or frame < 0):
                    n += 1
                else:
                    if n:
                        lengths.append(n)
                    n = 1 if score >= theta else 0
                last = frame
            if n:
                lengths.append(n)
    return sum(lengths) / len(lengths) if lengths else 0.0


def same_as_old(old: Sequence[CameraRun], new: Sequence[CameraRun]) -> list[str]:
    """What differs between two recordings of the same runs, besides the scores."""
    problems = []
    o = {r.index: r for r in old}
    for run in new:
        was = o.get(run.index)
        if was is None or len(was.frames) != len(run.frames) or was.failed != run.failed:
            problems.append(f"run {run.index}: other frames or verdict")
            continue
        for a, b in zip(was.frames, run.frames, strict=True):
            if (a.features, a.frame, a.actor, a.distance, a.width_px) != (
                b.features, b.frame, b.actor, b.distance, b.width_px,
            ):  # fmt: skip
                problems.append(f"run {run.index} frame {b.frame}: other features")
            elif a.score != b.score_best_iou:
                problems.append(f"run {run.index} frame {b.frame}: best-overlap score differs")
    if len(o) != len(new):
        problems.append(f"{len(o)} runs before, {len(new)} now")
    return problems


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("frames", help="a frames file with score_best_iou")
    parser.add_argument("--old", default=None, help="the same recording made before")
    args = parser.parse_args(argv)
    new = read_frames(args.frames)
    old = read_frames(args.old) if args.old else {}
    bad = 0
    for kind, data in new.items():
        frames = [f for r in data.runs for f in r.frames]
        if any(f.score_best_iou == NOT_STORED for f in frames):
            print(f"{kind}: {args.frames} has no score_best_iou (recorded before it existed)")
            bad += 1
            continue
        cells = []
        for theta in (0.5, 0.7):
            top = sum(f.score >= theta for f in frames)
            best = sum(f.score_best_iou >= theta for f in frames)
            cells.append(f">= {theta}: top {top} / best-overlap {best}")
        runs = f"mean run >= 0.5: top {mean_run(data.runs, 0.5, False):.2f} / best-overlap "
        runs += f"{mean_run(data.runs, 0.5, True):.2f} frames"
        print(
            f"{kind}: {len(data.runs)} runs, {len(frames)} frames; "
            + "; ".join(cells)
            + f"; {runs}"
        )
        if kind in old:
            problems = same_as_old(old[kind].runs, data.runs)
            print(f"  vs {args.old}: " + ("same runs, frames, features, verdicts and "
                  "best-overlap scores" if not problems else f"{len(problems)} differences, "
                  f"first: {problems[0]}"))  # fmt: skip
            bad += bool(problems)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
