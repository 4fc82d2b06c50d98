"""Simulation backends and the outcome of a run."""

from __future__ import annotations

from typing import Any

from sitcov import _plugins
from sitcov.sim._adversary import AdversaryController, AdversaryParams, arrival_time, pure_pursuit
from sitcov.sim._base import STATUSES, WORLD_MODEL_VERSION, Backend, Outcome, Trace
from sitcov.sim._judge import FAILURE_KINDS, JUDGES, OUTCOME_KINDS, Judge, normalize_judge
from sitcov.weather import PHYSICS_PROFILES, Conditions, conditions_from_values

_plugins.register_builtin("backend", "embedded", "sitcov.sim.embedded:EmbeddedBackend")
_plugins.register_builtin("backend", "carla", "sitcov.sim.carla:CarlaBackend")
_plugins.register_builtin("backend", "esmini", "sitcov.sim.esmini:EsminiBackend")


def make_backend(name: str = "embedded", **options: Any) -> Backend:
    """Create a backend by registered name, entry point or ``module:Class`` path.

    Raises:
        UnknownPluginError: no such backend. ConfigError: it rejected an option.
    """
    cls = _plugins.load("backend", name, Backend)
    try:
        return cls(**options)
    except TypeError as exc:
        from sitcov.errors import ConfigError

        raise ConfigError(f"backend {name!r}: invalid options {sorted(options)}: {exc}") from None


__all__ = [
    "FAILURE_KINDS",
    "JUDGES",
    "OUTCOME_KINDS",
    "PHYSICS_PROFILES",
    "STATUSES",
    "WORLD_MODEL_VERSION",
    "AdversaryController",
    "AdversaryParams",
    "Backend",
    "Conditions",
    "Judge",
    "Outcome",
    "Trace",
    "arrival_time",
    "conditions_from_values",
    "make_backend",
    "normalize_judge",
    "pure_pursuit",
]
