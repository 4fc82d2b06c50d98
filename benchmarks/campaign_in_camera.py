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

``--pem-draws K`` re-runs the PEM side with the majority of K perception draws (``sitcov
run --perception-draws``) and ``--camera-rows FILE`` takes the camera verdicts from an
earlier rows file of the same campaign and stack, so only the PEM side runs:

    python benchmarks/campaign_in_camera.py --db sitcov.db --pem-draws 7 \\
        --camera-rows docs/data/default-campaign-camera.csv --out draws7.csv

Rows are written as runs finish (``index, intsit, side, pem_failed, camera_failed,
camera_status, cpu_s``); an interrupted re-run resumes from the rows already in ``--out``.
``--stack NAME`` runs the campaign's situations and run seeds with another stack (e.g.
``examples.aeb_stacks:Threshold07``, with the checkout on ``PYTHONPATH``) in both modes.
``--second-seed`` runs every situation in both modes at the agreement experiment's second
run seed (stream B, ``second_run_seed(campaign seed, index)``) instead of the stored one:
the camera's own reproducibility across run seeds on the campaign's situations. With
``--against ROWS`` (the same stack's rows at the stored seeds) it prints the agreement of
camera@A with camera@B (the ceiling), with PEM@B (across run seeds) and PEM@A with PEM@B.
``--pem FILE`` runs the PEM side with that car PEM file instead of the shipped one (a
candidate's verdicts on the same worlds; with ``--camera-rows`` only the PEM side runs).
``--by precipitation>=50,wind_intensity>=50`` adds the rates and the agreement in each
group of runs by the situations' bins (an element's bin, or below / from a value on).
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


def _verdicts(job: dict[str, Any]) -> dict[str, Any]:
    """One stored run again (``job``: its index, situation as ``Situation.to_dict``, run
    seed and setup): in camera mode unless ``camera`` is False, and on the PEM when
    ``with_pem`` (another stack than the campaign's, another seed or perception draws):
    its row (index, verdicts, CPU seconds of the camera run)."""
    from sitcov.av import make_stack
    from sitcov.campaign._draws import PerceptionDraws
    from sitcov.hyperspace import Situation
    from sitcov.perception import PEMSensor
    from sitcov.sim._judge import Judge
    from sitcov.sim.embedded._backend import EmbeddedBackend

    key = (job["av"], job["physics"], job["judge"], job["draws"], job["pem"])
    if _WORKER.get("key") != key:  # one backend per mode and one stack per worker and setup
        judge = Judge.from_spec(job["judge"])
        sensor = PEMSensor(job["pem"]) if job["pem"] is not None else None
        pem = EmbeddedBackend(perception="pem", physics=job["physics"], sensor=sensor)
        if job["draws"] > 1:
            pem = PerceptionDraws(pem, job["draws"], lambda o: judge(o).failed)
        camera = EmbeddedBackend(perception="camera", physics=job["physics"])
        _WORKER.update(key=key, stack=make_stack(job["av"]), judge=judge, pem=pem, camera=camera)
    sit, seed = Situation.from_dict(job["situation"]), job["seed"]
    row: dict[str, Any] = {"index": job["index"]}
    if job["camera"]:
        cpu0 = time.process_time()
        outcome = _WORKER["judge"](_WORKER["camera"].run(sit, _WORKER["stack"], seed))
        row.update(camera_failed=int(outcome.status == "fail"), camera_status=outcome.status,
                   cpu_s=round(time.process_time() - cpu0, 3))  # fmt: skip
    if job["with_pem"]:
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
    db: Path,
    campaign: str,
    out: Path,
    workers: int,
    stack: str | None = None,
    second_seed: bool = False,
    pem_draws: int = 1,
    camera_rows: Path | None = None,
    pem_file: Path | None = None,
) -> list[dict[str, Any]]:
    """Every judged run of ``campaign`` in camera mode (resuming ``out``): the rows. With
    ``stack`` (another than the campaign's) its situations and run seeds are run with that
    stack in both modes; with ``second_seed`` both modes run at stream B's run seeds; with
    ``pem_draws`` > 1 the PEM verdict is the majority of that many perception draws
    (``sitcov run --perception-draws``); ``camera_rows``: the camera verdicts of these
    runs from an earlier rows file of the same campaign, stack and seeds (not run again);
    ``pem_file``: the PEM side's car PEM file (default: the shipped one)."""
    from sitcov.campaign._agreement import second_run_seed
    from sitcov.hyperspace._situation import approach_side

    runs = _stored(db, campaign)
    if not runs:
        raise SystemExit(f"{db}: no judged runs of campaign {campaign!r}")
    av, physics, judge = _setup(runs[0])
    with_pem = second_seed or pem_draws > 1 or pem_file is not None
    with_pem = with_pem or (stack is not None and stack != av)
    av = stack or av
    base_seed = int(runs[0].config.get("seed") or 0)

    def seed_of(run: Any) -> int:
        return second_run_seed(base_seed, run.index) if second_seed else int(run.seed)

    done = _read(out)
    known = _read(camera_rows) if camera_rows is not None else {}
    base = {
        r.index: {"index": r.index, "intsit": r.situation.bins.get("intsit", "-"),
                  "side": approach_side(r.situation.bins, r.situation.values),
                  "pem_failed": -1 if with_pem else int(r.status == "fail"),
                  **{k: v for k, v in known.get(r.index, {}).items()
                     if k in ("camera_failed", "camera_status", "cpu_s")}}
        for r in runs
    }  # fmt: skip
    jobs = [
        {"index": r.index, "situation": r.situation.to_dict(), "seed": seed_of(r), "av": av,
         "physics": physics, "judge": judge, "with_pem": with_pem, "draws": pem_draws,
         "camera": r.index not in known, "pem": None if pem_file is None else str(pem_file)}
        for r in runs
        if r.index not in done
    ]  # fmt: skip
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
                print(f"  {k}/{len(jobs)} runs", flush=True)
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


def group_of(bins: dict[str, str], spec: str) -> str:
    """A run's group by ``spec``: ``ELEMENT`` (its bin) or ``ELEMENT>=VALUE`` (two groups,
    below and from VALUE on, for a numeric element), ``,``-separated for crossed groups."""
    parts = []
    for item in spec.split(","):
        name, _, cut = item.partition(">=")
        label = bins.get(name.strip(), "-")
        if cut:
            below = float(label) < float(cut)
            label = f"{name.strip()}<{cut}" if below else f"{name.strip()}>={cut}"
        else:
            label = f"{name.strip()}={label}"
        parts.append(label)
    return " ".join(parts)


def report_by(
    rows: Sequence[dict[str, Any]], bins: dict[int, dict[str, str]], spec: str
) -> list[str]:
    """Failure rates per mode and the agreement in each group of runs (:func:`group_of`)."""
    groups: dict[str, list[dict[str, Any]]] = {}
    for r in rows:
        groups.setdefault(group_of(bins[int(r["index"])], spec), []).append(r)
    lines = [f"{'group':<44} {'n':>5}  {'PEM':>6} {'camera':>7} {'agree':>7}"]
    for name in sorted(groups):
        sel = groups[name]
        n = len(sel)
        pem = sum(int(r["pem_failed"]) for r in sel) / n
        cam = sum(int(r["camera_failed"]) for r in sel) / n
        agree = sum(int(r["pem_failed"]) == int(r["camera_failed"]) for r in sel) / n
        lines.append(f"{name:<44} {n:>5}  {100 * pem:5.1f}% {100 * cam:6.1f}% {100 * agree:6.1f}%")
    return lines


def across_seeds(at_a: Sequence[dict[str, Any]], at_b: Sequence[dict[str, Any]]) -> list[str]:
    """Agreement of the verdicts at the stored run seeds (``at_a``) with those at stream
    B's (``at_b``), over the situations both hold: camera@A vs camera@B (the camera's own
    reproducibility, the ceiling of any model drawn independently of it), camera@A vs
    PEM@B (the agreement experiment's ``pem-camera``), PEM@A vs PEM@B, each with its
    Wilson 95 % interval."""
    from sitcov.analysis._stats import wilson_interval

    b = {int(r["index"]): r for r in at_b}
    pairs = [(r, b[int(r["index"])]) for r in at_a if int(r["index"]) in b]
    lines = []
    for name, left, right in (
        ("camera@A vs camera@B", "camera", "camera"),
        ("camera@A vs PEM@B", "camera", "pem"),
        ("PEM@A vs PEM@B", "pem", "pem"),
    ):
        n = len(pairs)
        k = sum(int(x[f"{left}_failed"]) == int(y[f"{right}_failed"]) for x, y in pairs)
        lo, hi = wilson_interval(k, n) or (0.0, 0.0)
        lines.append(
            f"{name:<22} {k}/{n} = {100 * k / max(n, 1):5.1f}% [{100 * lo:4.1f}, {100 * hi:4.1f}]"
        )
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
    parser.add_argument(
        "--second-seed", action="store_true", help="run both modes at stream B's run seeds"
    )
    parser.add_argument(
        "--against", type=Path, default=None, help="rows at the stored seeds, for --second-seed"
    )
    parser.add_argument(
        "--pem-draws", type=int, default=1, help="PEM verdict: the majority of this many draws"
    )
    parser.add_argument(
        "--camera-rows", type=Path, default=None, help="camera verdicts of an earlier rows file"
    )
    parser.add_argument("--pem", type=Path, default=None, help="the PEM side's car PEM file")
    parser.add_argument(
        "--by", default=None, help="also by ELEMENT or ELEMENT>=VALUE, comma-separated (crossed)"
    )
    args = parser.parse_args()
    start = time.perf_counter()
    rows = rerun(args.db, args.campaign, args.out, args.workers, args.stack, args.second_seed,
                 args.pem_draws, args.camera_rows, args.pem)  # fmt: skip
    for line in report(rows):
        print(line)
    if args.against is not None:
        for line in across_seeds(list(_read(args.against).values()), rows):
            print(line)
    if args.by:
        bins = {r.index: dict(r.situation.bins) for r in _stored(args.db, args.campaign)}
        for line in report_by(rows, bins, args.by):
            print(line)
    cpu = sum(float(r["cpu_s"]) for r in rows)
    print(f"{len(rows)} rows, {cpu:.0f} CPU-s in their camera runs; this call "
          f"{time.perf_counter() - start:.0f} s wall on {args.workers} worker(s)")  # fmt: skip


if __name__ == "__main__":
    main()
