"""sitcov: situation-coverage-based testing of autonomous-driving stacks at intersections.

The public API is small; everything else lives in the sub-packages (one per concern):

>>> from sitcov import load_hyperspace, make_generator, ask_rng
>>> hyperspace = load_hyperspace()
>>> situation = make_generator("sitcov", hyperspace).ask(ask_rng(0, 0))
>>> sorted(situation.bins)[:2]
['cloudiness', 'fog_density']
"""

from sitcov._seeding import ask_rng, run_seed
from sitcov._version import __version__
from sitcov.analysis import summarize
from sitcov.av import AVStack, Control, Observation, ReferenceStack, RunInfo, make_stack
from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.errors import ConfigError, SitcovError
from sitcov.generation import Generator, make_generator
from sitcov.hyperspace import Hyperspace, Situation, load_hyperspace
from sitcov.sim import Backend, Outcome, make_backend

__all__ = [
    "AVStack",
    "Backend",
    "CampaignConfig",
    "ConfigError",
    "Control",
    "Generator",
    "Hyperspace",
    "Observation",
    "Outcome",
    "ReferenceStack",
    "RunInfo",
    "SitcovError",
    "Situation",
    "__version__",
    "ask_rng",
    "load_hyperspace",
    "make_backend",
    "make_generator",
    "make_stack",
    "open_store",
    "run_campaign",
    "run_seed",
    "summarize",
]
