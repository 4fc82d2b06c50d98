"""The embedded simulator: junction maps as data, single-track dynamics, the backend."""

from sitcov.sim.embedded._backend import ELEMENT_EFFECTS, EmbeddedBackend
from sitcov.sim.embedded._collision import box_distance, overlap, time_to_collision
from sitcov.sim.embedded._dynamics import Vehicle, VehicleParams, bmw_320i, default_params
from sitcov.sim.embedded._lanes_map import LanesMap  # registers layout: lanes
from sitcov.sim.embedded._layouts import MergeMap, RoundaboutMap  # registers the layouts
from sitcov.sim.embedded._map import Conflict, JunctionMap, Scenario, find_conflict, load_map
from sitcov.sim.embedded._path import Path
from sitcov.sim.embedded._render import render_topdown

__all__ = [
    "ELEMENT_EFFECTS",
    "Conflict",
    "EmbeddedBackend",
    "JunctionMap",
    "LanesMap",
    "MergeMap",
    "Path",
    "RoundaboutMap",
    "Scenario",
    "Vehicle",
    "VehicleParams",
    "bmw_320i",
    "box_distance",
    "default_params",
    "find_conflict",
    "load_map",
    "overlap",
    "render_topdown",
    "time_to_collision",
]
