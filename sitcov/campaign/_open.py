"""Opening a store by path: the one place that knows the store implementations."""

from __future__ import annotations

from pathlib import Path

from sitcov.campaign._memory import MemoryStore
from sitcov.campaign._sqlite import SQLiteStore
from sitcov.campaign._store import Store


def open_store(path: str | Path | None) -> Store:
    """Open (creating if needed) the store at ``path``; None gives an in-memory store.

    Args:
        path: a SQLite file path, ``":memory:"`` or None.

    Raises:
        StoreError: the file is not a sitcov store, or was written by a newer sitcov.
    """
    if path is None or str(path) == ":memory:":
        return MemoryStore()
    return SQLiteStore(Path(path))
