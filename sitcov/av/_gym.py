"""Deprecated home of the gymnasium environment, now :mod:`sitcov.gym` (gone next release).

The environment runs a simulator, so it moved above :mod:`sitcov.sim`; the stacks must not
depend on the layer that drives them. Until the next release the old names still resolve,
with a :class:`DeprecationWarning` naming the new path: ``from sitcov.av import
TJunctionEnv`` (through :func:`moved_to_gym`) and the entry point that older versions
registered, ``sitcov.av._gym:TJunctionEnv``. The new package is looked up by name, when a
moved name is asked for, so importing :mod:`sitcov.av` never imports it.
"""

from __future__ import annotations

import importlib
import warnings
from typing import Any

#: The package the environment moved to.
NEW_HOME = "sitcov.gym"
#: The names that still resolve at the old paths (the public ones; the old module was private).
MOVED = ("ENV_ID", "PolicyStack", "TJunctionEnv")


def moved_to_gym(module: str, name: str) -> Any:
    """``name`` from :mod:`sitcov.gym`, warning that ``module.name`` is deprecated.

    Raises:
        AttributeError: ``name`` is not one of :data:`MOVED` (nothing is imported then).
    """
    if name not in MOVED:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    warnings.warn(
        f"{module}.{name} moved to {NEW_HOME}.{name}; import it from {NEW_HOME} "
        "(the old path goes in the next release)",
        DeprecationWarning,
        stacklevel=3,
    )
    return getattr(importlib.import_module(NEW_HOME), name)


def __getattr__(name: str) -> Any:
    return moved_to_gym(__name__, name)
