"""A shipped map's situations on the map's own OpenDRIVE export (no ``--road``).

The situation builder (``sitcov.sim.carla.situation_scenario``) places situations by a
CARLA map file: spawn points, goals, conflict points and switch distances in CARLA's
left-handed frame. For an embedded map (``t-junction``, ``crossroads``, ...) the same facts
come from the map itself, in its own frame, which is the frame of its OpenDRIVE export
(``sitcov export-xodr``, ``sitcov/roads``): :func:`map_spec` writes them as a map file
whose CARLA frame is the map's mirrored in y (junction at the origin, not turned), and
:func:`own_road` writes the export once per process. A situation's conflict point and
switch distance are the embedded world's for its movements (:func:`situation_spec`).
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Mapping
from functools import lru_cache
from pathlib import Path
from typing import Any

from sitcov.errors import ConfigError

_DIR: tempfile.TemporaryDirectory | None = None


def _carla(x: float, y: float, h: float | None = None) -> dict[str, float]:
    point = {"x": x, "y": -y}
    if h is not None:
        point["yaw"] = -math.degrees(h)
    return point


def map_spec(jmap: Any) -> Any:
    """The map file of an embedded map (its spawns, goals and junction; see the module
    docstring). Conflict points and switch distances are per situation."""
    from sitcov.sim.carla._mapfile import CarlaMap

    ego, ov, goals = {}, {}, {}
    for leg in jmap.entry_legs:
        move = next(m for m in jmap.movements if m.startswith(f"{leg}-"))
        e, o = jmap.ego_path(move), jmap.ov_path(move)
        ego[leg] = _carla(e.xs[0], e.ys[0], e.hs[0])
        ov[leg] = _carla(o.xs[0], o.ys[0], o.hs[0])
    for leg in jmap.exit_legs:
        move = next(m for m in jmap.movements if m.endswith(f"-{leg}"))
        e = jmap.ego_path(move)
        goals[leg] = (e.xs[-1], -e.ys[-1])
    return CarlaMap.model_validate(
        {
            "name": jmap.name,
            "town": jmap.name,
            "description": f"the embedded map {jmap.name!r} on its own OpenDRIVE export",
            "junction": {"x": 0.0, "y": 0.0},
            "conflict_points": {"centre": (0.0, 0.0)},
            "ego_spawns": ego,
            "ov_spawns": ov,
            "goals": goals,
            "embedded_map": jmap.name,
            "goal_tolerance": 3.0,
        }
    )


def situation_spec(spec: Any, jmap: Any, values: dict[str, Any]) -> Any:
    """``spec`` with the situation's conflict point (under the situation's label) and
    switch distance: the embedded world's for its ego and OV movements."""
    intsit = values.get("intsit")
    if not isinstance(intsit, Mapping) or not {"ego", "ov"} <= set(intsit):
        return spec
    ego, ov = str(intsit["ego"]), str(intsit["ov"])
    if ego not in jmap.movements or ov not in jmap.movements:
        raise ConfigError(
            field="intsit",
            value=intsit,
            expected=f"movements of map {jmap.name!r}: {list(jmap.movements)}",
        )
    scenario = jmap.scenario(ego, ov)
    point = (0.0, 0.0) if scenario.conflict is None else scenario.conflict.point
    switch = jmap.switch_distance(scenario)
    label = str(intsit.get("conflict", "centre"))
    update: dict[str, Any] = {"conflict_points": {label: (point[0], -point[1])}}
    if switch is not None:
        update["switch_distances"] = {f"{ego}/{ov}": switch}
    return spec.model_copy(update=update)


@lru_cache(maxsize=8)
def own_road(name: str) -> Path:
    """The embedded map ``name``'s OpenDRIVE export (``sitcov export-xodr``), written once
    per process."""
    global _DIR
    from sitcov.roads import write_xodr
    from sitcov.sim.embedded import load_map
    from sitcov.sim.embedded._odr import road_network

    network, _ = road_network(load_map(name))
    if _DIR is None:
        _DIR = tempfile.TemporaryDirectory(prefix="sitcov-esmini-maps-")
    return write_xodr(network, Path(_DIR.name) / f"{Path(name).stem}.xodr")
