"""The situation hyperspace: axes, elements, bins, constraints, and concrete situations."""

from sitcov.hyperspace._load import DEFAULT_HYPERSPACE, load_hyperspace
from sitcov.hyperspace._situation import Situation, canonical_json
from sitcov.hyperspace._space import Axis, Bin, Constraint, Element, Hyperspace

__all__ = [
    "DEFAULT_HYPERSPACE",
    "Axis",
    "Bin",
    "Constraint",
    "Element",
    "Hyperspace",
    "Situation",
    "canonical_json",
    "load_hyperspace",
]
