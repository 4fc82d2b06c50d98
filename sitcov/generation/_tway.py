"""tway: a t-way covering array (covertable), then the least-covered combinations.

The array is built by ``covertable.make`` with its deterministic ``hash`` sorter; the
``salt`` (from the ``seed`` option, or drawn from the rng of the first ask) varies the
array between campaigns. covertable touches no global random state with this sorter.
Constraints are passed to covertable as declarative ``not(and(in ...))`` conditions and
every row is checked again against the hyperspace. Once the rows are used up, each ask
builds a few greedy candidates and returns the one that covers the most of the
least-seen t-way combinations (random order and ties from the ask's rng).
"""

from __future__ import annotations

import itertools
import math
from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.generation._common import MAX_REDRAWS, ComboCounts, IndexedGenerator
from sitcov.hyperspace import Hyperspace, Situation

#: Greedy candidates compared per ask after the covering array is used up.
N_CANDIDATES = 8


def covering_array(hyperspace: Hyperspace, t: int, salt: str) -> list[list[int]]:
    """Rows of bin indices covering every allowed t-way combination (covertable)."""
    from covertable import make, sorters

    factors = {f"f{e}": list(range(n)) for e, n in enumerate(hyperspace.sizes)}
    constraints = [
        {
            "operator": "not",
            "condition": {
                "operator": "and",
                "conditions": [
                    {"operator": "in", "left": f"f{e}", "values": sorted(forbidden)}
                    for e, forbidden in c
                ],
            },
        }
        for c in hyperspace._constraints
    ]
    rows = make(
        factors,
        strength=t,
        sorter=sorters.hash,
        salt=salt,
        constraints=constraints or None,
    )
    out = []
    for row in rows:
        idx = [int(row[f"f{e}"]) for e in range(len(hyperspace.sizes))]
        if hyperspace._allowed_indices(idx):
            out.append(idx)
    if t == 2:
        rebalance(hyperspace, out)
    return out


def rebalance(hyperspace: Hyperspace, rows: list[list[int]], passes: int = 4) -> None:
    """Even out the per-bin counts of a pairwise covering array in place.

    covertable fills the cells no pair needs ("don't care" cells) with each element's
    first bin, so low bins are over-used. A cell is moved to a less-used bin whenever every
    pair it currently covers is also covered by another row, so coverage and constraints
    are kept. Deterministic: rows, elements and bins are visited in order.
    """
    sizes = hyperspace.sizes
    n = len(sizes)
    counts = [[0] * k for k in sizes]
    pairs: dict[tuple[int, int, int, int], int] = {}

    def key(e: int, b: int, f: int, c: int) -> tuple[int, int, int, int]:
        return (e, b, f, c) if e < f else (f, c, e, b)

    for row in rows:
        for e in range(n):
            counts[e][row[e]] += 1
            for f in range(e + 1, n):
                k = (e, row[e], f, row[f])
                pairs[k] = pairs.get(k, 0) + 1
    for _ in range(passes):
        moved = False
        for row in rows:
            for e in range(n):
                cur = row[e]
                if any(pairs[key(e, cur, f, row[f])] < 2 for f in range(n) if f != e):
                    continue  # the cell is needed for a pair no other row covers
                for b in sorted(range(sizes[e]), key=lambda x: (counts[e][x], x)):
                    if counts[e][b] >= counts[e][cur] - 1:
                        break
                    row[e] = b
                    if not hyperspace._allowed_indices(row):
                        row[e] = cur
                        continue
                    for f in range(n):
                        if f != e:
                            pairs[key(e, cur, f, row[f])] -= 1
                            k = key(e, b, f, row[f])
                            pairs[k] = pairs.get(k, 0) + 1
                    counts[e][cur] -= 1
                    counts[e][b] += 1
                    moved = True
                    break
        if not moved:
            break


#: Most t-way bin combinations a covering array is built for (t=3 on the default
#: hyperspace has 24,192 and takes ~7 s; t=4 has 235,872 and takes minutes).
MAX_COMBINATIONS = 50_000


class TWayGenerator(IndexedGenerator):
    """t-way combinatorial coverage (default pairwise).

    Args:
        hyperspace: the hyperspace.
        t: strength (2 = every pair of bins of every two elements).
        seed: salt of the covering array; None draws it from the first ask's rng.
    """

    name = "tway"

    def __init__(self, hyperspace: Hyperspace, *, t: int = 2, seed: int | None = None) -> None:
        if not isinstance(t, int) or not 1 <= t <= len(hyperspace.sizes):
            raise ConfigError(
                field="generator 'tway' option t",
                value=t,
                expected=f"an integer in 1..{len(hyperspace.sizes)}",
            )
        n_combinations = sum(math.prod(c) for c in itertools.combinations(hyperspace.sizes, t))
        if n_combinations > MAX_COMBINATIONS:
            raise ConfigError(
                f"generator 'tway' option t={t}: the hyperspace has {n_combinations:,} {t}-way bin"
                f" combinations, more than the {MAX_COMBINATIONS:,} a covering array can be built"
                " for in reasonable time; use a smaller t or fewer/smaller elements"
            )
        super().__init__(hyperspace, t=t, seed=seed)
        self.t = t
        self.salt: str | None = None if seed is None else str(int(seed))
        self.rows: list[list[int]] | None = None
        self.position = 0
        self.combos = ComboCounts(self.sizes, t)

    @property
    def array_size(self) -> int | None:
        """Rows in the covering array (None until the first ask builds it)."""
        return None if self.rows is None else len(self.rows)

    def ask(self, rng: np.random.Generator) -> Situation:
        """The next covering-array row, or once used up the best greedy candidate."""
        if self.rows is None:
            if self.salt is None:
                self.salt = str(int(rng.integers(0, 2**31)))
            self.rows = covering_array(self.hs, self.t, self.salt)
        if self.position < len(self.rows):
            idx = self.rows[self.position]
            self.position += 1
        else:
            idx = self._least_covered(rng)
        self.combos.add(idx)
        return self._emit(idx, rng)

    def _least_covered(self, rng: np.random.Generator) -> list[int]:
        """Best of :data:`N_CANDIDATES` greedy rows: most combinations at the lowest count,
        then the lowest total count."""
        level = self._level()
        combos = self.combos
        best, best_score = None, None
        found = tries = 0
        while found < N_CANDIDATES and tries < MAX_REDRAWS:
            tries += 1
            idx = self._candidate(rng)
            if idx is None or not self._allowed(idx):
                continue
            found += 1
            values = [combos.table[sub][combos.flat(sub, idx)] for sub in combos.subsets]
            score = (-sum(1 for v in values if v == level), sum(values))
            if best_score is None or score < best_score:
                best, best_score = idx, score
        if best is None:
            raise self._over_constrained()
        return best

    def _level(self) -> int:
        """Lowest count among the combinations seen at least once.

        The covering array covers every allowed combination, so after it the combinations
        still at 0 are exactly the forbidden ones and must not hold the level down.
        """
        return min((x for v in self.combos.table.values() for x in v if x > 0), default=0)

    def _candidate(self, rng: np.random.Generator) -> list[int] | None:
        """One greedy row: elements in random order, each taking the bin whose completed
        combinations with the bins already chosen have the lowest total count."""
        n = self.n_elements
        order = rng.permutation(n).tolist()
        keys = rng.random((n, max(self.sizes))).tolist()
        idx = [-1] * n
        combos = self.combos
        constrained = bool(self.hs._constraints)
        for e in order:
            best, best_score = None, None
            # each completed combination: (its table, offset of the other bins, stride of e)
            parts = []
            for s in combos.by_element[e]:
                if all(idx[f] >= 0 for f in s if f != e):
                    st = combos.strides[s]
                    base = sum(idx[f] * st[f] for f in s if f != e)
                    parts.append((combos.table[s], base, st[e]))
            for b in range(self.sizes[e]):
                idx[e] = b
                if constrained and not self._allowed(idx):
                    continue
                used = sum(table[base + b * k] for table, base, k in parts)
                score = (used, keys[e][b])
                if best_score is None or score < best_score:
                    best, best_score = b, score
            if best is None:
                return None
            idx[e] = best
        return idx

    def _state_body(self) -> dict[str, Any]:
        return {
            "salt": self.salt,
            "rows": self.rows,
            "position": self.position,
            "combos": self.combos.dump(),
        }

    def _load_body(self, body: dict[str, Any]) -> None:
        self.salt = body["salt"]
        self.rows = None if body["rows"] is None else [list(map(int, r)) for r in body["rows"]]
        self.position = int(body["position"])
        self.combos.load(body["combos"])
