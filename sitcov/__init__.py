"""sitcov: situation-coverage-based testing of autonomous-driving stacks at intersections."""

from sitcov.av import AVStack, Control, Observation, RunInfo
from sitcov.errors import ConfigError, SitcovError
from sitcov.generation import Generator
from sitcov.hyperspace import Situation
from sitcov.sim import Backend, Outcome

__version__ = "0.1.0"

__all__ = [
    "AVStack",
    "Backend",
    "ConfigError",
    "Control",
    "Generator",
    "Observation",
    "Outcome",
    "RunInfo",
    "SitcovError",
    "Situation",
    "__version__",
]
