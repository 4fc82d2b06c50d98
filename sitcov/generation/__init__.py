"""Situation generators behind one ask/tell interface."""

from sitcov.generation._base import Generator
from sitcov.generation._common import MAX_REDRAWS, OverConstrainedError
from sitcov.generation._failure_guided import FailureGuidedGenerator
from sitcov.generation._random import RandomGenerator
from sitcov.generation._registry import (
    GENERATOR_NAMES,
    generator_class,
    make_generator,
    restore_generator,
)
from sitcov.generation._run import generate, load_state, parse_options, save_state
from sitcov.generation._sitcov import SitCovGenerator, sitcov_probabilities
from sitcov.generation._sitcov_min import SitCovMinGenerator
from sitcov.generation._surrogate import SurrogateGenerator
from sitcov.generation._tway import TWayGenerator

__all__ = [
    "GENERATOR_NAMES",
    "MAX_REDRAWS",
    "FailureGuidedGenerator",
    "Generator",
    "OverConstrainedError",
    "RandomGenerator",
    "SitCovGenerator",
    "SitCovMinGenerator",
    "SurrogateGenerator",
    "TWayGenerator",
    "generate",
    "generator_class",
    "load_state",
    "make_generator",
    "parse_options",
    "restore_generator",
    "save_state",
    "sitcov_probabilities",
]
