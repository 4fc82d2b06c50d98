"""Scale benchmark: a long embedded campaign, its memory, its database, and the analysis commands.

Usage::

    nice -n 10 python benchmarks/bench_scale.py --db scale.db          # 100,000 runs, --workers 2
    python benchmarks/bench_scale.py --runs 10000 --db s10k.db         # a smaller look
    python benchmarks/bench_scale.py --db scale.db --analysis-only     # time summary/report/export

Measures:

1. the campaign (embedded backend, PEM, reference stack, sitcov generator, ``processes``):
   wall time, CPU time (this process and its workers), and the resident memory (RSS) of the
   parent and of each worker process, sampled every ``--sample-every`` finished runs (so at
   10k, 50k and 100k among others); the parent's and the workers' growth from the first
   sample to the last, in MiB and percent;
2. the database: bytes on disk (main file + WAL) and bytes per run;
3. ``sitcov summary --json``, ``sitcov report`` and ``sitcov export`` (csv, json, junit) run
   as the user runs them (a fresh ``python -m sitcov.cli`` process each): wall time, CPU time
   and peak RSS of that process (``wait4``), so "streaming" shows as a peak RSS that does
   not grow with the number of runs.

Prints one JSON object (also written to ``--out`` if given). The machine's load average is
recorded at start and end: on a shared machine wall times are distorted, CPU times less so.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
_PAGE = os.sysconf("SC_PAGE_SIZE")


def rss_mib(pid: int | str = "self") -> float | None:
    """Resident set size of process ``pid`` [MiB] (Linux /proc), None if it is gone."""
    try:
        with open(f"/proc/{pid}/statm") as fh:
            return int(fh.read().split()[1]) * _PAGE / 2**20
    except (OSError, IndexError, ValueError):
        return None


def child_pids(parent: int) -> list[int]:
    """Live child processes of ``parent`` (the campaign's worker processes)."""
    out = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit():
            continue
        try:
            with open(f"/proc/{entry}/stat") as fh:
                stat = fh.read()
        except OSError:
            continue
        fields = stat.rsplit(")", 1)[1].split()
        if int(fields[1]) == parent:
            out.append(int(entry))
    return sorted(out)


def db_bytes(db: Path) -> int:
    """Size on disk of the SQLite file and its WAL / shared-memory side files."""
    return sum(p.stat().st_size for p in db.parent.glob(db.name + "*") if p.is_file())


def _growth(samples: list[tuple[int, float]]) -> dict[str, float] | None:
    if len(samples) < 2:
        return None
    first, last = samples[0][1], samples[-1][1]
    return {"mib": round(last - first, 2), "percent": round(100 * (last - first) / first, 2)}


def run_scale_campaign(db: Path, runs: int, workers: int, sample_every: int) -> dict[str, Any]:
    """Run (or resume) the campaign ``scale`` in ``db``, sampling parent and worker RSS."""
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    parent: list[tuple[int, float]] = []
    workers_rss: list[tuple[int, list[float]]] = []

    def progress(p: Any) -> None:
        if p.event == "run" and p.done % sample_every == 0:
            parent.append((p.done, round(rss_mib() or 0.0, 2)))
            kids = [rss_mib(pid) for pid in child_pids(os.getpid())]
            workers_rss.append((p.done, [round(k, 2) for k in kids if k is not None]))
            print(  # also here: a campaign stopped early still leaves its samples
                f"[bench_scale] {p.done}/{p.total} runs, parent RSS {parent[-1][1]} MiB, "
                f"workers {workers_rss[-1][1]} MiB, load {os.getloadavg()}",
                flush=True,
            )

    config = CampaignConfig(name="scale", runs=runs, workers=workers, executor="processes", seed=1)
    with open_store(db) as store:
        start, cpu0 = time.perf_counter(), os.times()
        result = run_campaign(config, store, progress=progress)
        wall, cpu1 = time.perf_counter() - start, os.times()
    cpu = sum(b - a for a, b in zip(cpu0[:4], cpu1[:4], strict=True))
    worker_max = [(n, max(r)) for n, r in workers_rss if r]
    return {
        "runs": runs,
        "workers": workers,
        "executed": result.executed,
        "wall_s": round(wall, 1),
        "cpu_s": round(cpu, 1),
        "cpu_ms_per_run": round(1000 * cpu / max(result.executed, 1), 2),
        "counts": result.counts,
        "parent_rss_mib": parent,
        "parent_rss_growth": _growth(parent),
        "worker_rss_mib": workers_rss,
        "worker_rss_growth": _growth(worker_max),
    }


def time_cli(args: list[str], stdout: Any = subprocess.DEVNULL) -> dict[str, Any]:
    """Run ``python -m sitcov.cli ARGS``; its wall time, CPU time and peak RSS (wait4)."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")]),
    }
    start = time.perf_counter()
    proc = subprocess.Popen(
        [sys.executable, "-m", "sitcov.cli", *args], stdout=stdout, stderr=subprocess.PIPE, env=env
    )
    _, status, usage = os.wait4(proc.pid, 0)
    wall = time.perf_counter() - start
    proc.returncode = os.waitstatus_to_exitcode(status)
    err = proc.stderr.read().decode(errors="replace") if proc.stderr else ""
    if proc.returncode != 0:
        raise SystemExit(f"sitcov {' '.join(args)} failed ({proc.returncode}): {err[-2000:]}")
    return {
        "wall_s": round(wall, 2),
        "cpu_s": round(usage.ru_utime + usage.ru_stime, 2),
        "peak_rss_mib": round(usage.ru_maxrss / 1024, 1),
    }


def time_analysis(db: Path, tmp: Path) -> dict[str, Any]:
    """Time summary, report and the exports on ``db`` (outputs written under ``tmp``)."""
    out: dict[str, Any] = {"summary_json": time_cli(["summary", "--db", str(db), "--json"])}
    out["summary"] = time_cli(["summary", "--db", str(db)])
    out["report"] = time_cli(["report", "--db", str(db), "--out", str(tmp / "report")])
    for fmt in ("csv", "json", "junit"):
        target = tmp / f"runs.{fmt}"
        out[f"export_{fmt}"] = time_cli(
            ["export", "--db", str(db), "--format", fmt, "--out", str(target)]
        )
        out[f"export_{fmt}"]["bytes"] = target.stat().st_size
    return out


def main(argv: list[str] | None = None) -> dict[str, Any]:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--runs", type=int, default=100_000)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--sample-every", type=int, default=10_000)
    parser.add_argument("--db", type=Path, help="database to write (default: a temporary one)")
    parser.add_argument(
        "--analysis-only", action="store_true", help="only time summary/report/export on --db"
    )
    parser.add_argument("--out", type=Path, help="also write the JSON result here")
    args = parser.parse_args(argv)
    if args.analysis_only and not (args.db and args.db.exists()):
        parser.error("--analysis-only needs an existing --db")
    report: dict[str, Any] = {"cpus": os.cpu_count(), "loadavg_start": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        db = args.db or Path(tmp, "scale.db")
        if not args.analysis_only:
            report["campaign"] = run_scale_campaign(db, args.runs, args.workers, args.sample_every)
        from sitcov.campaign import open_store

        with open_store(db) as store:
            stored = store.count_runs()
        size = db_bytes(db)
        report["database"] = {
            "runs": stored,
            "bytes": size,
            "bytes_per_run": round(size / max(stored, 1), 1),
        }
        report["loadavg_before_analysis"] = os.getloadavg()
        report["analysis"] = time_analysis(db, Path(tmp))
    report["loadavg_end"] = os.getloadavg()
    text = json.dumps(report, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return report


if __name__ == "__main__":
    main()
