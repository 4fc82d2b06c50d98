"""The road layer (below ``sim/``; it imports nothing from sim or above): OpenDRIVE in and out.

In: ``read_opendrive`` parses a file, ``list_junctions`` describes every junction with its
legs, ``junction_map_data`` turns one junction into the data of a sitcov map (``layout:
lanes``, docs/roads.md), which the embedded world loads as it loads the shipped YAML maps.
Drawing: ``lane_outlines`` samples every lane and lane border (the report's pictures of
runs on a user's OpenDRIVE road).
Out: the writer's input types end in ``Spec`` (``RoadSpec``, ``LaneSpec`` ...); the maps of
``sim/`` describe themselves with them (``sitcov.sim.embedded._odr``) and ``write_xodr``
writes the ``.xodr`` (docs/export-xosc.md).
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
from sitcov.roads._outline import LaneBorder, LaneOutline, lane_outlines
from sitcov.roads._writer import (
    ConnectionSpec,
    CrosswalkSpec,
    JunctionSpec,
    LaneSpec,
    LinkSpec,
    NetworkSpec,
    Piece,
    RoadSpec,
    arc_spline,
    piece_end,
    write_xodr,
    xodr_text,
)

__all__ = [
    "Arc",
    "Connection",
    "ConnectionSpec",
    "Crosswalk",
    "CrosswalkSpec",
    "DEFAULT_EXTENSION",
    "DRIVING_TYPES",
    "Geometry",
    "Junction",
    "JunctionSpec",
    "Lane",
    "LaneLink",
    "LaneBorder",
    "LaneOutline",
    "LaneSection",
    "LaneSpec",
    "LegInfo",
    "Line",
    "LinkSpec",
    "Network",
    "NetworkSpec",
    "ParamPoly3",
    "Piece",
    "PlanView",
    "Road",
    "RoadSpec",
    "Spiral",
    "arc_spline",
    "junction_centre",
    "junction_legs",
    "junction_map_data",
    "lane_outlines",
    "leg_names",
    "list_junctions",
    "nearest_junction",
    "piece_end",
    "poly3",
    "read_opendrive",
    "write_xodr",
    "xodr_text",
]
