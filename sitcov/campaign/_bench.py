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
    progress: Callable[[int], None] | None = None,
) -> dict[str, Any]:
    """Run ``runs`` random default-hyperspace situations with the reference stack.

    Situations come from the ``random`` generator (``ask_rng(seed, i)``) and runs use
    ``run_seed(seed, i)``, as a campaign would; outcomes are judged by ``judge`` and the
    world uses the ``physics`` profile, as in a campaign with the same settings. Time is
    CPU time of this process (``time.process_time``), so other load does not count;
    wall time is reported too. The first ``warmup`` situations run once untimed before
    (``warmup_cpu_s``): what a process pays once (lazy imports, the compiled kernels of
    ``_jit.py``, per-route caches) is not a per-run cost.

    Returns:
        ``{"runs", "runs_per_s", "ms_per_run", "mean_steps", "failures", "wall_s", "cpu_s",
        "warmup_cpu_s", "jit", "end_reasons"}``.
    """
    from sitcov._jit import enabled
    from sitcov.av import make_stack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim._judge import Judge
    from sitcov.sim.embedded._backend import EmbeddedBackend

    hyperspace = load_hyperspace()
    generator = make_generator("random", hyperspace)
    situations = [generator.ask(ask_rng(seed, i)) for i in range(runs)]
    backend = EmbeddedBackend(perception=perception, physics=physics)
    verdict = Judge.from_spec(judge)
    stack = make_stack("reference", fault=fault)
    cpu0 = time.process_time()
    for i, situation in enumerate(situations[:warmup]):
        backend.run(situation, stack, run_seed(seed, i))
    warm = time.process_time() - cpu0
    steps = failures = 0
    reasons: dict[str, int] = {}
    wall0, cpu0 = time.perf_counter(), time.process_time()
    for i, situation in enumerate(situations):
        outcome = verdict(backend.run(situation, stack, run_seed(seed, i)))
        steps += int(outcome.metrics.get("steps", 0))
        failures += outcome.failed
        reasons[outcome.end_reason] = reasons.get(outcome.end_reason, 0) + 1
        if progress is not None:
            progress(i + 1)
    cpu = time.process_time() - cpu0
    wall = time.perf_counter() - wall0
    stack.close()
    return {
        "runs": runs,
        "runs_per_s": runs / cpu if cpu > 0 else float("inf"),
        "ms_per_run": 1000.0 * cpu / max(runs, 1),
        "mean_steps": steps / max(runs, 1),
        "failures": failures,
        "cpu_s": cpu,
        "wall_s": wall,
        "warmup_cpu_s": warm,
        "jit": enabled(),
        "end_reasons": reasons,
    }
