"""Perception draws: one situation's world run with several perception seeds, and the
majority verdict.

A PEM run draws its detector noise from the run's generator, so one run's verdict is one
draw: two runs of the same world (the same run seed's wind and road-user colours) with
other perception noise disagree on a sizeable share of situations, far more often than
two camera runs of that world, whose detector is a deterministic function of the
rendered frame (measured per stack in docs/pem.md, "Perception draws"). One PEM draw
cannot agree with the camera's verdict much more often than the PEM agrees with itself;
the majority of several draws estimates the PEM's most likely verdict for that world.

:class:`PerceptionDraws` wraps a backend whose ``run`` takes ``perception_seed``: it
runs draw 0 (the run itself, bit for bit the single run) and draws 1 .. K-1 with the
perception seeds :func:`sitcov._seeding.draw_seed` gives for the run seed, judges each
with the given verdict, and returns the first draw whose verdict is the majority's, with
``metrics["perception_draws"]`` (K), ``metrics["draws_failed"]`` (how many failed) and
``metrics["draw"]`` (which draw is stored). Every stored number is therefore one real
run's, and the share of failing draws is the situation's failure probability under the
perception model. K must be odd (no ties); K = 1 is the plain backend.
"""

from __future__ import annotations

import dataclasses
import inspect
from collections.abc import Callable
from typing import Any

from sitcov._seeding import draw_seed
from sitcov.errors import ConfigError
from sitcov.sim import Backend, Outcome


def takes_perception_seed(backend: Any) -> bool:
    """Whether ``backend.run`` accepts ``perception_seed`` (the embedded backend's)."""
    try:
        return "perception_seed" in inspect.signature(backend.run).parameters
    except (TypeError, ValueError):  # pragma: no cover - builtins without a signature
        return False


def check_draws(draws: int, backend: Any = None, *, field: str = "perception_draws") -> int:
    """``draws`` if it is a usable number of perception draws for ``backend``; else a
    ConfigError naming ``field``."""
    if isinstance(draws, bool) or not isinstance(draws, int) or draws < 1 or draws % 2 == 0:
        raise ConfigError(field=field, value=draws, expected="an odd whole number >= 1")
    if draws > 1 and backend is not None and not takes_perception_seed(backend):
        name = getattr(backend, "name", type(backend).__name__)
        raise ConfigError(
            field=field,
            value=draws,
            expected=f"1: backend {name!r} cannot rerun a world with other perception "
            "noise (its run() has no perception_seed)",
        )
    return draws


class PerceptionDraws(Backend):
    """``backend`` run ``draws`` times per situation with other perception seeds; the
    majority's verdict (module docstring).

    Args:
        backend: a backend whose ``run`` takes ``perception_seed`` (``EmbeddedBackend``).
        draws: odd number of draws per run.
        failed: the verdict of one draw (e.g. ``lambda o: judge(o).failed``); the campaign
            judges the stored draw again, which gives the same verdict.
    """

    def __init__(self, backend: Any, draws: int, failed: Callable[[Outcome], bool]) -> None:
        self.backend = backend
        self.draws = check_draws(draws, backend)
        self._failed = failed
        self.name = getattr(backend, "name", "embedded")  # type: ignore[misc]

    def run(
        self,
        situation: Any,
        av_stack: Any,
        seed: int,
        *,
        record: bool = False,
        perception_seed: int | None = None,
    ) -> Outcome:
        """The stored draw of ``situation`` at run seed ``seed`` (module docstring).
        ``perception_seed``: draw 0's perception seed (the backend's meaning; None: the
        run's own), the other draws' derive from it."""
        seed = int(seed)
        base = seed if perception_seed is None else int(perception_seed)
        draws = [None if base == seed else base]
        draws += [draw_seed(base, j) for j in range(1, self.draws)]
        outcomes = [self._draw(situation, av_stack, seed, sense) for sense in draws]
        verdicts = [bool(self._failed(o)) for o in outcomes]
        failing = sum(verdicts)
        chosen = verdicts.index(2 * failing > self.draws)  # the first of the majority
        outcome = outcomes[chosen]
        if record:  # the same draw again, with its trace (a run is deterministic)
            outcome = self._draw(situation, av_stack, seed, draws[chosen], record=True)
        metrics = {
            **outcome.metrics,
            "perception_draws": self.draws,
            "draws_failed": failing,
            "draw": chosen,
        }
        return dataclasses.replace(outcome, metrics=metrics)

    def _draw(
        self, situation: Any, av_stack: Any, seed: int, sense: int | None, record: bool = False
    ) -> Outcome:
        """One draw: the run itself (``sense`` None) or its world with perception seed
        ``sense``."""
        if sense is None:
            return self.backend.run(situation, av_stack, seed, record=record)
        return self.backend.run(situation, av_stack, seed, record=record, perception_seed=sense)

    def effects(self) -> dict[str, str]:
        return self.backend.effects()

    def check_hyperspace(self, hyperspace: Any) -> None:
        self.backend.check_hyperspace(hyperspace)

    def close(self) -> None:
        self.backend.close()

    def __getattr__(self, name: str) -> Any:
        # options a caller reads from the backend it built (perception, physics, map ...)
        if name == "backend":
            raise AttributeError(name)
        return getattr(self.backend, name)
