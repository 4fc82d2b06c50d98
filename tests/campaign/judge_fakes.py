"""A fake backend that reports departure facts (for the judge and physics plumbing tests).

Loaded as ``judge_fakes:DepartingBackend`` (this folder is on the path, see conftest.py).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any, ClassVar

import numpy as np
from campaign_fakes import fake_outcome

from sitcov.sim import Backend, Outcome

DEPARTING = "judge_fakes:DepartingBackend"


def departing_outcome(situation: Any, seed: int, physics: str = "carla") -> Outcome:
    """FakeBackend's outcome plus lane/road departure and route progress facts drawn
    from the seed.

    About 30% of runs leave their lane, half of those the road too, a little earlier (a
    corner over the kerb before the centre is far off the lane, as when steering into the
    near kerb); departures come before the end (and before any collision) of the run.
    """
    base = fake_outcome(situation, seed)
    rng = np.random.default_rng([int(seed), 11])
    lane = road = None
    if rng.random() < 0.3:
        lane = round(0.3 * base.sim_time, 3)
        if rng.random() < 0.5:
            road = round(0.2 * base.sim_time, 3)
    # route progress facts: a collision is the standing ego's in a fifth of the cases;
    # a run without a collision reaches its goal, or stops short (blocked or not)
    stationary = base.collision and rng.random() < 0.2
    goal = not base.collision and rng.random() < 0.7
    stops = not (base.collision or goal or rng.random() < 0.5)
    blocked = round(0.5 * base.sim_time, 3) if stops else None
    metrics = {
        **base.metrics,
        "lane_departure_time": lane,
        "road_departure_time": road,
        "physics": physics,
        "ego_stationary": bool(stationary),
        "route_completion": 1.0 if goal else round(float(rng.random()), 6),
        "blocked_time": blocked,
        "route_incomplete_time": None if base.collision or goal else 60.0,
        "actor_collisions": [{"actors": ["a", "b"]}] * int(rng.random() < 0.1),
    }
    return replace(base, metrics=metrics, collision_time=base.sim_time if base.collision else None)


class DepartingBackend(Backend):
    """Deterministic outcomes with departure facts; takes a ``physics`` option."""

    name: ClassVar[str] = "departing"

    def __init__(self, physics: str = "carla") -> None:
        self.physics = physics

    def run(self, situation: Any, av_stack: Any, seed: int, *, record: bool = False) -> Outcome:
        return departing_outcome(situation, seed, self.physics)

    def effects(self) -> dict[str, str]:
        return {"friction": "fake failures", "intsit": "none"}
