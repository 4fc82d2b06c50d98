"""``make_stack``: an AV stack from a name, an entry point or a ``package.module:Class`` path."""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from typing import Any

from sitcov._plugins import load, register_builtin
from sitcov.av._base import AVStack
from sitcov.errors import ConfigError

register_builtin("av", "reference", "sitcov.av._reference:ReferenceStack")
register_builtin("av", "reference-latched", "sitcov.av._reference:LatchedReferenceStack")
register_builtin("av", "no-perception", "sitcov.av._reference:NoPerceptionStack")


def make_stack(
    spec: str = "reference",
    fault: str | None = None,
    params: Mapping[str, Any] | None = None,
) -> AVStack:
    """Build the AV stack named by ``spec``.

    Args:
        spec: ``"reference"`` (the paper's stack, its AEB releasing),
            ``"reference-latched"`` (its AEB latched, as the paper's),
            ``"no-perception"`` (the same without its brake), an entry point in the
            group ``sitcov.av``, ``package.module:Class``, or ``cmd:COMMAND`` (an
            external process; ``params`` are its options, see ``sitcov.av.external_stack``).
        fault: seeded fault (``f1``/``f2``/``f3``), passed to stacks that accept ``fault``.
        params: parameter overrides, passed to stacks that accept ``params``.

    Raises:
        UnknownPluginError: ``spec`` names no known stack.
        ConfigError: the class is not an AVStack, or it does not accept a given fault/params.
    """
    if spec.startswith("cmd:"):  # an external process speaking protocol v1
        from sitcov.av._external import external_stack

        return external_stack(spec[4:], fault, params)
    cls = load("av", spec, AVStack)
    kwargs: dict[str, Any] = {}
    if fault is not None:
        kwargs["fault"] = fault
    if params:
        kwargs["params"] = dict(params)
    if kwargs:
        try:
            accepted = inspect.signature(cls).parameters
        except (TypeError, ValueError):  # pragma: no cover - builtins without signatures
            accepted = {}
        takes_any = any(p.kind is inspect.Parameter.VAR_KEYWORD for p in accepted.values())
        for key in kwargs:
            if key not in accepted and not takes_any:
                raise ConfigError(
                    f"av stack {spec!r} does not take {key!r} "
                    "(faults and params apply to stacks that accept them, e.g. 'reference')",
                    field=key,
                    value=kwargs[key],
                )
    return cls(**kwargs)
