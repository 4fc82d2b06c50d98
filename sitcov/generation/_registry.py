"""Generators by name: the built-ins, entry points (``sitcov.generators``) or ``module:Class``."""

from __future__ import annotations

from typing import Any

from sitcov import _plugins
from sitcov.generation._base import Generator
from sitcov.generation._common import check_options
from sitcov.hyperspace import Hyperspace, load_hyperspace

#: Built-in generator names, in the order the docs and benchmarks list them.
GENERATOR_NAMES = ("random", "sitcov", "sitcov-min", "tway", "failure-guided", "surrogate")

for _name, _path in {
    "random": "sitcov.generation._random:RandomGenerator",
    "sitcov": "sitcov.generation._sitcov:SitCovGenerator",
    "sitcov-min": "sitcov.generation._sitcov_min:SitCovMinGenerator",
    "tway": "sitcov.generation._tway:TWayGenerator",
    "failure-guided": "sitcov.generation._failure_guided:FailureGuidedGenerator",
    "surrogate": "sitcov.generation._surrogate:SurrogateGenerator",
    "nsga2": "sitcov.generation._nsga2:NSGA2Generator",  # needs the search extra (pymoo)
}.items():
    _plugins.register_builtin("generator", _name, _path)


def generator_class(name: str) -> type[Generator]:
    """The class registered as ``name`` (UnknownPluginError listing the known names)."""
    return _plugins.load("generator", name, Generator)


def make_generator(
    name: str, hyperspace: Hyperspace | str | None = None, **options: Any
) -> Generator:
    """A fresh generator.

    Args:
        name: ``random``, ``sitcov``, ``sitcov-min``, ``tway``, ``failure-guided``,
            ``surrogate``, an entry point name, or ``module:Class``.
        hyperspace: a Hyperspace, or what :func:`load_hyperspace` accepts (None = default).
        **options: generator options (e.g. ``t=3`` for tway); unknown ones are a ConfigError.
    """
    cls = generator_class(name)
    check_options(cls, options)
    return cls(load_hyperspace(hyperspace), **options)


def restore_generator(
    name: str, hyperspace: Hyperspace | str | None, state: dict[str, Any]
) -> Generator:
    """Rebuild a generator from its saved ``state()`` so that it continues exactly."""
    return generator_class(name).from_state(load_hyperspace(hyperspace), state)
