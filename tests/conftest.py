"""Shared fixtures for the test suite (and ``needs``, importable from every test folder)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

_TESTS = str(Path(__file__).resolve().parent)
if _TESTS not in sys.path:
    sys.path.append(_TESTS)  # ``from needs import ...`` (tests/needs.py) in any folder


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator; tests never use global random state."""
    return np.random.default_rng(12345)
