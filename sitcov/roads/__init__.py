"""The road layer (below ``sim/``): OpenDRIVE road networks as plain geometry.

Imports nothing from ``sitcov.sim`` or above. The writer's input types end in ``Spec``
(``RoadSpec``, ``LaneSpec`` ...): the maps of ``sim/`` describe themselves with them
(``sitcov.sim.embedded._odr``) and ``write_xodr`` writes the ``.xodr``.
"""

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
    "ConnectionSpec",
    "CrosswalkSpec",
    "JunctionSpec",
    "LaneSpec",
    "LinkSpec",
    "NetworkSpec",
    "Piece",
    "RoadSpec",
    "arc_spline",
    "piece_end",
    "write_xodr",
    "xodr_text",
]
