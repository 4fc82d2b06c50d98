"""Tiny deterministic stand-ins for a backend, an AV stack and a learning generator.

They are loaded by ``module:Class`` path (``campaign_fakes:FakeBackend`` with this folder on the
path), so worker processes and Ray actors build them exactly like real plugins.
"""

from __future__ import annotations

import os
import time
from dataclasses import replace
from types import SimpleNamespace
from typing import Any, ClassVar

import numpy as np

from sitcov.av import AVStack, Control
from sitcov.generation import Generator
from sitcov.sim import Backend, Outcome, Trace

BACKEND = "campaign_fakes:FakeBackend"
STACK = "campaign_fakes:FakeStack"
GENERATOR = "campaign_fakes:FakeGenerator"


def fake_outcome(situation: Any, seed: int) -> Outcome:
    """The outcome FakeBackend gives (independently computable in tests)."""
    rng = np.random.default_rng([int(seed), 7])
    friction = float(situation.value("friction", 1.0))
    p_fail = 0.6 if friction <= 0.2 else 0.15
    failed = bool(rng.random() < p_fail)
    distance = float(rng.uniform(0.0, 5.0))
    return Outcome(
        status="fail" if failed else "pass",
        end_reason="collision" if failed else "goal",
        sim_time=round(float(rng.uniform(5.0, 20.0)), 3),
        collision=failed,
        min_distance=0.0 if failed else distance,
        metrics={"draw": distance},
    )


def raises(seed: int, rate: float) -> bool:
    """Whether FakeBackend raises for this seed (deterministic, ~``rate`` of seeds)."""
    return bool(np.random.default_rng([int(seed), 99]).random() < rate)


def crashes(seed: int, rate: float) -> bool:
    """Whether FakeBackend kills its process for this seed (~``rate`` of seeds)."""
    return bool(np.random.default_rng([int(seed), 13]).random() < rate)


class FakeBackend(Backend):
    """Outcome from the seed and the friction value; optional raising and hanging."""

    name: ClassVar[str] = "fake"

    def __init__(
        self,
        raise_rate: float = 0.0,
        hang_rate: float = 0.0,
        sleep: float = 0.0,
        crash_rate: float = 0.0,
        **_: Any,
    ) -> None:
        self.raise_rate, self.hang_rate, self.sleep = raise_rate, hang_rate, sleep
        self.crash_rate = crash_rate

    def run(self, situation: Any, av_stack: AVStack, seed: int, *, record: bool = False) -> Outcome:
        if crashes(seed, self.crash_rate):
            os._exit(3)  # the worker process dies (as on a segfault): never in the test process
        if raises(seed, self.raise_rate):
            raise RuntimeError(f"fake backend exploded on seed {seed}")
        if self.hang_rate and np.random.default_rng([int(seed), 5]).random() < self.hang_rate:
            time.sleep(3600)
        if self.sleep:
            time.sleep(self.sleep)
        av_stack.reset(SimpleNamespace(seed=seed))  # type: ignore[arg-type]
        av_stack.step(None)  # type: ignore[arg-type]
        outcome = fake_outcome(situation, seed)
        if record:
            ego = [(0.1 * k, float(k), 0.0, 0.0, 5.0) for k in range(3)]
            trace = Trace(ego=ego, ov=[(0.0, 9.0, 9.0, 1.0, float(seed % 5))], meta={"seed": seed})
            outcome = replace(outcome, trace=trace)
        return outcome

    def effects(self) -> dict[str, str]:
        return {"friction": "raises the failure probability at 0.1 and 0.2", "intsit": "none"}


class FakeStack(AVStack):
    """Does nothing (the fake backend decides everything); ``params={"raise_rate": r}``
    makes ``reset`` raise for about a fraction r of the seeds (the same ones as
    :func:`raises`)."""

    name: ClassVar[str] = "fake-stack"

    def __init__(self, params: dict | None = None) -> None:
        self.raise_rate = float((params or {}).get("raise_rate", 0.0))

    def reset(self, info: Any) -> None:
        if raises(info.seed, self.raise_rate):
            raise ValueError(f"fake stack refused seed {info.seed}")

    def step(self, observation: Any) -> Control:
        return Control()


class FakeGenerator(Generator):
    """A learning generator: bins that failed are drawn more often (weight 1 + failures)."""

    name: ClassVar[str] = "fake"
    learns: ClassVar[bool] = True

    def __init__(self, hyperspace: Any, **options: Any) -> None:
        super().__init__(hyperspace)
        self.fails = {e: dict.fromkeys(hyperspace.labels(e), 0) for e in hyperspace.element_names}
        self.told = 0

    def ask(self, rng: np.random.Generator) -> Any:
        bins = {}
        for element, counts in self.fails.items():
            labels = list(counts)
            weights = np.array([1.0 + counts[lab] for lab in labels])
            bins[element] = labels[int(rng.choice(len(labels), p=weights / weights.sum()))]
        return self.hyperspace.situation_from_bins(bins, rng)

    def tell(self, situation: Any, outcome: Outcome) -> None:
        self.told += 1
        if outcome.status == "fail":
            for element, label in situation.bins.items():
                self.fails[element][label] += 1

    def state(self) -> dict[str, Any]:
        return {"fails": self.fails, "told": self.told}

    @classmethod
    def from_state(cls, hyperspace: Any, state: dict[str, Any]) -> FakeGenerator:
        gen = cls(hyperspace)
        gen.fails = {e: dict(c) for e, c in state["fails"].items()}
        gen.told = state["told"]
        return gen


class RaisingBackend(FakeBackend):
    """A FakeBackend whose every run raises (a broken backend: nothing can be judged)."""

    def __init__(self, **options: Any) -> None:
        super().__init__(**{**options, "raise_rate": 1.0})


DRAWS_BACKEND = "campaign_fakes:DrawsBackend"


def draw_fails(seed: int, perception_seed: int | None) -> bool:
    """DrawsBackend's verdict: a world's failure probability (from the run seed) drawn
    with the perception seed (the run's own when None)."""
    p_fail = np.random.default_rng([int(seed), 11]).random()
    sense = seed if perception_seed is None else perception_seed
    return bool(np.random.default_rng([int(sense), 12]).random() < p_fail)


class DrawsBackend(FakeBackend):
    """FakeBackend whose run takes ``perception_seed`` (as the embedded backend's): the
    verdict depends on the world (run seed) and the perception draw."""

    name: ClassVar[str] = "fake-draws"
    calls: ClassVar[list[tuple[int, int | None, bool]]] = []

    def run(  # type: ignore[override]
        self,
        situation: Any,
        av_stack: AVStack,
        seed: int,
        *,
        record: bool = False,
        perception_seed: int | None = None,
    ) -> Outcome:
        DrawsBackend.calls.append((int(seed), perception_seed, record))
        outcome = super().run(situation, av_stack, seed, record=record)
        failed = draw_fails(seed, perception_seed)
        return replace(
            outcome,
            status="fail" if failed else "pass",
            end_reason="collision" if failed else "goal",
            collision=failed,
            metrics={**outcome.metrics, "sense": perception_seed},
        )
