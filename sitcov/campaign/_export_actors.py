"""Exports per road user: which actor came closest and which one the ego hit, per run.

A run's top-level ``min_distance`` / ``min_ttc`` / ``pet`` belong to its primary actor
(``ov``, the intersection situation's road user), also when the ego hit someone else. The
per-actor values are in ``outcome.metrics["actors"]`` (name -> kind, route, behaviour,
conflict_type, min_distance [m], min_ttc [s], pet [s], max_drac [m/s^2], collided). This
module turns them into

- run columns (:data:`RUN_COLUMNS`): the closest actor's and the hit actor's name, kind,
  min distance, min TTC and PET (``hit_kind`` stays where exports always had it);
- an actor table (:data:`ACTOR_COLUMNS`, ``sitcov export --per-actor``): one row per run
  and actor.

A run without per-actor metrics (the paper's two-car scene, databases from before actors)
has one road user, ``ov``, whose kind is the intersection situation's (``car`` by default)
and whose values are the run's top-level ones.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from typing import Any

from sitcov.campaign._records import RunRecord

#: The per-run columns this module adds (after ``hit_kind``).
RUN_COLUMNS = (
    "closest_actor",
    "closest_kind",
    "closest_min_distance",
    "closest_min_ttc",
    "closest_pet",
    "hit_actor",
    "hit_min_distance",
    "hit_min_ttc",
    "hit_pet",
)
#: The columns of the actor table, one row per run and actor.
ACTOR_COLUMNS = (
    "campaign",
    "index",
    "situation_id",
    "status",
    "failure_kind",
    "actor",
    "kind",
    "route",
    "behaviour",
    "conflict_type",
    "min_distance",
    "min_ttc",
    "pet",
    "max_drac",
    "collided",
    "closest",
)
#: Float columns of both tables (Parquet types), in metres or seconds.
FLOAT_COLUMNS = frozenset(
    c for c in (*RUN_COLUMNS, *ACTOR_COLUMNS) if c.endswith(("distance", "ttc", "pet", "drac"))
)
#: Boolean columns of the actor table.
BOOL_COLUMNS = frozenset({"collided", "closest"})
_PRIMARY = "ov"


def _number(value: Any) -> float | None:
    return float(value) if isinstance(value, int | float) and not isinstance(value, bool) else None


def run_actors(run: RunRecord, values: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Actor name -> {kind, route, behaviour, conflict_type, min_distance, min_ttc, pet,
    collided} of a finished run ({} while it is pending or without an outcome)."""
    outcome = run.outcome
    if outcome is None:
        return {}
    stored = outcome.metrics.get("actors")
    if isinstance(stored, Mapping) and stored:
        return {str(name): dict(info) for name, info in stored.items() if isinstance(info, Mapping)}
    intsit = values.get("intsit")
    kind = str(intsit.get("kind") or "car") if isinstance(intsit, Mapping) else "car"
    route = intsit.get("ov") if isinstance(intsit, Mapping) else None
    return {
        _PRIMARY: {
            "kind": kind,
            "route": route,
            "min_distance": outcome.min_distance,
            "min_ttc": outcome.min_ttc,
            "pet": outcome.pet,
            "max_drac": outcome.metrics.get("max_drac"),
            "collided": bool(outcome.collision),
        }
    }


def closest_actor(actors: Mapping[str, Mapping[str, Any]]) -> str | None:
    """The actor with the smallest min distance (a collided one first on a tie, then the
    first in order); None if no distance was measured."""
    best: tuple[float, int, int] | None = None
    name = None
    for i, (actor, info) in enumerate(actors.items()):
        d = _number(info.get("min_distance"))
        if d is None or not math.isfinite(d):
            continue
        key = (d, 0 if info.get("collided") else 1, i)
        if best is None or key < best:
            best, name = key, actor
    return name


def hit_actor(run: RunRecord, actors: Mapping[str, Mapping[str, Any]]) -> str | None:
    """The actor the ego collided with (``metrics["collision_actor"]``, else the one
    marked ``collided``, else ``ov`` for a collision that stores neither); None without."""
    outcome = run.outcome
    if outcome is None or not outcome.collision:
        return None
    stored = outcome.metrics.get("collision_actor")
    if stored is not None:
        return str(stored)
    collided = [name for name, info in actors.items() if info.get("collided")]
    return collided[0] if collided else _PRIMARY


def run_columns(run: RunRecord, values: Mapping[str, Any]) -> dict[str, Any]:
    """The :data:`RUN_COLUMNS` of one run (None where there is no such actor)."""
    actors = run_actors(run, values)
    out: dict[str, Any] = dict.fromkeys(RUN_COLUMNS)
    closest = closest_actor(actors)
    if closest is not None:
        info = actors[closest]
        out["closest_actor"], out["closest_kind"] = closest, info.get("kind")
        out.update(_measures("closest", info))
    hit = hit_actor(run, actors)
    if hit is not None:
        out["hit_actor"] = hit
        out.update(_measures("hit", actors.get(hit, {})))
    return out


def _measures(prefix: str, info: Mapping[str, Any]) -> dict[str, float | None]:
    return {f"{prefix}_{m}": _number(info.get(m)) for m in ("min_distance", "min_ttc", "pet")}


def actor_rows(runs: Iterator[RunRecord]) -> Iterator[dict[str, Any]]:
    """One :data:`ACTOR_COLUMNS` row per run and actor (pending runs give none)."""
    for run in runs:
        values = run.situation.to_dict()["values"]
        actors = run_actors(run, values)
        closest = closest_actor(actors)
        hit = hit_actor(run, actors)
        for name, info in actors.items():
            yield {
                "campaign": run.campaign,
                "index": run.index,
                "situation_id": run.situation.id,
                "status": run.status,
                "failure_kind": run.failure_kind,
                "actor": name,
                "kind": info.get("kind"),
                "route": _text(info.get("route")),
                "behaviour": _text(info.get("behaviour")),
                "conflict_type": _text(info.get("conflict_type")),
                "min_distance": _number(info.get("min_distance")),
                "min_ttc": _number(info.get("min_ttc")),
                "pet": _number(info.get("pet")),
                "max_drac": _number(info.get("max_drac")),
                "collided": bool(info.get("collided")) or name == hit,
                "closest": name == closest,
            }


def _text(value: Any) -> str | None:
    return None if value is None else str(value)


def hit_description(run: RunRecord, values: Mapping[str, Any]) -> str | None:
    """``actor2 (pedestrian)``: the road user the ego hit; None without a collision."""
    actors = run_actors(run, values)
    hit = hit_actor(run, actors)
    if hit is None:
        return None
    kind = (actors.get(hit) or {}).get("kind") or (run.outcome.metrics.get("collision_kind"))
    return f"{hit} ({kind})" if kind else hit
