"""Fuzz tests: Hypothesis profiles and the "one clear line, never a traceback" check.

Profiles: ``fuzz`` (default; few examples, derandomized, so CI is fast and repeatable) and
``fuzz-long`` (``SITCOV_FUZZ=long``: many random examples, for a hunt before a release)::

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

_COMMON = {
    "deadline": None,  # machines are shared: time per example is bounded by no_hang below
    "suppress_health_check": [HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
    "database": None,
}
settings.register_profile("fuzz", max_examples=40, derandomize=True, **_COMMON)
settings.register_profile("fuzz-long", max_examples=2000, **_COMMON)
LONG = os.environ.get("SITCOV_FUZZ") == "long"
settings.load_profile("fuzz-long" if LONG else "fuzz")
#: Examples of the fuzz tests that start a process per example.
PROCESS_EXAMPLES = 300 if LONG else 12

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
