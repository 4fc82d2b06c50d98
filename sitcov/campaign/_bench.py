"""Throughput of the embedded backend: runs per second on one core."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

from sitcov._seeding import ask_rng, run_seed


def bench(
    runs: int = 200,
    seed: int = 0,
    *,
    fault: str | None = None,
    perception: str = "pem",
    physics: str = "carla",
    judge: str = "default",
    warmup: int = 5,
    rounds: int = 1,
    progress: Callable[[int], None] | None = None,
    map: str | None = None,  # noqa: A002 - the backend option's name
    hyperspace: str | None = None,
) -> dict[str, Any]:
    """Run ``runs`` random default-hyperspace situations with the reference stack.

    Situations come from the ``random`` generator (``ask_rng(seed, i)``) and runs use
    ``run_seed(seed, i)``, as a campaign would; outcomes are judged by ``judge`` and the
    world uses the ``physics`` profile, as in a campaign with the same settings. Time is
    CPU time of this process (``time.process_time``), so other load does not count;
    wall time is reported too. The first ``warmup`` situations run once untimed before
    (``warmup_cpu_s``): what a process pays once (lazy imports, the compiled kernels of
    ``_jit.py``, per-route caches) is not a per-run cost.

    With ``rounds`` > 1 the same runs are timed that many times in this process: a
    machine whose speed drifts (a shared host changes by up to 1.5x within minutes) is
    better summarised by the median round than by one; ``runs_per_s`` is then that median
    and ``rounds_runs_per_s`` every round's figure. Every round must give the same
    outcomes (the same seeds give the same runs), else RuntimeError.

    ``map`` runs on another embedded map (a name, a YAML file or ``FILE.xodr[#ID]``) and
    ``hyperspace`` draws from another hyperspace file (e.g. one derived on that map).

    Returns:
        ``{"runs", "runs_per_s", "ms_per_run", "mean_steps", "failures", "wall_s", "cpu_s",
        "warmup_cpu_s", "jit", "end_reasons", "rounds", "rounds_runs_per_s"}`` (times of
        the median round).
    """
    from sitcov._jit import enabled
    from sitcov.av import make_stack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim._judge import Judge
    from sitcov.sim.embedded._backend import EmbeddedBackend

    space = load_hyperspace(hyperspace) if hyperspace else load_hyperspace()
    generator = make_generator("random", space)
    situations = [generator.ask(ask_rng(seed, i)) for i in range(runs)]
    options = {"map": map} if map else {}
    backend = EmbeddedBackend(perception=perception, physics=physics, **options)
    verdict = Judge.from_spec(judge)
    stack = make_stack("reference", fault=fault)
    cpu0 = time.process_time()
    for i, situation in enumerate(situations[:warmup]):
        backend.run(situation, stack, run_seed(seed, i))
    warm = time.process_time() - cpu0
    timed = []
    for _ in range(max(1, rounds)):
        timed.append(_timed_pass(backend, stack, verdict, situations, seed, progress))
        if timed[-1]["outcomes"] != timed[0]["outcomes"]:
            raise RuntimeError("sitcov bench: two rounds of the same runs gave other outcomes")
    stack.close()
    by_speed = sorted(timed, key=lambda r: r["cpu_s"])
    median = by_speed[len(by_speed) // 2]
    cpu, outcomes = median["cpu_s"], median["outcomes"]
    reasons: dict[str, int] = {}
    for _, reason, _ in outcomes:
        reasons[reason] = reasons.get(reason, 0) + 1
    return {
        "runs": runs,
        "runs_per_s": runs / cpu if cpu > 0 else float("inf"),
        "ms_per_run": 1000.0 * cpu / max(runs, 1),
        "mean_steps": sum(steps for _, _, steps in outcomes) / max(runs, 1),
        "failures": sum(failed for failed, _, _ in outcomes),
        "cpu_s": cpu,
        "wall_s": median["wall_s"],
        "warmup_cpu_s": warm,
        "jit": enabled(),
        "end_reasons": reasons,
        "rounds": len(timed),
        "rounds_runs_per_s": [runs / r["cpu_s"] if r["cpu_s"] > 0 else float("inf") for r in timed],
    }


def _timed_pass(
    backend: Any,
    stack: Any,
    verdict: Any,
    situations: list[Any],
    seed: int,
    progress: Callable[[int], None] | None,
) -> dict[str, Any]:
    """One timed pass over ``situations``: CPU and wall seconds and each run's
    (failed, end reason, steps)."""
    outcomes = []
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for i, situation in enumerate(situations):
        outcome = verdict(backend.run(situation, stack, run_seed(seed, i)))
        outcomes.append(
            (bool(outcome.failed), outcome.end_reason, int(outcome.metrics.get("steps", 0)))
        )
        if progress is not None:
            progress(i + 1)
    cpu = time.process_time() - cpu0
    return {"cpu_s": cpu, "wall_s": time.perf_counter() - wall0, "outcomes": outcomes}
