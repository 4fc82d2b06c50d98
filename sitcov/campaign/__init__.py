"""Campaigns: configuration, the run loop, executors, the store and experiments."""

from sitcov.campaign._records import RunRecord

__all__ = ["RunRecord"]
