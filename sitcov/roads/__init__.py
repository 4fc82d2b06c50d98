"""The road layer (below ``sim/``): OpenDRIVE road networks as plain geometry.

Imports nothing from ``sitcov.sim`` or above; the maps of ``sim/`` describe themselves with
these types (``sitcov.sim.embedded._odr``).
"""

from sitcov.roads._writer import (
    Connection,
    Crosswalk,
    Junction,
    Lane,
    Link,
    Piece,
    Road,
    RoadNetwork,
    arc_spline,
    piece_end,
    write_xodr,
    xodr_text,
)

__all__ = [
    "Connection",
    "Crosswalk",
    "Junction",
    "Lane",
    "Link",
    "Piece",
    "Road",
    "RoadNetwork",
    "arc_spline",
    "piece_end",
    "write_xodr",
    "xodr_text",
]
