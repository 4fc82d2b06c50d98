"""Situation generators behind one ask/tell interface."""

from sitcov.generation._base import Generator

__all__ = ["Generator"]
