"""Fixtures of the report tests."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from sitcov.campaign import open_store


@pytest.fixture
def make_db(tmp_path: Path):
    """Factory: ``make_db(name, build)`` -> path of a store filled by ``build(store)``."""

    def factory(filename: str, build: Callable[[Any], None]) -> Path:
        path = tmp_path / filename
        store = open_store(path)
        try:
            build(store)
        finally:
            store.close()
        return path

    return factory
