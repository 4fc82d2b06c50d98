"""How every random stream in a campaign derives from the campaign seed.

A run's situation and its simulation depend only on (campaign seed, run index), never on
which worker ran it or in what order, so serial, multi-process and Ray campaigns agree.
"""

from __future__ import annotations

import numpy as np

_ASK_STREAM = 0  # the generator's draw for run i
_RUN_STREAM = 1  # the simulation of run i


def ask_rng(seed: int, index: int) -> np.random.Generator:
    """The generator used to ask for the situation of run ``index``."""
    return np.random.default_rng([_ASK_STREAM, int(seed), int(index)])


def run_seed(seed: int, index: int) -> int:
    """The simulation seed of run ``index`` (a 32-bit integer, stored with the run)."""
    sequence = np.random.SeedSequence([_RUN_STREAM, int(seed), int(index)])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


_DRAW_STREAM = 5  # a run's further perception draws (apart from 0-4: ask, run, shrinker, repeats)


def draw_seed(seed: int, draw: int) -> int:
    """The perception seed of draw ``draw`` (>= 1) of a run whose seed is ``seed``: the
    same world, other perception noise (``EmbeddedBackend.run(..., perception_seed=)``).
    Draw 0 is the run itself. A function of the stored run seed alone, so a stored run's
    draws can be run again without its campaign."""
    sequence = np.random.SeedSequence([_DRAW_STREAM, int(seed), int(draw)])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])
