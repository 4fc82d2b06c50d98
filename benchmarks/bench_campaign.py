"""Campaign benchmark: worker speed-up, parent memory over a long campaign, wall times.

Usage::

    python benchmarks/bench_campaign.py                  # 2,000-run speed-up + 10,000-run RSS
    python benchmarks/bench_campaign.py --speedup-runs 200 --memory-runs 1000   # quick look
    python benchmarks/bench_campaign.py --memory-backend null   # RSS with a no-op backend
    python benchmarks/bench_campaign.py --backend sleep --memory-runs 0  # executor parallelism

Measures, on fresh SQLite files in a temporary directory:

1. wall time of the same campaign (default: embedded backend, PEM, reference stack, sitcov
   generator) with ``processes --workers 1`` and ``--workers 2``, and the speed-up;
2. the parent's resident memory (RSS) sampled every 1,000 finished runs of a long campaign
   (``--workers 2``), and its growth from the first sample to the last.

Prints one JSON object (also written to ``--out`` if given).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, ClassVar

from sitcov.sim import Backend, Outcome

HERE = Path(__file__).resolve().parent


class NullBackend(Backend):
    """Returns a fixed pass immediately: isolates the campaign machinery's own cost."""

    name: ClassVar[str] = "null"

    def run(self, situation: Any, av_stack: Any, seed: int, *, record: bool = False) -> Outcome:
        return Outcome(status="pass", end_reason="goal", sim_time=1.0, min_distance=float(seed % 7))


class SleepBackend(NullBackend):
    """Waits 20 ms per run without using CPU: measures the executor's parallelism alone,
    independent of how much CPU a shared machine grants."""

    name: ClassVar[str] = "sleep"

    def run(self, situation: Any, av_stack: Any, seed: int, *, record: bool = False) -> Outcome:
        time.sleep(0.02)
        return super().run(situation, av_stack, seed, record=record)


def rss_mib() -> float:
    """Resident set size of this process [MiB] (Linux /proc)."""
    with open("/proc/self/statm") as fh:
        pages = int(fh.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def timed_campaign(db: Path, backend: str, runs: int, workers: int, sample_every: int = 0) -> dict:
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    samples: list[tuple[int, float]] = []

    def progress(p: Any) -> None:
        if sample_every and p.event == "run" and p.done % sample_every == 0:
            samples.append((p.done, round(rss_mib(), 2)))

    config = CampaignConfig(
        name="bench", backend=backend, runs=runs, workers=workers, executor="processes", seed=1
    )
    with open_store(db) as store:
        start, cpu0 = time.perf_counter(), os.times()
        result = run_campaign(config, store, progress=progress)
        wall, cpu1 = time.perf_counter() - start, os.times()
    # CPU seconds of this process and its (joined) workers: on a machine shared with other
    # jobs, wall-clock speed-up is capped by the CPU actually granted; CPU per run is not.
    cpu = sum(b - a for a, b in zip(cpu0[:4], cpu1[:4], strict=True))
    out = {
        "runs": runs,
        "workers": workers,
        "wall_s": round(wall, 2),
        "runs_per_s": round(runs / wall, 1),
        "cpu_s": round(cpu, 2),
        "cpu_ms_per_run": round(1000 * cpu / max(runs, 1), 2),
        "cpu_utilisation": round(cpu / wall, 2),
        "failures": result.failures,
        "errors": result.errors,
    }
    if samples:
        out["rss_mib"] = samples
        out["rss_growth_mib"] = round(samples[-1][1] - samples[0][1], 2)
    return out


def main(argv: list[str] | None = None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--speedup-runs", type=int, default=2000)
    parser.add_argument("--memory-runs", type=int, default=10000)
    parser.add_argument(
        "--backend", default="embedded", help="backend for the speed-up (or 'null', 'sleep')"
    )
    parser.add_argument(
        "--memory-backend", default="embedded", help="backend for the RSS run (or 'null')"
    )
    parser.add_argument("--out", type=Path)
    args = parser.parse_args(argv)
    if str(HERE) not in sys.path:
        sys.path.insert(0, str(HERE))  # workers import NullBackend as bench_campaign:NullBackend
    names = {"null": "bench_campaign:NullBackend", "sleep": "bench_campaign:SleepBackend"}
    report: dict[str, Any] = {"cpus": os.cpu_count(), "loadavg_start": os.getloadavg()}
    with tempfile.TemporaryDirectory() as tmp:
        if args.speedup_runs:
            backend = names.get(args.backend, args.backend)
            one = timed_campaign(Path(tmp, "w1.db"), backend, args.speedup_runs, 1)
            two = timed_campaign(Path(tmp, "w2.db"), backend, args.speedup_runs, 2)
            report["speedup"] = {
                "backend": args.backend,
                "workers_1": one,
                "workers_2": two,
                "speedup_2_over_1": round(one["wall_s"] / two["wall_s"], 2),
            }
        if args.memory_runs:
            backend = names.get(args.memory_backend, args.memory_backend)
            report["memory"] = {
                "backend": args.memory_backend,
                **timed_campaign(Path(tmp, "mem.db"), backend, args.memory_runs, 2, 1000),
            }
    report["loadavg_end"] = os.getloadavg()
    text = json.dumps(report, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")
    return report


if __name__ == "__main__":
    main()
