"""nsga2: the search-based baseline (NSGA-II via pymoo over bin indices, as OpenSBT does).

Each element is an integer variable (its bin index). pymoo's NSGA-II (integer random
sampling, SBX crossover and polynomial mutation with rounding) minimises two criticality
objectives per run:

- ``f1`` = 0 for a failing run, else ``1 + min_distance`` (metres; 51 when unknown);
- ``f2`` = ``min_ttc`` capped at 10 s (10 when unknown); runs that were not judged
  (error, timeout) get the worst values (51, 10).

The campaign's asks are served from the population pymoo asks for; when every member has
been told, the generation is told to pymoo and the next one asked. With ``pop_size`` equal
to the campaign's batch size the two line up; if a batch asks for more than is left before
the outcomes are known, the surplus asks are uniform draws (not used by the search).

Randomness: pymoo draws from its own ``numpy.random.Generator`` seeded by ``seed`` (an
option, or a number drawn from the first ask's rng), never global state. The state holds
the seed and the objective values told so far; restoring replays pymoo's ask/tell
sequence with them, which rebuilds the identical algorithm.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from sitcov.errors import ConfigError, MissingExtraError
from sitcov.generation._common import MAX_REDRAWS, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation

#: objective values of a run that was not judged (worst)
WORST = (51.0, 10.0)


def objectives(outcome: Any) -> tuple[float, float]:
    """(f1, f2) of an outcome, both minimised (see the module docstring)."""
    status = getattr(outcome, "status", outcome)
    if status not in ("pass", "fail"):
        return WORST
    dist = getattr(outcome, "min_distance", None)
    ttc = getattr(outcome, "min_ttc", None)
    f1 = 0.0 if status == "fail" else 1.0 + min(float(dist) if dist is not None else 50.0, 50.0)
    f2 = min(float(ttc), 10.0) if ttc is not None else 10.0
    return f1, f2


def _pymoo() -> Any:
    try:
        import pymoo  # noqa: F401
    except ImportError:
        raise MissingExtraError("generator 'nsga2'", "search", "pymoo") from None
    from pymoo.algorithms.moo.nsga2 import NSGA2
    from pymoo.core.evaluator import Evaluator
    from pymoo.core.problem import Problem
    from pymoo.operators.crossover.sbx import SBX
    from pymoo.operators.mutation.pm import PM
    from pymoo.operators.repair.rounding import RoundingRepair
    from pymoo.operators.sampling.rnd import IntegerRandomSampling
    from pymoo.problems.static import StaticProblem

    return {
        "NSGA2": NSGA2, "Evaluator": Evaluator, "Problem": Problem,
        "StaticProblem": StaticProblem, "SBX": SBX, "PM": PM,
        "RoundingRepair": RoundingRepair, "IntegerRandomSampling": IntegerRandomSampling,
    }  # fmt: skip


class NSGA2Generator(IndexedGenerator):
    """NSGA-II over bin indices (pymoo), minimising failure distance and TTC.

    Args:
        hyperspace: the hyperspace.
        pop_size: population and offspring size (match the campaign's batch size).
        seed: pymoo's seed (default: drawn from the first ask's rng).
    """

    name = "nsga2"
    learns = True

    def __init__(
        self, hyperspace: Hyperspace, *, pop_size: int = 32, seed: int | None = None
    ) -> None:
        if int(pop_size) < 2:
            raise ConfigError(
                field="generator 'nsga2' option pop_size", value=pop_size, expected=">= 2"
            )
        super().__init__(hyperspace, pop_size=int(pop_size), seed=seed)
        self.pm = _pymoo()
        self.pop_size = int(pop_size)
        self.seed: int | None = None if seed is None else int(seed)
        self.history: list[list[list[float]]] = []  # F of each completed generation
        self.current: list[list[float] | None] = []  # F of the current one (None = untold)
        self.served = 0  # members of the current generation already asked
        self._algo: Any = None
        self._pop: Any = None

    # -- pymoo ------------------------------------------------------------------------------
    def _start(self) -> None:
        """Set pymoo up and replay the stored generations (deterministic)."""
        pm = self.pm
        n = self.n_elements
        problem = pm["Problem"](
            n_var=n, n_obj=2, xl=np.zeros(n), xu=np.asarray(self.sizes) - 1, vtype=int
        )
        self._problem = problem
        algo = pm["NSGA2"](
            pop_size=self.pop_size,
            sampling=pm["IntegerRandomSampling"](),
            crossover=pm["SBX"](prob=1.0, eta=3.0, vtype=float, repair=pm["RoundingRepair"]()),
            mutation=pm["PM"](eta=3.0, vtype=float, repair=pm["RoundingRepair"]()),
            eliminate_duplicates=True,
        )
        algo.setup(problem, termination=("n_gen", 10**9), seed=self.seed, verbose=False)
        self._algo = algo
        for f in self.history:
            pop = algo.ask()
            self._tell_pop(pop, f)
        self._pop = algo.ask()

    def _tell_pop(self, pop: Any, f: list[list[float]]) -> None:
        static = self.pm["StaticProblem"](self._problem, F=np.asarray(f, dtype=float))
        self.pm["Evaluator"]().eval(static, pop)
        self._algo.tell(infills=pop)

    def _rows(self) -> list[list[int]]:
        return np.rint(self._pop.get("X")).astype(int).tolist()

    def _advance(self) -> None:
        """All members told: tell pymoo, ask the next generation."""
        f = [list(x) for x in self.current]  # type: ignore[arg-type]
        self._tell_pop(self._pop, f)
        self.history.append(f)
        self._pop = self._algo.ask()
        self.current, self.served = [], 0

    # -- ask / tell -------------------------------------------------------------------------
    def ask(self, rng: np.random.Generator) -> Situation:
        """The next member of the current generation, or a uniform draw if none is left."""
        if self.seed is None:
            self.seed = int(rng.integers(0, 2**31 - 1))
            self.options["seed"] = self.seed
        if self._algo is None:
            self._start()
        if self.served == len(self._rows()) and all(f is not None for f in self.current):
            self._advance()
        rows = self._rows()
        if self.served < len(rows):
            idx = rows[self.served]
            if self._allowed(idx):
                self.served += 1
                self.current.append(None)
                return self._emit(idx, rng)
            self.served += 1  # a forbidden member: told the worst values, replaced below
            self.current.append(list(WORST))
        for _ in range(MAX_REDRAWS):
            idx = rng.integers(0, np.asarray(self.sizes)).tolist()
            if self._allowed(idx):
                return self._emit(idx, rng)
        raise self._over_constrained()

    def tell(self, situation: Situation, outcome: Any) -> None:
        """Give the objectives to the first untold member with these bins (if any)."""
        if self._algo is None:
            return
        idx = self._bin_index(situation)
        rows = self._rows()
        for i, f in enumerate(self.current):
            if f is None and rows[i] == idx:
                self.current[i] = list(objectives(outcome))
                return

    # -- state ------------------------------------------------------------------------------
    def _state_body(self) -> dict[str, Any]:
        return {
            "pymoo_seed": self.seed,
            "history": self.history,
            "current": self.current,
            "served": self.served,
        }

    def _load_body(self, body: dict[str, Any]) -> None:
        self.seed = body.get("pymoo_seed")
        self.history = [[[float(v) for v in f] for f in gen] for gen in body.get("history", [])]
        self.current = [None if f is None else [float(v) for v in f] for f in body["current"]]
        self.served = int(body["served"])
        if self.seed is not None:
            self._start()
