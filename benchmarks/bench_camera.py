"""Camera-mode speed: runs/s on N worker processes, CPU seconds per run, and where they go.

Usage:
    python benchmarks/bench_camera.py [--runs N] [--seed S] [--workers W]
        [--scenes two-cars,three-actors] [--profile] [--out FILE.json]

Scenes (the embedded backend's default map, t-junction; reference stack with the SSD):
  * ``two-cars``: the paper's situations (random default-hyperspace situations, the
    ``random`` generator as ``sitcov bench``): ego and one car.
  * ``three-actors``: the same situations plus ``actor2``, a pedestrian crossing on one of
    the six crosswalks (cycled by run index): ego, car, pedestrian.

Each worker process builds one backend and one stack (so one TFLite interpreter) and runs a
contiguous share of the runs; the numbers printed per scene are the wall time, the CPU time
of the workers (``time.process_time`` in each, summed: independent of other load on the
machine), CPU-s per run, runs/s measured, and ``2 / CPU-s per run`` = the runs/s two idle
cores would give. The machine's load average is printed with them.

``--profile`` runs the scene in this process under cProfile and splits the CPU time into
renderer (``render_frame``), detector network (``Interpreter.invoke``), detector pre/post
processing (the rest of ``SSDDetector.__call__``) and the simulation (the rest).
"""

from __future__ import annotations

import argparse
import cProfile
import json
import multiprocessing as mp
import os
import pstats
import time
from typing import Any

from sitcov._seeding import ask_rng, run_seed
from sitcov.generation import make_generator
from sitcov.hyperspace import Situation, load_hyperspace

#: Crosswalk routes the three-actor scene's pedestrian walks (cycled by run index).
CROSSWALKS = ("XBL", "XBR", "XLL", "XLR", "XRL", "XRR")
SCENES = ("two-cars", "three-actors")


def situation(scene: str, seed: int, index: int) -> Situation:
    """Run ``index``'s situation of ``scene`` (deterministic per seed and index)."""
    base = make_generator("random", load_hyperspace()).ask(ask_rng(seed, index))
    if scene == "two-cars":
        return base
    if scene != "three-actors":
        raise SystemExit(f"--scenes: unknown scene {scene!r}; expected one of {SCENES}")
    route = CROSSWALKS[index % len(CROSSWALKS)]
    slot = {"kind": "pedestrian", "route": route, "behaviour": "cross"}
    bins, values = dict(base.bins), dict(base.values)
    bins["actor2"] = f"pedestrian:{slot['route']}"
    values["actor2"] = slot
    return Situation(bins=bins, values=values)


def run_share(args: tuple[str, int, list[int]]) -> dict[str, Any]:
    """Run the given run indices of a scene in this process; CPU time, verdicts, frames."""
    from sitcov.av import ReferenceStack
    from sitcov.perception import SSDDetector
    from sitcov.sim.embedded import EmbeddedBackend

    scene, seed, indices = args
    cpu0 = time.process_time()
    backend = EmbeddedBackend(perception="camera")
    stack = ReferenceStack(detector=SSDDetector())
    rows = []
    for i in indices:
        out = backend.run(situation(scene, seed, i), stack, run_seed(seed, i))
        rows.append((i, out.status, out.aeb_time, out.sim_time))
    return {"cpu_s": time.process_time() - cpu0, "rows": rows}


def measure(scene: str, runs: int, seed: int, workers: int) -> dict[str, Any]:
    """Wall and CPU time of ``runs`` camera runs of ``scene`` on ``workers`` processes."""
    shares = [list(range(w, runs, workers)) for w in range(workers)]
    load0 = os.getloadavg()
    t0 = time.perf_counter()
    if workers == 1:
        results = [run_share((scene, seed, shares[0]))]
    else:
        with mp.get_context("spawn").Pool(workers) as pool:
            results = pool.map(run_share, [(scene, seed, s) for s in shares])
    wall = time.perf_counter() - t0
    cpu = sum(r["cpu_s"] for r in results)
    rows = sorted(row for r in results for row in r["rows"])
    return {
        "scene": scene,
        "runs": runs,
        "workers": workers,
        "wall_s": wall,
        "cpu_s": cpu,
        "runs_per_s": runs / wall,
        "cpu_s_per_run": cpu / runs,
        "idle_2core_runs_per_s": 2.0 * runs / cpu,
        "load_before": load0,
        "load_after": os.getloadavg(),
        "failures": sum(r[1] == "fail" for r in rows),
        "rows": rows,
    }


def _own_time(stats: pstats.Stats, match: str) -> float:
    """Cumulative time of the functions whose ``file:name`` contains ``match``."""
    total = 0.0
    for (file, _, name), (_, _, _, cum, _) in stats.stats.items():  # type: ignore[attr-defined]
        if match in f"{file}:{name}":
            total = max(total, cum)
    return total


def profile(scene: str, runs: int, seed: int) -> dict[str, float]:
    """CPU split of ``runs`` runs of ``scene`` in this process (cProfile)."""
    prof = cProfile.Profile(time.process_time)
    prof.enable()
    result = run_share((scene, seed, list(range(runs))))
    prof.disable()
    stats = pstats.Stats(prof)
    render = _own_time(stats, "_renderer.py:render_frame")
    invoke = _own_time(stats, ":invoke")
    detect = _own_time(stats, "_detector.py:__call__")
    total = result["cpu_s"]
    return {
        "scene": scene,
        "runs": runs,
        "total_s": total,
        "render_s": render,
        "detector_net_s": invoke,
        "detector_prepost_s": detect - invoke,
        "sim_other_s": total - render - detect,
    }


def main() -> None:
    """Measure each scene; print one line per scene (and the profile split with --profile)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--scenes", default=",".join(SCENES))
    parser.add_argument("--profile", action="store_true")
    parser.add_argument("--out", default=None, help="Write the results as JSON here.")
    args = parser.parse_args()
    results = []
    for scene in args.scenes.split(","):
        if args.profile:
            p = profile(scene, args.runs, args.seed)
            print(
                f"{scene}: {p['runs']} runs, {p['total_s']:.1f} CPU-s: "
                f"render {p['render_s']:.1f}, detector net {p['detector_net_s']:.1f}, "
                f"detector pre/post {p['detector_prepost_s']:.1f}, "
                f"sim+other {p['sim_other_s']:.1f}"
            )
            results.append(p)
            continue
        r = measure(scene, args.runs, args.seed, args.workers)
        print(
            f"{scene}: {r['runs']} runs on {r['workers']} workers: {r['wall_s']:.1f} s wall "
            f"({r['runs_per_s']:.2f} runs/s), {r['cpu_s']:.1f} CPU-s "
            f"({r['cpu_s_per_run']:.2f} CPU-s/run -> {r['idle_2core_runs_per_s']:.2f} runs/s "
            f"on 2 idle cores), failures {r['failures']}, load "
            f"{r['load_before'][0]:.1f} -> {r['load_after'][0]:.1f}"
        )
        results.append(r)
    if args.out:
        with open(args.out, "w") as fh:
            json.dump(results, fh, indent=1)


if __name__ == "__main__":
    main()
