"""Hypothesis strategies that damage a valid file: structurally (parsed data) or as bytes."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from typing import Any

import yaml
from hypothesis import strategies as st

#: Any value a YAML or JSON file can hold.
VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(min_value=-(10**30), max_value=10**30)
    | st.floats()
    | st.text(max_size=12),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=8,
)

#: A YAML document with exponentially many aliases ("billion laughs").
ALIAS_BOMB = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 9)}]\n" for k in range(8)
)


def _paths(data: Any, here: tuple = ()) -> Iterator[tuple]:
    """Every path (keys and indices) into ``data``, the root excluded."""
    items = (
        data.items()
        if isinstance(data, dict)
        else enumerate(data)
        if isinstance(data, list)
        else ()
    )
    for key, value in items:
        yield (*here, key)
        yield from _paths(value, (*here, key))


def _parent(data: Any, path: tuple) -> Any:
    for key in path[:-1]:
        data = data[key]
    return data


@st.composite
def mutated_data(draw: st.DrawFn, base: Any, max_changes: int = 4) -> Any:
    """``base`` with 1..max_changes of: a value replaced, an entry deleted, a key renamed."""
    data = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, max_changes))):
        paths = list(_paths(data))
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent, key = _parent(data, path), path[-1]
        op = draw(st.sampled_from(["replace", "delete", "rename"]))
        if op == "replace":
            parent[key] = draw(VALUES)
        elif op == "delete":
            del parent[key]
        elif isinstance(parent, dict):
            parent[draw(st.text(min_size=1, max_size=8))] = parent.pop(key)
    return data


@st.composite
def mutated_bytes(draw: st.DrawFn, text: str, max_changes: int = 6) -> bytes:
    """``text`` (UTF-8) with byte flips, insertions, deletions or a truncation."""
    data = bytearray(text.encode())
    for _ in range(draw(st.integers(1, max_changes))):
        pos = draw(st.integers(0, max(0, len(data) - 1)))
        op = draw(st.sampled_from(["flip", "insert", "delete", "truncate"]))
        if op == "flip" and data:
            data[pos] ^= 1 << draw(st.integers(0, 7))
        elif op == "insert":
            data[pos:pos] = draw(
                st.sampled_from(
                    [
                        b":",
                        b"- ",
                        b"{",
                        b"]",
                        b"\n  ",
                        b"&x *x",
                        b"\xff",
                        b"!!python/object:os.system ''",
                    ]
                )
            )
        elif op == "delete":
            del data[pos : pos + draw(st.integers(1, 20))]
        else:
            del data[pos:]
    return bytes(data)


def dump(data: Any) -> str:
    """YAML text of ``data`` (keys in their order)."""
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)
