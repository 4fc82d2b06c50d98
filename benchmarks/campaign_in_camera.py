"""A stored PEM campaign re-run in camera mode, run by run: does its finding hold?

Each stored run's situation is simulated again with its stored run seed on the embedded
backend in camera mode (rendered frames, the SSD detector) with the same stack, physics
profile and judge; the PEM verdict is the stored one. The same worlds, only the
perception differs (the run seed draws the same wind and road-user colours). Printed: the
failure rate in each mode overall, by the side the road user comes from (left, right,
ahead) and by ``intsit`` bin, each with its Wilson 95 % interval; the left/right one-sided
Fisher p in each mode; and the paired discordance (runs failing in one mode only).

    python benchmarks/campaign_in_camera.py --db sitcov.db --campaign default --workers 2 \\
        --out docs/data/default-campaign-camera.csv

Rows are written as runs finish (``index, intsit, side, pem_failed, camera_failed,
camera_status, cpu_s``); an interrupted re-run resumes from the rows already in ``--out``.
``--stack NAME`` runs the campaign's situations and run seeds with another stack (e.g.
``examples.aeb_stacks:Threshold07``, with the checkout on ``PYTHONPATH``) in both modes.
Needs the camera extra (the detector model: ``sitcov models fetch``).
"""

from __future__ import annotations

import argparse
import csv
import time
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path
from typing import Any

FIELDS = ("index", "intsit", "side", "pem_failed", "camera_failed", "camera_status", "cpu_s")
_WORKER: dict[str, Any] = {}


def _verdicts(job: tuple[int, dict[str, Any], int, str, str, str, bool]) -> dict[str, Any]:
    """One stored run again in camera mode (its situation as ``Situation.to_dict``), and
    on the PEM too when ``with_pem`` (another stack than the campaign's): its row (index,
    verdicts, CPU seconds of the camera run)."""
    from sitcov.av import make_stack
    from sitcov.hyperspace import Situation
    from sitcov.sim._judge import Judge
    from sitcov.sim.embedded._backend import EmbeddedBackend

    index, situation, seed, av, physics, judge, with_pem = job
    key = (av, physics, judge)
    if _WORKER.get("key") != key:  # one backend per mode and one stack per worker and setup
        _WORKER.update(key=key, stack=make_stack(av), judge=Judge.from_spec(judge),
                       camera=EmbeddedBackend(perception="camera", physics=physics),
                       pem=EmbeddedBackend(perception="pem", physics=physics))  # fmt: skip
    sit = Situation.from_dict(situation)
    cpu0 = time.process_time()
    outcome = _WORKER["judge"](_WORKER["camera"].run(sit, _WORKER["stack"], seed))
    cpu = round(time.process_time() - cpu0, 3)
    row = {"index": index, "camera_failed": int(outcome.status == "fail"),
           "camera_status": outcome.status, "cpu_s": cpu}  # fmt: skip
    if with_pem:
        pem = _WORKER["judge"](_WORKER["pem"].run(sit, _WORKER["stack"], seed))
        row["pem_failed"] = int(pem.status == "fail")
    return row


def _stored(db: Path, campaign: str) -> list[Any]:
    """The campaign's judged runs in index order."""
    from sitcov.campaign import open_store

    store = open_store(db)
    try:
        return [r for r in store.runs() if r.campaign == campaign and r.status in ("pass", "fail")]
    finally:
        store.close()


def _setup(run: Any) -> tuple[str, str, str]:
    """(stack, physics profile, judge) the campaign ran with (its stored config)."""
    cfg = run.config
    if cfg.get("fault"):
        raise SystemExit("a campaign with a seeded fault: re-run it by hand")
    return (
        str(cfg.get("av") or "reference"),
        str(cfg.get("physics") or "carla"),
        str(cfg.get("judge") or "default"),
    )


def _read(out: Path) -> dict[int, dict[str, Any]]:
    if not out.exists():
        return {}
    with out.open(newline="") as f:
        return {int(r["index"]): r for r in csv.DictReader(f)}


def rerun(
    db: Path, campaign: str, out: Path, workers: int, stack: str | None = None
) -> list[dict[str, Any]]:
    """Every judged run of ``campaign`` in camera mode (resuming ``out``): the rows. With
    ``stack`` (another than the campaign's) its situations and run seeds are run with that
    stack in both modes."""
    from sitcov.hyperspace._situation import approach_side

    runs = _stored(db, campaign)
    if not runs:
        raise SystemExit(f"{db}: no judged runs of campaign {campaign!r}")
    av, physics, judge = _setup(runs[0])
    with_pem = stack is not None and stack != av
    av = stack or av
    done = _read(out)
    base = {
        r.index: {"index": r.index, "intsit": r.situation.bins.get("intsit", "-"),
                  "side": approach_side(r.situation.bins, r.situation.values),
                  "pem_failed": -1 if with_pem else int(r.status == "fail")}
        for r in runs
    }  # fmt: skip
    jobs = [
        (r.index, r.situation.to_dict(), r.seed, av, physics, judge, with_pem)
        for r in runs
        if r.index not in done
    ]
    new = not out.exists()
    with out.open("a", newline="") as f, ProcessPoolExecutor(workers) as pool:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        if new:
            writer.writeheader()
        futures = [pool.submit(_verdicts, job) for job in jobs]
        for k, fut in enumerate(as_completed(futures), 1):
            row = {**base[fut.result()["index"]], **fut.result()}
            writer.writerow(row)
            f.flush()
            done[row["index"]] = row
            if k % 50 == 0:
                print(f"  {k}/{len(jobs)} camera runs", flush=True)
    return [done[i] for i in sorted(done)]


def report(rows: Sequence[dict[str, Any]]) -> list[str]:
    """Failure rates per mode (overall, per side, per intsit bin), side tests, discordance."""
    from scipy.stats import fisher_exact

    from sitcov.analysis._stats import wilson_interval

    def rate(sel: Sequence[dict[str, Any]], mode: str) -> str:
        k, n = sum(int(r[f"{mode}_failed"]) for r in sel), len(sel)
        lo, hi = wilson_interval(k, n) or (0.0, 0.0)
        return f"{100 * k / max(n, 1):5.1f}% [{100 * lo:4.1f}, {100 * hi:4.1f}]"

    lines = [f"{'group':<14} {'n':>5}  {'PEM':<22} {'camera':<22}"]
    groups = [("all", list(rows))]
    for side in ("left", "right", "ahead"):
        name = f"from {side}" if side != "ahead" else side
        groups.append((name, [r for r in rows if r["side"] == side]))
    bins = sorted({r["intsit"] for r in rows}, key=lambda b: int(b.rpartition("-")[2] or 0))
    groups += [(b, [r for r in rows if r["intsit"] == b]) for b in bins]
    for name, sel in groups:
        if sel:
            lines.append(
                f"{name:<14} {len(sel):>5}  {rate(sel, 'pem'):<22} {rate(sel, 'camera'):<22}"
            )
    for mode in ("pem", "camera"):
        left = [int(r[f"{mode}_failed"]) for r in rows if r["side"] == "left"]
        right = [int(r[f"{mode}_failed"]) for r in rows if r["side"] == "right"]
        table = [[sum(left), len(left) - sum(left)], [sum(right), len(right) - sum(right)]]
        p = fisher_exact(table, alternative="greater")[1]
        lines.append(
            f"{mode}: from the left fails more than from the right, one-sided Fisher p {p:.2g}"
        )
    only_pem = sum(int(r["pem_failed"]) and not int(r["camera_failed"]) for r in rows)
    only_cam = sum(int(r["camera_failed"]) and not int(r["pem_failed"]) for r in rows)
    agree = len(rows) - only_pem - only_cam
    lines.append(f"verdicts agree on {agree}/{len(rows)} runs; PEM only fails {only_pem}, "
                 f"camera only {only_cam}")  # fmt: skip
    return lines


def main() -> None:
    """Parse the arguments, re-run, print the comparison."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", type=Path, required=True, help="campaign database")
    parser.add_argument("--campaign", default="default", help="campaign name")
    parser.add_argument("--out", type=Path, required=True, help="rows file (.csv)")
    parser.add_argument("--workers", type=int, default=1, help="processes")
    parser.add_argument(
        "--stack", default=None, help="another stack (as sitcov run --av names it), in both modes"
    )
    args = parser.parse_args()
    start = time.perf_counter()
    rows = rerun(args.db, args.campaign, args.out, args.workers, args.stack)
    for line in report(rows):
        print(line)
    cpu = sum(float(r["cpu_s"]) for r in rows)
    print(f"{len(rows)} camera runs, {cpu:.0f} CPU-s in the runs; this call "
          f"{time.perf_counter() - start:.0f} s wall on {args.workers} worker(s)")  # fmt: skip


if __name__ == "__main__":
    main()
