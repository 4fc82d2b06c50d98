"""Experiments refuse to report on campaigns that measured nothing.

A campaign whose every finished run ended in ``error`` or ``timeout`` judged no run: its
failure count is 0 out of nothing, which a table would show as "0/4, 0 %" (issue 26: a
backend that raises made ``experiment faults`` exit 0 with such a table). The experiments
call :func:`require_judged` after running, and the CLI turns the error into one line.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from sitcov.errors import SitcovError


class NothingJudgedError(SitcovError):
    """Every finished run of a campaign of an experiment ended in error or timeout."""


def require_judged(store: Any, campaigns: Iterable[str], experiment: str) -> None:
    """Raise :class:`NothingJudgedError` for the first of ``campaigns`` with finished runs
    but none judged (pass or fail); the message quotes the first line of its first run's
    error (``Type: message``, see ``sitcov.campaign._executors.error_message``)."""
    for name in campaigns:
        counts = store.status_counts(name)
        unjudged = counts["error"] + counts["timeout"]
        if not unjudged or counts["pass"] + counts["fail"]:
            continue
        first = next(iter(store.iter_runs(name, ("error", "timeout"))), None)
        said = ""
        if first is not None:
            message = (first.outcome.message if first.outcome else None) or first.status
            lines = [line.strip() for line in message.splitlines() if line.strip()]
            said = f"; the first ({name}:{first.index}) said: {(lines or [''])[0][:200]}"
        raise NothingJudgedError(
            f"{store.location}: experiment {experiment}: all {unjudged} runs of campaign "
            f"{name!r} ended in error or timeout, so it measured nothing{said}"
        )
