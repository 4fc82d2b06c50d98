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


def moved_to_gym(module: str, name: str) -> Any:
    """``name`` from :mod:`sitcov.gym`, warning that ``module.name`` is deprecated.

    Raises:
        AttributeError: :mod:`sitcov.gym` has no public ``name``.
    """
    new = importlib.import_module(NEW_HOME)
    if name not in new.__all__:
        raise AttributeError(f"module {module!r} has no attribute {name!r}")
    warnings.warn(
        f"{module}.{name} moved to {NEW_HOME}.{name}; import it from {NEW_HOME} "
        "(the old path goes in the next release)",
        DeprecationWarning,
        stacklevel=3,
    )
    return getattr(new, name)


def __getattr__(name: str) -> Any:
    if name.startswith("__"):
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    return moved_to_gym(__name__, name)
