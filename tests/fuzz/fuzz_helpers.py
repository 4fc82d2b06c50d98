"""Helpers of the fuzz tests: settings, and the "one clear line, never a traceback, never a
hang" check.

Two sizes (settings applied per test, so other Hypothesis tests of the suite keep theirs):
the default (few examples, derandomized: CI is fast and repeatable) and the long hunt
(``SITCOV_FUZZ=long``: many random examples, before a release)::

    SITCOV_FUZZ=long python -m pytest -q tests/fuzz
"""

from __future__ import annotations

import os
import signal
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

from hypothesis import HealthCheck, settings

from sitcov.errors import SitcovError

#: The long profile (``SITCOV_FUZZ=long``, see conftest.py) is active.
LONG = os.environ.get("SITCOV_FUZZ") == "long"


def fuzz_settings(examples: int = 40, long_examples: int = 2000) -> settings:
    """Hypothesis settings of a fuzz test: ``examples`` derandomized, or ``long_examples``
    random ones under ``SITCOV_FUZZ=long``; no per-example deadline (shared machines: a hang
    is caught by :func:`no_hang` instead)."""
    return settings(
        max_examples=long_examples if LONG else examples,
        derandomize=not LONG,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    )


#: Seconds one example may take before it counts as a hang.
HANG = 20


@contextmanager
def no_hang(seconds: float = HANG) -> Iterator[None]:
    """Fail (TimeoutError) if the block takes longer than ``seconds`` (SIGALRM, main thread)."""

    def expired(signum: int, frame: Any) -> None:
        raise TimeoutError(f"no answer within {seconds:g} s: a hang")

    previous = signal.signal(signal.SIGALRM, expired)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def ok_or_one_line(call: Callable[[], Any], *mentions: str) -> str:
    """Run ``call``: ``"ok"``, or ``"error"`` if it raised a SitcovError whose message is one
    non-empty line mentioning one of ``mentions`` (if given). Anything else propagates."""
    try:
        with no_hang():
            call()
    except SitcovError as exc:
        message = str(exc)
        assert message.strip() and "\n" not in message, repr(message)
        assert len(message) < 2000, f"a {len(message)}-character error message"
        if mentions:
            assert any(m in message for m in mentions), message
        return "error"
    return "ok"
