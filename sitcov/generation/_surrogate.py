"""surrogate: a Bayesian logistic failure model proposes situations, with a coverage floor.

The paper's "machine learning ... to generate more interesting situations" future work,
kept small and deterministic:

- **model**: ``P(fail) = sigmoid(b + sum_e beta[e, bin_e] + sum_pairs gamma[pair, bins])``
  over one-hot bins, with pairwise terms for every pair among the ``pairs`` elements whose
  main effects currently span the widest logit range (so the interaction that matters,
  e.g. intsit x friction, is modelled without thousands of columns). Coefficients have a
  N(0, 1) prior (ridge 1); the fit is penalised Newton-Raphson (``sitcov.analysis._logit``)
  and its Laplace approximation ``N(coef, H^-1)`` is the posterior;
- **proposal** (Thompson sampling): per ask, draw one coefficient vector from the
  posterior, score ``candidates`` uniform situations plus the one that maximises the drawn
  main effects element by element, and return the highest drawn failure logit. Drawing
  rather than taking the mean trades exploitation (high predicted failure) against
  uncertainty (rarely tried bins have wide posteriors). With ``novelty`` > 0 the drawn
  logit of a candidate is lowered by ``novelty * log(1 + f)``, ``f`` = failures already
  observed in the candidate's cell of the modelled elements (e.g. its intsit x friction
  cell), which steers the search from failures already found to new ones;
- **coverage floor**: ask number ``i`` is a coverage ask when ``floor(share * (i + 1)) >
  floor(share * i)``, i.e. exactly a ``floor`` share of the asks; it takes, per element,
  a least-generated bin (seeded tie-break). Every element's least-used bin therefore has at
  least ``floor(C / n_bins)`` runs after ``C`` coverage asks, so every bin's failure rate
  stays estimable. Until ``warmup`` judged outcomes exist, every ask is a coverage ask.

The state holds the bin counts and the judged outcomes (bin indices and verdict); the
model is refitted from them, so a restored generator continues exactly.
"""

from __future__ import annotations

from itertools import combinations
from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.generation._common import MAX_REDRAWS, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation

#: prior precision of every non-intercept coefficient (a N(0, 1) prior on the logit scale)
PRIOR_PRECISION = 1.0


class SurrogateGenerator(IndexedGenerator):
    """Thompson sampling from a logistic failure model over bins, with a coverage floor.

    Args:
        hyperspace: the hyperspace.
        floor: share of asks that take least-generated bins (0..1).
        candidates: uniform candidate situations scored per model ask.
        pairs: elements whose pairwise interactions are modelled (0 = main effects only).
        warmup: judged outcomes needed before the model is used.
        novelty: weight of the penalty on cells that already failed (0 = pure Thompson).
    """

    name = "surrogate"
    learns = True

    def __init__(
        self,
        hyperspace: Hyperspace,
        *,
        floor: float = 0.2,
        candidates: int = 64,
        pairs: int = 2,
        warmup: int = 20,
        novelty: float = 1.0,
    ) -> None:
        checks = {
            "floor": (0.0 <= float(floor) <= 1.0, "0..1"),
            "candidates": (int(candidates) >= 1, ">= 1"),
            "pairs": (int(pairs) >= 0, ">= 0"),
            "warmup": (int(warmup) >= 0, ">= 0"),
            "novelty": (float(novelty) >= 0, ">= 0"),
        }
        values = {"floor": floor, "candidates": candidates, "pairs": pairs, "warmup": warmup,
                  "novelty": novelty}  # fmt: skip
        for key, (ok, expected) in checks.items():
            if not ok:
                field = f"generator 'surrogate' option {key}"
                raise ConfigError(field=field, value=values[key], expected=expected)
        super().__init__(
            hyperspace, floor=float(floor), candidates=int(candidates), pairs=int(pairs),
            warmup=int(warmup), novelty=float(novelty),
        )  # fmt: skip
        self.floor, self.n_candidates = float(floor), int(candidates)
        self.n_pairs, self.warmup, self.novelty = int(pairs), int(warmup), float(novelty)
        self.counts: list[list[int]] = [[0] * n for n in self.sizes]
        self.obs: list[list[int]] = []  # bin indices + [1 if fail else 0]
        self.offsets = np.concatenate([[0], np.cumsum(self.sizes)[:-1]]).astype(int)
        self._fit: tuple[int, Any] | None = None  # (len(obs) at fit, model)

    # -- model ----------------------------------------------------------------------------
    def _design(self, idx: np.ndarray, pair_list: list[tuple[int, int]]) -> np.ndarray:
        """Columns: intercept, one-hot bins, one-hot bin pairs of ``pair_list``."""
        n = idx.shape[0]
        main = np.zeros((n, int(sum(self.sizes))))
        rows = np.arange(n)
        for e in range(self.n_elements):
            main[rows, self.offsets[e] + idx[:, e]] = 1.0
        parts = [np.ones((n, 1)), main]
        for a, b in pair_list:
            block = np.zeros((n, self.sizes[a] * self.sizes[b]))
            block[rows, idx[:, a] * self.sizes[b] + idx[:, b]] = 1.0
            parts.append(block)
        return np.concatenate(parts, axis=1)

    def _fit_model(self) -> dict[str, Any]:
        """Main effects first, then the model with pairs among the widest-ranging elements."""
        from sitcov.analysis._logit import fit_logit, single_thread

        data = np.asarray(self.obs, dtype=int)
        idx, y = data[:, :-1], data[:, -1].astype(float)
        with single_thread():
            main = fit_logit(self._design(idx, []), y, ridge=PRIOR_PRECISION)
            spans = [
                float(np.ptp(main.coef[1 + o : 1 + o + s]))
                for o, s in zip(self.offsets, self.sizes, strict=True)
            ]
            top = sorted(range(self.n_elements), key=lambda e: (-spans[e], e))[: self.n_pairs]
            pair_list = list(combinations(sorted(top), 2))
            x = self._design(idx, pair_list)
            fit = fit_logit(x, y, ridge=PRIOR_PRECISION) if pair_list else main
            p = fit.prob
            hess = (x.T * (p * (1 - p))) @ x + np.diag(
                np.r_[1e-6, np.full(x.shape[1] - 1, PRIOR_PRECISION)]
            )
            chol = np.linalg.cholesky(np.linalg.inv(hess))
        cells = sorted(top) if top else []
        fails: dict[tuple[int, ...], int] = {}
        for row in data[data[:, -1] == 1]:
            key = tuple(int(row[e]) for e in cells)
            fails[key] = fails.get(key, 0) + 1
        return {"coef": fit.coef, "chol": chol, "pairs": pair_list, "cells": cells,
                "cell_fails": fails}  # fmt: skip

    def _model(self) -> dict[str, Any]:
        if self._fit is None or self._fit[0] != len(self.obs):
            self._fit = (len(self.obs), self._fit_model())
        return self._fit[1]

    # -- asking ---------------------------------------------------------------------------
    def _coverage_ask(self) -> bool:
        i = self.asked
        return len(self.obs) < self.warmup or int(self.floor * (i + 1) + 1e-9) > int(
            self.floor * i + 1e-9
        )

    def _least_used(self, rng: np.random.Generator) -> list[int] | None:
        """Per element (random order), a least-generated bin that keeps the partial
        situation allowed; seeded tie-break."""
        constrained = bool(self.hs._constraints)
        for _ in range(MAX_REDRAWS):
            idx = [-1] * self.n_elements
            for e in rng.permutation(self.n_elements).tolist():
                keys = rng.random(self.sizes[e]).tolist()
                ok = []
                for b in range(self.sizes[e]):
                    idx[e] = b
                    if not constrained or self._allowed(idx):
                        ok.append(b)
                idx[e] = min(ok, key=lambda b: (self.counts[e][b], keys[b])) if ok else -1
                if not ok:
                    break
            if min(idx) >= 0 and self._allowed(idx):
                return idx
        return None

    def _model_pick(self, rng: np.random.Generator) -> list[int] | None:
        model = self._model()
        coef = model["coef"] + model["chol"] @ rng.standard_normal(len(model["coef"]))
        cands = rng.integers(0, np.asarray(self.sizes), size=(self.n_candidates, self.n_elements))
        greedy = [
            int(np.argmax(coef[1 + o : 1 + o + s]))
            for o, s in zip(self.offsets, self.sizes, strict=True)
        ]
        cands = np.vstack([cands, greedy])
        allowed = [i for i, row in enumerate(cands.tolist()) if self._allowed(row)]
        if not allowed:
            return None
        scores = self._design(cands[allowed], model["pairs"]) @ coef
        if self.novelty > 0 and model["cells"]:
            seen = model["cell_fails"]
            found = [seen.get(tuple(row[e] for e in model["cells"]), 0) for row in
                     cands[allowed].tolist()]  # fmt: skip
            scores = scores - self.novelty * np.log1p(np.asarray(found, dtype=float))
        return cands[allowed[int(np.argmax(scores))]].tolist()

    def ask(self, rng: np.random.Generator) -> Situation:
        """A coverage ask (least-used bins) or a Thompson draw from the failure model."""
        idx = self._least_used(rng) if self._coverage_ask() else self._model_pick(rng)
        if idx is None:
            raise self._over_constrained()
        for e, i in enumerate(idx):
            self.counts[e][i] += 1
        return self._emit(idx, rng)

    def tell(self, situation: Situation, outcome: Any) -> None:
        """Record a ``pass`` or ``fail`` (errors and timeouts are not judged)."""
        status = getattr(outcome, "status", outcome)
        if status in ("pass", "fail"):
            self.obs.append([*self._bin_index(situation), int(status == "fail")])

    # -- state ----------------------------------------------------------------------------
    def _state_body(self) -> dict[str, Any]:
        return {"counts": self._dump_counts(self.counts), "observations": self.obs}

    def _load_body(self, body: dict[str, Any]) -> None:
        self.counts = self._load_counts(body["counts"])
        obs = body.get("observations")
        width = self.n_elements + 1
        if not isinstance(obs, list) or any(
            not isinstance(o, list) or len(o) != width for o in obs
        ):
            raise ConfigError(
                field="generator state.observations", value=type(obs).__name__,
                expected=f"a list of [bin index x {self.n_elements}, 0|1]",
            )  # fmt: skip
        self.obs = [[int(v) for v in o] for o in obs]
