"""Conflict types of actor slots, from the geometry of the map a hyperspace was derived on.

A derived hyperspace's ``actor2``, ``actor3``, ... values name a kind and a route but not
how that actor meets the ego (it depends on the ego's route, which ``intsit`` chooses).
``sitcov.analysis`` breaks failure rates down by conflict type without importing the
simulator, so the campaign layer gives it the types: for every (ego route, kind, route)
that conflicts on the map, the type ``sitcov hyperspace derive`` computes.
"""

from __future__ import annotations

import functools
from typing import Any

from sitcov.analysis._breakdown import SlotTypes, actor_elements
from sitcov.errors import SitcovError


def slot_types(hyperspace: Any) -> SlotTypes | None:
    """(ego route, kind, route) -> conflict type on ``hyperspace.metadata.map``, or None
    when the hyperspace has no actor slot or names no map (then only ``intsit`` and slots
    with an explicit ``conflict`` are typed)."""
    slots = [n for n in actor_elements(hyperspace) if n != "intsit"]
    name = (hyperspace.metadata or {}).get("map")
    if not slots or not isinstance(name, str):
        return None
    return _map_types(name)


@functools.lru_cache(maxsize=8)
def _map_types(name: str) -> dict[tuple[str, str, str], str]:
    """Every typed conflict on map ``name`` (empty if the map cannot be loaded)."""
    try:
        from sitcov.sim.embedded._derive import ACTOR_KINDS, derive_conflicts
        from sitcov.sim.embedded._map import load_map

        conflicts = derive_conflicts(load_map(name), ACTOR_KINDS)
    except (ImportError, SitcovError):
        return {}
    return {(c.ego, c.kind, c.route): c.type for c in conflicts}
