"""A concrete situation: one bin per element, plus the concrete value drawn for it."""

from __future__ import annotations

import hashlib
import json
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any


def canonical_json(obj: Any) -> str:
    """JSON with sorted keys and no whitespace: the same text on every machine."""
    return json.dumps(
        obj, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False
    )


def _freeze(value: Any) -> Any:
    if isinstance(value, Mapping):
        return MappingProxyType({k: _freeze(v) for k, v in value.items()})
    if isinstance(value, list | tuple):
        return tuple(_freeze(v) for v in value)
    return value


def _thaw(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {k: _thaw(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_thaw(v) for v in value]
    return value


@dataclass(frozen=True)
class Situation(Mapping[str, str]):
    """An immutable mapping element name -> bin label, with the concrete values.

    Backends read ``values`` (numbers in the element's unit, or a category's value,
    which may be a mapping such as an intersection situation's routes); generators
    and analysis read ``bins``. ``id`` is a 16-hex-digit hash of both, stable across
    machines and Python versions.

    Args:
        bins: element name -> bin label, in hyperspace order.
        values: element name -> concrete value (JSON-serialisable).
    """

    bins: Mapping[str, str]
    values: Mapping[str, Any]
    id: str = field(init=False)

    def __post_init__(self) -> None:
        if set(self.bins) != set(self.values):
            raise ValueError("Situation: bins and values must name the same elements")
        object.__setattr__(self, "bins", MappingProxyType(dict(self.bins)))
        object.__setattr__(
            self, "values", MappingProxyType({k: _freeze(v) for k, v in self.values.items()})
        )
        digest = hashlib.sha256(
            canonical_json({"bins": dict(self.bins), "values": _thaw(self.values)}).encode()
        )
        object.__setattr__(self, "id", digest.hexdigest()[:16])

    @classmethod
    def _trusted(cls, bins: dict[str, str], values: dict[str, Any], id: str) -> Situation:
        """Build without validating or hashing (the generators' hot path).

        The caller guarantees that ``values`` are already frozen, that ``bins`` and ``values``
        name the same elements, and that ``id`` equals what ``Situation(bins, values).id``
        would compute (``sitcov.hyperspace.Hyperspace`` assembles the same canonical JSON
        from precomputed fragments; a test checks the two agree).
        """
        obj = object.__new__(cls)
        object.__setattr__(obj, "bins", MappingProxyType(bins))
        object.__setattr__(obj, "values", MappingProxyType(values))
        object.__setattr__(obj, "id", id)
        return obj

    def __getitem__(self, element: str) -> str:
        return self.bins[element]

    def __iter__(self) -> Iterator[str]:
        return iter(self.bins)

    def __len__(self) -> int:
        return len(self.bins)

    def __hash__(self) -> int:
        return hash(self.id)

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Situation) and other.id == self.id

    def value(self, element: str, default: Any = None) -> Any:
        """The concrete value of ``element``, or ``default`` if the element is absent."""
        return self.values.get(element, default)

    def to_dict(self) -> dict[str, Any]:
        """The JSON form printed by ``sitcov generate`` and stored with each run."""
        return {"id": self.id, "bins": dict(self.bins), "values": _thaw(self.values)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> Situation:
        """Inverse of :meth:`to_dict`; the id is recomputed (and checked if given)."""
        situation = cls(bins=data["bins"], values=data["values"])
        if "id" in data and data["id"] != situation.id:
            raise ValueError(f"situation id {data['id']} does not match its content")
        return situation


#: T-junction legs: entry leg of the ego -> the leg on its left / on its right (leg B is the
#: stem; from L the stem is on the right, from R on the left; tests/av/test_plugins.py).
_ON_LEFT = {"B": "L", "R": "B"}
_ON_RIGHT = {"B": "R", "L": "B"}


def approach_side(bins: Mapping[str, Any], values: Mapping[str, Any]) -> str:
    """Where the conflicting road user comes from, seen by the ego: ``left``, ``right`` or
    ``ahead`` (from the situation's ``intsit`` routes, entry legs of the T-junction);
    ``other`` when the situation names no such routes."""
    intsit = values.get("intsit")
    if not isinstance(intsit, Mapping) or "ego" not in intsit or "ov" not in intsit:
        return "other"
    ego, ov = str(intsit["ego"])[:1], str(intsit["ov"])[:1]
    if _ON_LEFT.get(ego) == ov:
        return "left"
    if _ON_RIGHT.get(ego) == ov:
        return "right"
    return "ahead"
