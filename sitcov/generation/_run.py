"""Asking a generator for a numbered sequence of situations, as a campaign would."""

from __future__ import annotations

import json
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

from sitcov._seeding import ask_rng
from sitcov.errors import ConfigError
from sitcov.generation._base import Generator
from sitcov.hyperspace import Situation


def generate(gen: Generator, n: int, seed: int, start: int = 0) -> Iterator[Situation]:
    """Situations ``start .. start + n - 1``, each asked with ``ask_rng(seed, index)``.

    Generating 50 from index 0, saving the state, restoring it and generating 50 from
    index 50 gives the same 100 situations as generating 100 from index 0.
    """
    if n < 0 or start < 0:
        raise ConfigError(field="n/start", value=(n, start), expected="non-negative integers")
    for index in range(start, start + n):
        yield gen.ask(ask_rng(seed, index))


def parse_options(items: Sequence[str] | None) -> dict[str, Any]:
    """``["t=3", "seed=7", "name=x"]`` -> ``{"t": 3, "seed": 7, "name": "x"}`` (values are
    read as JSON when they parse, else kept as strings)."""
    out: dict[str, Any] = {}
    for item in items or ():
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise ConfigError(field="--option", value=item, expected="KEY=VALUE")
        try:
            out[key] = json.loads(raw)
        except json.JSONDecodeError:
            out[key] = raw
    return out


def save_state(path: str | Path, gen: Generator, *, seed: int, next_index: int) -> None:
    """Write a generator's state with what is needed to continue (temp file + rename)."""
    path = Path(path)
    payload = {
        "generator": gen.name,
        "hyperspace": gen.hyperspace.name,
        "seed": seed,
        "next_index": next_index,
        "state": gen.state(),
    }
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(payload) + "\n", encoding="utf-8")
    tmp.replace(path)


def load_state(path: str | Path) -> dict[str, Any]:
    """Read a file written by :func:`save_state` (ConfigError naming the file if bad)."""
    file = str(path)
    try:
        data = json.loads(Path(path).read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise ConfigError(f"{file}: file not found (expected a generator state file)") from None
    except (OSError, ValueError) as exc:
        raise ConfigError(f"{file}: expected a JSON generator state file, got: {exc}") from None
    keys = ("generator", "seed", "next_index", "state")
    if not isinstance(data, dict) or any(k not in data for k in keys):
        raise ConfigError(file=file, field="(top level)", expected=f"keys {', '.join(keys)}")
    return data
