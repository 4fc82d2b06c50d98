"""What the built-in generators share: integer bin indices, state checks, redraws, counts.

Generators work on bin *indices* (element order of the hyperspace) and build the situation
only at the end through the hyperspace's precomputed tables, which keeps ``ask`` cheap.
"""

from __future__ import annotations

import inspect
from collections.abc import Sequence
from itertools import combinations
from typing import Any, ClassVar

import numpy as np

from sitcov.errors import ConfigError, SitcovError
from sitcov.generation._base import Generator
from sitcov.hyperspace import Hyperspace, Situation

#: How many times ``ask`` redraws a whole situation that breaks a constraint before giving
#: up with :class:`OverConstrainedError` (each redraw uses the same rng, so it is deterministic).
MAX_REDRAWS = 1000

STATE_VERSION = 1


class OverConstrainedError(SitcovError):
    """No allowed situation was found within :data:`MAX_REDRAWS` draws."""

    def __init__(self, generator: str, hyperspace: Hyperspace) -> None:
        super().__init__(
            f"generator {generator!r}: no allowed situation after {MAX_REDRAWS} draws in "
            f"hyperspace {hyperspace.name!r} ({hyperspace.n_situations} allowed situations): "
            "its constraints "
            "forbid almost every combination; relax them"
        )


class IndexedGenerator(Generator):
    """Base of the built-in generators: options, state envelope and situation building.

    Subclasses set ``name``, list their options in ``__init__``'s keyword arguments, and
    implement ``_state_body`` / ``_load_body`` for what they add to the state.
    """

    name: ClassVar[str] = ""

    def __init__(self, hyperspace: Hyperspace, **options: Any) -> None:
        super().__init__(hyperspace)
        self.hs = hyperspace
        self.sizes: tuple[int, ...] = hyperspace.sizes
        self.n_elements = len(self.sizes)
        self.options: dict[str, Any] = dict(options)
        #: number of situations returned by ``ask`` so far (the next run index when the
        #: campaign asks one per run).
        self.asked = 0

    # -- helpers for subclasses ----------------------------------------------------------
    def _emit(self, idx: Sequence[int], rng: np.random.Generator) -> Situation:
        self.asked += 1
        return self.hs._situation(idx, rng)

    def _allowed(self, idx: Sequence[int]) -> bool:
        return self.hs._allowed_indices(idx)

    def _over_constrained(self) -> OverConstrainedError:
        return OverConstrainedError(self.name, self.hs)

    def _bin_index(self, situation: Situation) -> list[int]:
        return self.hs._indices(situation.bins)

    # -- state -------------------------------------------------------------------------------
    def _state_body(self) -> dict[str, Any]:
        return {}

    def _load_body(self, body: dict[str, Any]) -> None:
        """Restore what ``_state_body`` saved."""

    def state(self) -> dict[str, Any]:
        """JSON-serialisable state; :meth:`from_state` continues exactly from here."""
        return {
            "version": STATE_VERSION,
            "generator": self.name,
            "hyperspace": self.hs.name,
            "elements": {e.name: list(e.labels) for e in self.hs.elements},
            "options": dict(self.options),
            "asked": self.asked,
            **self._state_body(),
        }

    @classmethod
    def from_state(cls, hyperspace: Hyperspace, state: dict[str, Any]) -> Generator:
        """Rebuild the generator; ConfigError if the state belongs to another generator or
        to a hyperspace with different elements or bins."""
        if not isinstance(state, dict) or state.get("generator") != cls.name:
            got = state.get("generator") if isinstance(state, dict) else state
            raise ConfigError(field="generator state", value=got, expected=f"a {cls.name!r} state")
        if state.get("version") != STATE_VERSION:
            raise ConfigError(
                field="generator state.version", value=state.get("version"), expected="1"
            )
        elements = {e.name: list(e.labels) for e in hyperspace.elements}
        if state.get("elements") != elements:
            raise ConfigError(
                field="generator state.elements",
                value=list(state.get("elements") or {}),
                expected=f"the elements and bins of hyperspace {hyperspace.name!r}",
            )
        gen = cls(hyperspace, **state.get("options", {}))
        gen.asked = int(state["asked"])
        gen._load_body(state)
        return gen

    # -- counts as {element: [count per bin]} ------------------------------------------------
    def _dump_counts(self, counts: list[list[int]]) -> dict[str, list[int]]:
        return {name: list(c) for name, c in zip(self.hs.element_names, counts, strict=True)}

    def _load_counts(self, data: dict[str, list[int]]) -> list[list[int]]:
        return [[int(x) for x in data[name]] for name in self.hs.element_names]


def check_options(cls: type[Generator], options: dict[str, Any]) -> None:
    """ConfigError naming the generator, the bad option and the allowed ones.

    A class whose ``__init__`` takes only ``**options`` accepts anything (third-party plugins).
    """
    params = list(inspect.signature(cls.__init__).parameters.values())
    named = [p.name for p in params[2:] if p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)]
    if not named and any(p.kind == p.VAR_KEYWORD for p in params):
        return
    for key in options:
        if key not in named:
            raise ConfigError(
                field=f"generator {getattr(cls, 'name', cls.__name__)!r} option",
                value=key,
                expected=f"one of: {', '.join(named)}" if named else "no options",
            )


class ComboCounts:
    """How often each t-way bin combination has been chosen (t = 2 for pairs).

    Stored per element subset as a flat list indexed by the mixed-radix bin tuple.
    """

    def __init__(self, sizes: Sequence[int], t: int = 2) -> None:
        self.sizes = tuple(sizes)
        self.t = t
        self.subsets: list[tuple[int, ...]] = list(combinations(range(len(sizes)), t))
        self.table: dict[tuple[int, ...], list[int]] = {}
        for sub in self.subsets:
            n = 1
            for e in sub:
                n *= sizes[e]
            self.table[sub] = [0] * n
        #: per subset, element -> stride of its bin index in the flat table
        self.strides: dict[tuple[int, ...], dict[int, int]] = {}
        for sub in self.subsets:
            stride, st = 1, {}
            for e in reversed(sub):
                st[e] = stride
                stride *= sizes[e]
            self.strides[sub] = st
        #: for each element, the subsets it belongs to
        self.by_element: list[list[tuple[int, ...]]] = [
            [s for s in self.subsets if e in s] for e in range(len(sizes))
        ]

    def flat(self, sub: tuple[int, ...], idx: Sequence[int]) -> int:
        """Flat position of the bins ``idx[e]`` (e in ``sub``) in ``table[sub]``."""
        pos = 0
        for e in sub:
            pos = pos * self.sizes[e] + idx[e]
        return pos

    def add(self, idx: Sequence[int]) -> None:
        """Count every t-combination of a full situation."""
        for sub in self.subsets:
            self.table[sub][self.flat(sub, idx)] += 1

    def dump(self) -> dict[str, list[int]]:
        """JSON form: keys like ``"0,3"`` (element indices)."""
        return {",".join(map(str, s)): list(v) for s, v in self.table.items()}

    def load(self, data: dict[str, list[int]]) -> None:
        """Inverse of :meth:`dump`."""
        for key, values in data.items():
            sub = tuple(int(x) for x in key.split(","))
            if sub not in self.table or len(values) != len(self.table[sub]):
                raise ConfigError(
                    field="generator state.combos", value=key, expected="valid counts"
                )
            self.table[sub] = [int(v) for v in values]
