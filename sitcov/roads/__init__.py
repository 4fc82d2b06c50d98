"""The road layer: OpenDRIVE networks read into plain data, and junctions cut out as maps.

Below ``sim/`` (it imports nothing from sim or above): ``read_opendrive`` parses a file,
``list_junctions`` describes every junction with its legs, ``junction_map_data`` turns one
junction into the data of a sitcov map (``layout: lanes``, ``docs/roads.md``), which the
embedded world loads as it loads the shipped YAML maps.
"""

from sitcov.roads._geometry import Arc, Geometry, Line, ParamPoly3, PlanView, Spiral, poly3
from sitcov.roads._junction import (
    DEFAULT_EXTENSION,
    LegInfo,
    junction_centre,
    junction_legs,
    junction_map_data,
    leg_names,
    list_junctions,
    nearest_junction,
)
from sitcov.roads._opendrive import (
    DRIVING_TYPES,
    Connection,
    Crosswalk,
    Junction,
    Lane,
    LaneLink,
    LaneSection,
    Network,
    Road,
    read_opendrive,
)

__all__ = [
    "DEFAULT_EXTENSION",
    "DRIVING_TYPES",
    "LegInfo",
    "junction_centre",
    "junction_legs",
    "junction_map_data",
    "leg_names",
    "list_junctions",
    "nearest_junction",
    "Arc",
    "Connection",
    "Crosswalk",
    "Geometry",
    "Junction",
    "Lane",
    "LaneLink",
    "LaneSection",
    "Line",
    "Network",
    "ParamPoly3",
    "PlanView",
    "Road",
    "Spiral",
    "poly3",
    "read_opendrive",
]
