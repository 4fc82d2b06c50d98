"""Situations derived from a map: every pair of routes that really conflicts.

:func:`derive_hyperspace` builds a hyperspace document (the format of
``docs/hyperspace.md``) for a map: the default hyperspace's weather elements, an ``intsit``
element listing every (ego route, actor kind, actor route, conflict type) whose paths
overlap when both follow their routes from their spawns, and ``actor2`` ... ``actorK``
slots for further road users, with constraints that forbid impossible combinations. On the
paper's T-junction the car-car crossing and merging conflicts are exactly its twelve
intersection situations, which keep their labels and conflict names (:data:`PAPER_LABELS`).
``sitcov hyperspace derive`` is the command line.
"""

from __future__ import annotations

import copy
from collections.abc import Sequence
from dataclasses import dataclass
from importlib import resources
from pathlib import Path as FsPath
from typing import Any

import yaml

from sitcov.errors import ConfigError
from sitcov.hyperspace._load import DEFAULT_HYPERSPACE
from sitcov.sim._adversary import PAPER_INTSITS
from sitcov.sim.embedded._conflicts import CONFLICT_TYPES, KIND_WIDTHS, typed_conflict
from sitcov.sim.embedded._map import JunctionMap, load_map
from sitcov.sim.embedded._routes import actor_route, route_names, start_key

#: The paper's twelve intersection situations on the T-junction: (ego, OV) -> (label,
#: conflict point name), in the paper's order.
PAPER_LABELS: dict[tuple[str, str], tuple[str, str]] = {
    pair: (f"IntSit-{n}", point) for n, (pair, point) in enumerate(PAPER_INTSITS.items(), 1)
}
#: Kinds an actor may be (the ego is always a car).
ACTOR_KINDS = ("car", "cyclist", "pedestrian")
#: Conflict points closer than this share a name [m].
SAME_POINT = 1.5


@dataclass(frozen=True)
class DerivedConflict:
    """One real conflict between the ego's route and an actor's route."""

    ego: str
    kind: str
    route: str
    type: str
    point: tuple[float, float]


def derive_conflicts(
    jmap: JunctionMap, kinds: Sequence[str], types: Sequence[str] | None = None
) -> list[DerivedConflict]:
    """Every (ego route, kind, actor route) whose paths overlap, typed, in a fixed order.

    The ego drives its route from its spawn to its goal; another car drives from the OV
    spawn to the end of its leg (the routes the embedded backend runs); cyclists and
    pedestrians take their whole routes. ``types`` keeps only those conflict types.
    """
    for kind in kinds:
        if kind not in ACTOR_KINDS:
            raise ConfigError(field="actors", value=kind, expected=" | ".join(ACTOR_KINDS))
    for t in types or ():
        if t not in CONFLICT_TYPES:
            raise ConfigError(field="conflicts", value=t, expected=" | ".join(CONFLICT_TYPES))
    out = []
    for ego in jmap.movements:
        ego_path = jmap.ego_path(ego)
        for kind in kinds:
            for route in route_names(jmap, kind):
                path = jmap.ov_path(route) if kind == "car" else actor_route(jmap, kind, route)
                typed = typed_conflict(ego_path, path, kind, KIND_WIDTHS["car"])
                if typed is None or (types and typed.type not in types):
                    continue
                out.append(DerivedConflict(ego, kind, route, typed.type, typed.conflict.point))
    return out


def _point_names(conflicts: list[DerivedConflict]) -> dict[tuple[float, float], str]:
    """``k1``, ``k2``, ... per distinct conflict point, in order of first appearance."""
    names: dict[tuple[float, float], str] = {}
    anchors: list[tuple[tuple[float, float], str]] = []
    for c in conflicts:
        for anchor, name in anchors:
            if abs(anchor[0] - c.point[0]) + abs(anchor[1] - c.point[1]) < SAME_POINT:
                names[c.point] = name
                break
        else:
            anchors.append((c.point, f"k{len(anchors) + 1}"))
            names[c.point] = anchors[-1][1]
    return names


def _intsit_bins(jmap: JunctionMap, conflicts: list[DerivedConflict]) -> list[dict[str, Any]]:
    names = _point_names(conflicts)
    paper = jmap.name == "t-junction"
    bins = []
    for c in conflicts:
        label, point = f"{c.ego}/{c.kind}:{c.route}", names[c.point]
        if paper and c.kind == "car" and (c.ego, c.route) in PAPER_LABELS:
            label, point = PAPER_LABELS[(c.ego, c.route)]
        value = {"ego": c.ego, "ov": c.route, "conflict": point, "kind": c.kind, "type": c.type}
        bins.append({"label": label, "value": value})
    if paper:  # the paper's situations first, in its order
        order = {lab: n for n, (lab, _) in enumerate(PAPER_LABELS.values())}
        bins.sort(key=lambda b: order.get(b["label"], len(order)))
    return bins


def _slot_values(conflicts: list[DerivedConflict]) -> list[tuple[str, str]]:
    """(kind, route) of every actor that conflicts with some ego route, in order."""
    seen: dict[tuple[str, str], None] = {}
    for c in conflicts:
        seen.setdefault((c.kind, c.route), None)
    return list(seen)


def _slot_label(kind: str, route: str) -> str:
    return f"{kind}:{route}"


def _constraints(
    conflicts: list[DerivedConflict], bins: list[dict[str, Any]], slots: list[str]
) -> list[dict[str, Any]]:
    """Forbid slot actors that never meet the ego's route or spawn on another actor."""
    actors = _slot_values(conflicts)
    meets = {(c.ego, c.kind, c.route) for c in conflicts}
    by_ego: dict[str, list[str]] = {}
    by_start: dict[tuple[str, str], list[str]] = {}
    for b in bins:
        v = b["value"]
        by_ego.setdefault(v["ego"], []).append(b["label"])
        by_start.setdefault(start_key(v["kind"], v["ov"]), []).append(b["label"])
    starts: dict[tuple[str, str], list[str]] = {}
    for kind, route in actors:
        starts.setdefault(start_key(kind, route), []).append(_slot_label(kind, route))
    out: list[dict[str, Any]] = []
    for n, slot in enumerate(slots):
        for ego, labels in by_ego.items():
            never = [_slot_label(k, r) for k, r in actors if (ego, k, r) not in meets]
            if never:
                out.append(
                    {
                        "forbid": {"intsit": labels, slot: never},
                        "description": f"{slot}: actors whose route never meets the ego's {ego}",
                    }
                )
        for key, labels in by_start.items():
            if key in starts:
                out.append(
                    {
                        "forbid": {"intsit": labels, slot: starts[key]},
                        "description": f"{slot} would start where the intsit actor starts",
                    }
                )
        for earlier in slots[:n]:
            for labels in starts.values():
                out.append(
                    {
                        "forbid": {earlier: labels, slot: labels},
                        "description": f"{earlier} and {slot} would start at the same place",
                    }
                )
        if n:
            out.append(
                {
                    "forbid": {slots[n - 1]: ["none"], slot: [_slot_label(*a) for a in actors]},
                    "description": f"slots fill in order: {slot} only after {slots[n - 1]}",
                }
            )
    return out


def derive_hyperspace(
    map_name: str,
    actors: Sequence[str] = ("car",),
    max_actors: int = 1,
    types: Sequence[str] | None = None,
) -> dict[str, Any]:
    """The derived hyperspace document for a map (validated; YAML/JSON-ready).

    Args:
        map_name: a built-in map name or a map YAML file.
        actors: kinds of road users besides the ego (car, cyclist, pedestrian).
        max_actors: road users besides the ego: the intsit actor plus ``max_actors - 1``
            slots ``actor2`` ... (each "none" or a conflicting actor).
        types: keep only these conflict types (default: all).
    """
    if max_actors < 1:
        raise ConfigError(field="max_actors", value=max_actors, expected="an integer >= 1")
    jmap = load_map(map_name)
    conflicts = derive_conflicts(jmap, actors, types)
    if not conflicts:
        raise ConfigError(
            field="actors", value=list(actors), expected=f"kinds with a conflict on {jmap.name}"
        )
    bins = _intsit_bins(jmap, conflicts)
    res = resources.files("sitcov.hyperspace") / "data" / f"{DEFAULT_HYPERSPACE}.yaml"
    default = yaml.safe_load(res.read_text(encoding="utf-8"))
    environment = copy.deepcopy(default["axes"][0])
    slots = [f"actor{n}" for n in range(2, max_actors + 1)]
    axes = [environment, _intersection_axis(jmap, bins, actors)]
    if slots:
        axes.append(_actor_axis(slots, _slot_values(conflicts)))
    doc = {
        "name": f"derived-{jmap.name}",
        "description": f"Situations derived from map {jmap.name!r}: every route pair that "
        f"conflicts, actors {', '.join(actors)}, up to {max_actors} besides the ego.",
        "metadata": {
            # a map file (YAML or FILE.xodr#ID) is named as given, so that a campaign on the
            # derived hyperspace loads the same file; a built-in map by its name
            "map": map_name if "." in FsPath(str(map_name)).name else jmap.name,
            "traffic": "right-hand",
            "derived_by": "sitcov hyperspace derive",
            "actors": list(actors),
            "max_actors": max_actors,
            "conflict_types": sorted({c.type for c in conflicts}),
        },
        "axes": axes,
        "constraints": _constraints(conflicts, bins, slots),
    }
    from sitcov.hyperspace import Hyperspace

    Hyperspace.from_dict(doc, file=f"derived from {jmap.name}")  # raises if inconsistent
    return doc


def _intersection_axis(
    jmap: JunctionMap, bins: list[dict[str, Any]], actors: Sequence[str]
) -> dict[str, Any]:
    return {
        "name": "intersection",
        "description": "The ego's route, the conflicting road user's kind and route, and how "
        "their paths meet (conflict type and point).",
        "elements": [
            {
                "name": "intsit",
                "description": "Intersection situation: ego route, actor kind and route, "
                "conflict point and type.",
                "metadata": {
                    "legs": sorted(jmap.legs),
                    "route_format": "X-Y = from leg X to leg Y; X<leg><L|R> = crosswalk on "
                    "<leg> from its left/right kerb (facing the junction)",
                    "kinds": list(actors),
                },
                "bins": bins,
            }
        ],
    }


def _actor_axis(slots: list[str], actors: list[tuple[str, str]]) -> dict[str, Any]:
    slot_bins = [{"label": "none", "value": "none"}] + [
        {"label": _slot_label(k, r), "value": {"kind": k, "route": r}} for k, r in actors
    ]
    return {
        "name": "actors",
        "description": "Further road users, each conflicting with the ego's route.",
        "elements": [
            {
                "name": slot,
                "description": f"Road user {slot[5:]} besides the ego: none, or its kind and "
                "route.",
                "bins": slot_bins,
            }
            for slot in slots
        ],
    }


def derive_command(
    map_name: str,
    actors: Sequence[str],
    max_actors: int,
    types: Sequence[str] | None = None,
    out: str | FsPath | None = None,
) -> str:
    """The ``sitcov hyperspace derive`` command line that produces a document."""
    parts = ["sitcov hyperspace derive", f"--map {map_name}", f"--actors {','.join(actors)}"]
    parts.append(f"--max-actors {max_actors}")
    if types:
        parts.append(f"--conflicts {','.join(types)}")
    if out is not None:
        parts.append(f"--out {out}")
    return " ".join(parts)


def dump_derived(doc: dict[str, Any], command: str) -> str:
    """The derived document as YAML text with a header naming the command."""
    header = (
        "# Derived from the map's geometry; do not edit by hand. Produced by:\n"
        f"#   {command}\n# Format: docs/hyperspace.md; how it is derived: docs/embedded.md.\n"
    )
    return header + yaml.safe_dump(doc, sort_keys=False, width=100, default_flow_style=None)
