"""A backend whose failures depend on exactly two elements (for the shrinker's tests).

The run fails with probability 0.95 when friction is 0.1 AND the intersection situation is
IntSit-2, and with probability 0.02 otherwise, drawn from the run seed: every other element
is irrelevant, so a correct shrinker keeps exactly {friction, intsit}.
"""

from __future__ import annotations

from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np

from sitcov.sim import Backend, Outcome

BACKEND = "shrink_fakes:TwoElementBackend"


class TwoElementBackend(Backend):
    """Failure from (friction, intsit) and the seed only."""

    name: ClassVar[str] = "two-element"

    def __init__(self, **_: Any) -> None:
        pass

    def run(self, situation: Any, av_stack: Any, seed: int, *, record: bool = False) -> Outcome:
        av_stack.reset(SimpleNamespace(seed=seed))
        both = situation.bins["friction"] == "0.1" and situation.bins["intsit"] == "IntSit-2"
        failed = bool(np.random.default_rng([int(seed), 11]).random() < (0.95 if both else 0.02))
        return Outcome(
            status="fail" if failed else "pass",
            end_reason="collision" if failed else "goal",
            sim_time=10.0,
            collision=failed,
            min_distance=0.0 if failed else 3.0,
        )
