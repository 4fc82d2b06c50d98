"""The exception hierarchy: every error sitcov raises on purpose derives from SitcovError.

The CLI catches SitcovError and prints its message on one line; anything else is a bug.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any


class SitcovError(Exception):
    """Root of all deliberate sitcov errors; the message is meant for the user."""


class ConfigError(SitcovError, ValueError):
    """A configuration or data file (or argument) is invalid.

    The message names the file, the field path, the value given and what was expected,
    in the form ``FILE: FIELD: expected EXPECTATION, got VALUE``.
    """

    def __init__(
        self,
        message: str | None = None,
        *,
        file: str | None = None,
        field: str | None = None,
        value: Any = None,
        expected: str | None = None,
    ) -> None:
        self.file, self.field, self.value, self.expected = file, field, value, expected
        if message is None:
            parts = [p for p in (file, field) if p]
            head = ": ".join(parts) + ": " if parts else ""
            got = f", got {_plain(value)!r}" if value is not None else ""
            message = f"{head}expected {expected}{got}"
        # keys and values come from users' files: a line break in one must not split the line
        super().__init__(message.replace("\r", "\\r").replace("\n", "\\n"))


def _plain(value: Any) -> Any:
    """``value`` as the user wrote it: frozen mappings (``mappingproxy``) and tuples of a
    hyperspace's category values shown as plain dicts and lists."""
    if isinstance(value, Mapping):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, tuple):
        return [_plain(v) for v in value]
    return value


class UnknownPluginError(ConfigError):
    """A named generator, backend, AV stack or fault does not exist."""

    def __init__(self, kind: str, name: str, known: list[str]) -> None:
        super().__init__(
            f"unknown {kind} {name!r}; expected one of: {', '.join(sorted(known))}",
            field=kind,
            value=name,
            expected=" | ".join(sorted(known)),
        )


class SetupError(SitcovError):
    """The campaign cannot run at all (a model or an optional package is missing).

    Unlike an error of one run, this stops a campaign at once: the executors re-raise it
    instead of storing every run as ``error``, and the CLI prints its one-line message.
    """


class MissingExtraError(SetupError, ImportError):
    """An optional dependency is needed but not installed."""

    def __init__(self, feature: str, extra: str, module: str) -> None:
        super().__init__(
            f"{feature} needs the optional package {module!r}: pip install 'sitcov[{extra}]'"
        )


class BackendUnavailableError(SitcovError):
    """A simulation backend cannot be reached (e.g. no CARLA server)."""


class StackError(SitcovError):
    """The AV stack under test failed during a run: it crashed, broke the protocol or raised.

    Raised from ``AVStack.reset``/``step`` by the black-box adapters (external processes);
    the campaign stores the run with the status given by :attr:`status` instead of
    aborting, and the next run starts with a fresh stack process.
    """

    #: The status the campaign stores for a run that raised this error.
    status = "error"


class StackTimeoutError(StackError):
    """The AV stack under test did not answer within its wall-clock time-out.

    The campaign stores the run as ``timeout`` (see :attr:`StackError.status`).
    """

    status = "timeout"
