"""The situation hyperspace: axes, elements, bins, constraints, and concrete situations."""

from sitcov.hyperspace._situation import Situation, canonical_json

__all__ = ["Situation", "canonical_json"]
