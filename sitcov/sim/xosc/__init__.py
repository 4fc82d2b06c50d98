"""OpenSCENARIO out: scenarios that play in a real engine, and playing them in esmini."""

from sitcov.sim.xosc._distribution import write_distribution
from sitcov.sim.xosc._esmini import ENV, esmini_tool, find_esmini, schema_dir
from sitcov.sim.xosc._play import (
    Played,
    PlaySummary,
    distribution_sets,
    parameters,
    play,
    play_distribution,
    summarise,
)
from sitcov.sim.xosc._scenario import (
    HeroRoute,
    RunFacts,
    environment,
    facts_of,
    identity,
    run_scenario,
    simplify,
)

__all__ = [
    "PlaySummary",
    "Played",
    "distribution_sets",
    "parameters",
    "play_distribution",
    "write_distribution",
    "play",
    "summarise",
    "ENV",
    "HeroRoute",
    "RunFacts",
    "environment",
    "esmini_tool",
    "facts_of",
    "find_esmini",
    "identity",
    "run_scenario",
    "schema_dir",
    "simplify",
]
