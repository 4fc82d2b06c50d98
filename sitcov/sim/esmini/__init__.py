"""The esmini backend: users' OpenSCENARIO files (and sitcov's situations, exported) played
by esmini's C library through ctypes, the stack under test driving the ego."""

from sitcov.sim.esmini._backend import EsminiBackend
from sitcov.sim.esmini._lib import available, find_library
from sitcov.sim.esmini._scenario import ScenarioFile, scenario_files

__all__ = ["EsminiBackend", "ScenarioFile", "available", "find_library", "scenario_files"]
