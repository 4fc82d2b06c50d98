"""The few facts of each run a summary needs, streamed straight from SQL.

``sitcov summary`` on a 100,000-run campaign must answer in seconds. Building a
:class:`~sitcov.campaign.RunRecord` per run (situation values, the whole outcome JSON,
validation) costs far more than the summary itself, so the SQLite store is asked only for
the columns the counts use: bins, status, failure kind, which failure events happened and
which kind of road user the ego hit.
Any other store (the in-memory one, a plug-in) is read through ``iter_runs``; both give
the same facts (tested).
"""

from __future__ import annotations

import json
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from sitcov.campaign._records import RunRecord
from sitcov.campaign._sqlite import SQLiteStore, _damaged
from sitcov.campaign._store import Store
from sitcov.sim._judge import EVENT_METRICS, event_times

#: Rows fetched from SQLite at a time (memory stays flat whatever the campaign's size).
_CHUNK = 2000


def iter_facts(
    store: Store, campaign: str | None = None, status: str | Sequence[str] | None = None
) -> Iterator[dict[str, Any]]:
    """One mapping per run (same filters as ``Store.iter_runs``, in no particular order):
    ``bins``, ``status``, ``failure_kind``, ``events`` (the failure events the run's
    outcome reports as facts, a tuple of kinds; empty while pending), ``hit`` (the
    outcome's ``metrics["collision_kind"]``: the kind of road user the ego collided with;
    None without a collision and in runs that do not store it, such as the paper's
    two-car scene, whose only other road user is a car), ``completion`` (the outcome's
    ``metrics["route_completion"]``, None in runs stored before world model 3) and
    ``actor_collisions`` (how many collisions between two other road users it records)."""
    if isinstance(store, SQLiteStore):
        yield from _sql_facts(store, campaign, status)
        return
    for run in store.iter_runs(campaign, status):
        yield record_facts(run)


@dataclass(frozen=True, eq=False, slots=True)
class RunFacts:
    """A stored run without its concrete values and outcome: what reports count and group.

    About a tenth of a :class:`~sitcov.campaign.RunRecord` in memory and far cheaper to
    read, so a report of 100,000 runs holds them all. ``store.get_run(campaign, index)``
    gives the full record (situation, outcome, trace) of one run when it is needed.

    Attributes:
        campaign, index, seed, status, failure_kind, bins: as in ``RunRecord``.
        config: the campaign's stored config (shared by its runs).
        hit: the kind of road user the ego collided with, as :func:`iter_facts` says.
        events, completion, actor_collisions: as :func:`iter_facts` says (the failure
            events that happened, counted or not; the route completion; collisions
            between two other road users).
    """

    campaign: str
    index: int
    seed: int
    status: str
    failure_kind: str | None
    bins: Mapping[str, str]
    config: Mapping[str, Any]
    hit: str | None = None
    events: tuple[str, ...] = ()
    completion: float | None = None
    actor_collisions: int = 0


def iter_run_facts(
    store: Store, campaign: str, status: str | Sequence[str] | None = None
) -> Iterator[RunFacts]:
    """The runs of ``campaign`` (optionally of these statuses) as :class:`RunFacts`, in index
    order, streamed."""
    if not isinstance(store, SQLiteStore):
        for run in store.iter_runs(campaign, status):
            facts = record_facts(run)
            yield RunFacts(
                run.campaign,
                run.index,
                run.seed,
                run.status,
                run.failure_kind,
                dict(run.bins),
                run.config,
                facts["hit"],
                facts["events"],
                facts["completion"],
                facts["actor_collisions"],
            )
        return
    config = store._config(campaign)
    where, params = store._where(campaign, status)
    cursor = store._db.execute(
        f"SELECT idx, seed, status, failure_kind, bins, {_HIT}, {_EVENT_MASK}, {_COMPLETION}, "
        f"{_ACTOR_COLLISIONS} FROM runs{where} ORDER BY idx",
        params,
    )
    while rows := cursor.fetchmany(_CHUNK):
        for idx, seed, state, kind, bins, hit, mask, completion, contacts in rows:
            try:
                decoded = json.loads(bins)
            except (ValueError, TypeError) as exc:
                raise _damaged(store.location, f"run {campaign}:{idx}", exc) from None
            events = _COLLISION if mask == 0 and state == "fail" else _EVENTS[mask]
            yield RunFacts(
                campaign,
                int(idx),
                int(seed),
                state,
                kind,
                decoded,
                config,
                hit,
                events,
                completion,
                contacts or 0,
            )


def total_wall_time(store: Store, campaign: str) -> float:
    """Sum of the wall times of a campaign's runs [s] (pending runs count 0)."""
    if isinstance(store, SQLiteStore):
        where, params = store._where(campaign, None)
        row = store._db.execute(
            f"SELECT total(wall_time) FROM (SELECT wall_time FROM runs{where} ORDER BY idx)",
            params,
        ).fetchone()
        return float(row[0])
    return sum(r.wall_time or 0.0 for r in store.iter_runs(campaign))


def record_facts(run: RunRecord) -> dict[str, Any]:
    """The facts of a run record (what :func:`iter_facts` gives for it)."""
    events = tuple(event_times(run.outcome)) if run.outcome is not None else ()
    metrics = run.outcome.metrics if run.outcome is not None else {}
    completion = metrics.get("route_completion")
    return {
        "bins": dict(run.bins),
        "status": run.status,
        "failure_kind": run.failure_kind,
        "events": events,
        "hit": run_hit(run),
        "completion": None if completion is None else float(completion),
        "actor_collisions": len(metrics.get("actor_collisions") or ()),
    }


def draw_facts(store: Store, campaign: str | None = None) -> dict[str, Any] | None:
    """Over the judged runs stored with perception draws (``metrics.perception_draws`` >
    1, :mod:`sitcov.campaign._draws`): ``runs``, ``failing_draw_share`` (the mean share of
    a run's draws that failed: the failure rate a single draw per run estimates) and
    ``split_runs`` (runs whose draws did not all agree). None when no run has draws."""
    if isinstance(store, SQLiteStore):
        where, params = store._where(campaign, ("pass", "fail"))
        draws = "json_extract(outcome, '$.metrics.perception_draws')"
        failed = "json_extract(outcome, '$.metrics.draws_failed')"
        cond = f"{where} AND {draws} > 1" if where else f" WHERE {draws} > 1"
        rows = store._db.execute(f"SELECT {failed}, {draws} FROM runs{cond}", params).fetchall()
    else:
        rows = []
        for run in store.iter_runs(campaign, ("pass", "fail")):
            metrics = run.outcome.metrics if run.outcome is not None else {}
            if (metrics.get("perception_draws") or 1) > 1:
                rows.append((metrics["draws_failed"], metrics["perception_draws"]))
    if not rows:
        return None
    return {
        "runs": len(rows),
        "failing_draw_share": sum(k / n for k, n in rows) / len(rows),
        "split_runs": sum(0 < k < n for k, n in rows),
    }


def run_hit(run: RunRecord) -> str | None:
    """The kind of road user the ego collided with in ``run`` (``metrics["collision_kind"]``;
    None if it stores none)."""
    if run.outcome is None:
        return None
    hit = run.outcome.metrics.get("collision_kind")
    return None if hit is None else str(hit)


def _sql_facts(
    store: SQLiteStore, campaign: str | None, status: str | Sequence[str] | None
) -> Iterator[dict[str, Any]]:
    where, params = store._where(campaign, status)
    cursor = store._db.execute(
        f"SELECT campaign, idx, bins, status, failure_kind, {_EVENT_MASK}, {_HIT}, "
        f"{_COMPLETION}, {_ACTOR_COLLISIONS} FROM runs{where}",
        params,
    )
    while rows := cursor.fetchmany(_CHUNK):
        for name, idx, bins, state, kind, mask, hit, completion, contacts in rows:
            try:
                decoded = json.loads(bins)
            except (ValueError, TypeError) as exc:
                raise _damaged(store.location, f"run {name}:{idx}", exc) from None
            events = _COLLISION if mask == 0 and state == "fail" else _EVENTS[mask]
            yield {
                "bins": decoded,
                "status": state,
                "failure_kind": kind,
                "events": events,
                "hit": hit,
                "completion": completion,
                "actor_collisions": contacts or 0,
            }


#: Failure events a run's outcome reports as facts, as bits: the collision flag (split
#: by ``metrics.ego_stationary``), then each event metric that is set (-1: no outcome
#: yet). The same facts as ``sitcov.sim._judge.event_times``, computed by SQLite.
_EVENT_KINDS = ("collision", "ego_stationary", *EVENT_METRICS)
_STATIONARY = "coalesce(json_extract(outcome, '$.metrics.ego_stationary'), 0)"
_EVENT_MASK = (
    "CASE WHEN outcome IS NULL THEN -1 ELSE "
    f"(coalesce(collision, 0) != 0 AND {_STATIONARY} = 0)"
    f" | ((coalesce(collision, 0) != 0 AND {_STATIONARY} != 0) << 1)"
    + "".join(
        f" | ((json_extract(outcome, '$.metrics.{key}') IS NOT NULL) << {bit})"
        for bit, key in enumerate(EVENT_METRICS.values(), start=2)
    )
    + " END"
)
_EVENTS = {
    mask: tuple(k for bit, k in enumerate(_EVENT_KINDS) if mask >= 0 and mask >> bit & 1)
    for mask in range(-1, 2 ** len(_EVENT_KINDS))
}
#: The kind of road user the ego hit (:func:`run_hit`), computed by SQLite.
_HIT = (
    "CASE WHEN outcome IS NULL THEN NULL ELSE json_extract(outcome, '$.metrics.collision_kind') END"
)
#: A failed run whose outcome reports no event failed by collision (as before failure kinds).
_COLLISION = ("collision",)
#: The run's route completion (None before world model 3), computed by SQLite.
_COMPLETION = "json_extract(outcome, '$.metrics.route_completion')"
#: How many collisions between two other road users the run records.
_ACTOR_COLLISIONS = (
    "CASE WHEN outcome IS NULL THEN 0 "
    "ELSE coalesce(json_array_length(outcome, '$.metrics.actor_collisions'), 0) END"
)
