"""Situations per second per generator (for ``sitcov bench`` and benchmarks/)."""

from __future__ import annotations

import time

from sitcov._seeding import ask_rng
from sitcov.generation._registry import GENERATOR_NAMES, make_generator
from sitcov.hyperspace import Hyperspace, load_hyperspace


def bench_generators(
    n: int = 20_000,
    seed: int = 0,
    *,
    names: tuple[str, ...] = GENERATOR_NAMES,
    hyperspace: Hyperspace | str | None = None,
    fresh_rng: bool = False,
) -> dict[str, float]:
    """Asks per second of each generator on one core.

    Args:
        n: situations asked per generator.
        seed: seed of the rng(s).
        names: generators to measure.
        hyperspace: defaults to the built-in t-junction.
        fresh_rng: derive a new rng per ask as a campaign does (``ask_rng(seed, i)``)
            instead of one rng for all asks; that derivation costs ~10 us itself.

    Returns:
        generator name -> situations per second of CPU time of this process (so other
        load on a shared machine does not count); setup such as building a covering
        array is included, as a campaign pays it too.
    """
    import numpy as np

    hs = load_hyperspace(hyperspace)
    out: dict[str, float] = {}
    for name in names:
        start = time.process_time()
        gen = make_generator(name, hs)
        rng = np.random.default_rng(seed)
        for i in range(n):
            gen.ask(ask_rng(seed, i) if fresh_rng else rng)
        out[name] = n / max(time.process_time() - start, 1e-9)
    return out
