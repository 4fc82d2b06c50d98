"""AV stacks under test: the black-box interface and the reference modular stack."""

from typing import Any

from sitcov.av._aeb import aeb_test
from sitcov.av._base import (
    OBSERVATION_KINDS,
    AVStack,
    Control,
    EgoState,
    Observation,
    RunInfo,
)
from sitcov.av._external import ExternalProcessStack, external_stack
from sitcov.av._factory import make_stack
from sitcov.av._faults import DEFAULT_PARAMS, FAULT_DESCRIPTIONS, FAULTS, resolve_params
from sitcov.av._pid import LateralPID, LongitudinalPID, heading_error
from sitcov.av._reference import LatchedReferenceStack, NoPerceptionStack, ReferenceStack

__all__ = [
    "DEFAULT_PARAMS",
    "FAULTS",
    "FAULT_DESCRIPTIONS",
    "OBSERVATION_KINDS",
    "AVStack",
    "Control",
    "EgoState",
    "ExternalProcessStack",
    "LateralPID",
    "LongitudinalPID",
    "LatchedReferenceStack",
    "NoPerceptionStack",
    "Observation",
    "ReferenceStack",
    "RunInfo",
    "aeb_test",
    "external_stack",
    "heading_error",
    "make_stack",
    "resolve_params",
]

# The gymnasium environment and PolicyStack moved to ``sitcov.gym`` (they run a simulator,
# which stands above the stacks); the old names resolve until the next release, with a
# DeprecationWarning (sitcov/av/_gym.py).


def __getattr__(name: str) -> Any:
    from sitcov.av._gym import moved_to_gym

    return moved_to_gym(__name__, name)
