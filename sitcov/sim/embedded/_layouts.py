"""Map layouts beyond the leg junction: a single-lane roundabout and an on-ramp merge."""

from __future__ import annotations

from sitcov.sim.embedded._map import JunctionMap


class RoundaboutMap(JunctionMap):
    LAYOUT = "roundabout"


class MergeMap(JunctionMap):
    LAYOUT = "merge"
