"""AV stacks under test: the black-box interface and the reference modular stack."""

from sitcov.av._base import AVStack, Control, EgoState, Observation, RunInfo

__all__ = ["AVStack", "Control", "EgoState", "Observation", "RunInfo"]
