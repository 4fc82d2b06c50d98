"""Simulation backends and the outcome of a run."""

from sitcov.sim._base import STATUSES, Backend, Conditions, Outcome, Trace

__all__ = ["STATUSES", "Backend", "Conditions", "Outcome", "Trace"]
