"""Exports of stored runs: CSV, Parquet, JSON and JUnit XML.

All formats stream the runs from the store (memory stays flat for large campaigns). One
row / test case per run; a run's bins and concrete values become ``bin.ELEMENT`` and
``value.ELEMENT`` columns (mappings such as an intersection situation as JSON text), and
its ``actor_kinds`` and ``conflict_types`` (``;``-separated, see
:mod:`sitcov.analysis._breakdown`) so that failure rates can be broken down by road user,
and ``hit_kind``, the kind of road user the ego collided with (empty without a collision).
Every format carries each run's ``failure_kind`` (``pass``, a kind of
``sitcov.sim.FAILURE_KINDS``, ``error``, ``timeout``; empty while pending) and its route
progress facts (:data:`PROGRESS_COLUMNS`: route completion, time to goal, blocked and
route-incomplete times, stationary collision, stop reason; the JSON export has them in
the outcome's metrics); the JSON export also gives each campaign's ``physics``, ``judge``
and ``world_model``, its ``breakdowns`` (failure rates by actor kind and conflict type,
and collisions by the road user hit, as ``sitcov summary``) and its ``route_completion``
(mean, goal rate, distribution, as ``sitcov summary``).
"""

from __future__ import annotations

import csv
import json
from collections.abc import Iterator
from typing import IO, Any
from xml.sax.saxutils import escape, quoteattr

from sitcov.analysis._breakdown import HIT_UNSTORED, run_hit, run_roles
from sitcov.campaign._facts import total_wall_time
from sitcov.campaign._records import RunRecord
from sitcov.campaign._sqlite import OUTCOME_COLUMNS
from sitcov.campaign._store import Store, StoreError
from sitcov.campaign._summary import campaign_setup
from sitcov.errors import ConfigError, MissingExtraError

FORMATS = ("csv", "parquet", "json", "junit")

_BASE_COLUMNS = (
    "campaign",
    "index",
    "situation_id",
    "seed",
    "status",
    "failure_kind",
    *OUTCOME_COLUMNS,
)
_TAIL_COLUMNS = ("wall_time", "replay_of", "actor_kinds", "conflict_types", "hit_kind")
#: Route progress facts of ``Outcome.metrics`` exported as columns (empty for runs stored
#: before world model 3): docs/campaigns.md, "Route completion and blame".
PROGRESS_COLUMNS = (
    "route_completion",
    "time_to_goal",
    "blocked_time",
    "route_incomplete_time",
    "ego_stationary",
    "stop_reason",
)


def _elements(store: Store, campaign: str | None) -> list[str]:
    """Element names of the exported campaigns' hyperspaces, in first-seen order."""
    names: list[str] = []
    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    for info in infos:
        for axis in info.hyperspace.get("axes", []):
            for element in axis.get("elements", []):
                name = element.get("name") if isinstance(element, dict) else None
                if not isinstance(name, str):
                    raise StoreError(
                        f"{store.location}: campaign {info.name!r}: the stored hyperspace has an "
                        "element without a name (damaged database)"
                    )
                if name not in names:
                    names.append(name)
    return names


def _cell(value: Any) -> Any:
    return json.dumps(value, sort_keys=True) if isinstance(value, dict | list) else value


def flat_rows(store: Store, campaign: str | None = None) -> tuple[list[str], Iterator[dict]]:
    """The column names and a stream of one flat dict per run."""
    elements = _elements(store, campaign)
    columns = [
        *_BASE_COLUMNS,
        *_TAIL_COLUMNS,
        *PROGRESS_COLUMNS,
        *(f"bin.{e}" for e in elements),
        *(f"value.{e}" for e in elements),
    ]

    typing = _slot_typing(store, campaign)

    def rows() -> Iterator[dict]:
        for run in store.iter_runs(campaign):
            out = run.outcome.to_dict() if run.outcome is not None else {}
            row: dict[str, Any] = {
                "campaign": run.campaign,
                "index": run.index,
                "situation_id": run.situation.id,
                "seed": run.seed,
                "status": run.status,
                "failure_kind": run.failure_kind,
                "wall_time": run.wall_time,
                "replay_of": run.replay_of,
            }
            row.update({c: out.get(c) for c in OUTCOME_COLUMNS})
            metrics = out.get("metrics") or {}
            row.update({c: metrics.get(c) for c in PROGRESS_COLUMNS})
            values = run.situation.to_dict()["values"]
            kinds, types = run_roles(values, typing.get(run.campaign))
            row["actor_kinds"], row["conflict_types"] = ";".join(kinds), ";".join(types)
            row["hit_kind"] = _hit_kind(run, values)
            for e in elements:
                row[f"bin.{e}"] = run.bins.get(e)
                row[f"value.{e}"] = _cell(values.get(e))
            yield row

    return columns, rows()


def _hit_kind(run: RunRecord, values: dict[str, Any]) -> str | None:
    """The kind of road user the ego hit (a collision that stores none, as in the paper's
    two-car scene, hit the intersection situation's road user); None without a collision."""
    hit = run_hit(run, run.outcome is not None and run.outcome.collision)
    if hit != HIT_UNSTORED:
        return hit
    intsit = values.get("intsit")
    return str(intsit.get("kind") or "car") if isinstance(intsit, dict) else "car"


def _slot_typing(store: Store, campaign: str | None) -> dict[str, Any]:
    """Per campaign: how its actor slots are typed (``sitcov.campaign._breakdown``)."""
    from sitcov.campaign._breakdown import slot_types
    from sitcov.hyperspace import Hyperspace

    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    out = {}
    for info in infos:
        metadata = info.hyperspace.get("metadata") or {}
        if isinstance(metadata, dict) and "map" in metadata:
            out[info.name] = slot_types(Hyperspace.from_dict(info.hyperspace))
    return out


def export_csv(store: Store, out: IO[str], campaign: str | None = None) -> int:
    """Write CSV with a header row; returns the number of runs written."""
    columns, rows = flat_rows(store, campaign)
    writer = csv.DictWriter(out, fieldnames=columns, lineterminator="\n")
    writer.writeheader()
    n = 0
    for row in rows:
        writer.writerow(row)
        n += 1
    return n


def export_json(store: Store, out: IO[str], campaign: str | None = None) -> int:
    """Write ``{"campaigns": [...], "runs": [...]}`` (full outcomes, no traces)."""
    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    out.write('{"campaigns": ')
    json.dump(
        [
            {
                "name": c.name,
                "config": c.config,
                "sitcov_version": c.sitcov_version,
                "created": c.created,
                "generator": c.generator,
                "tags": c.tags,
                **campaign_setup(c),
                "breakdowns": _breakdowns(store, c),
                "route_completion": _completion(store, c.name),
            }
            for c in infos
        ],
        out,
        sort_keys=True,
    )
    out.write(', "runs": [')
    n = 0
    for run in store.iter_runs(campaign):
        out.write(",\n" if n else "\n")
        json.dump(run_to_json(run), out, sort_keys=True)
        n += 1
    out.write("\n]}\n")
    return n


def _breakdowns(store: Store, info: Any) -> dict[str, Any]:
    """A campaign's failure rates by actor kind and conflict type ({} without actors)."""
    from sitcov.analysis import breakdowns
    from sitcov.campaign._breakdown import slot_types
    from sitcov.campaign._facts import iter_facts
    from sitcov.campaign._summary import FINISHED
    from sitcov.hyperspace import Hyperspace

    hs = Hyperspace.from_dict(info.hyperspace, file=f"{store.location} (campaign {info.name})")
    return breakdowns(hs, iter_facts(store, info.name, FINISHED), slot_types(hs))


def _completion(store: Store, campaign: str) -> dict[str, Any]:
    """A campaign's route completion statistics over its judged runs."""
    from sitcov.analysis import route_completion_stats
    from sitcov.campaign._facts import iter_facts

    facts = iter_facts(store, campaign, ("pass", "fail"))
    return route_completion_stats(f.get("completion") for f in facts)


def run_to_json(run: RunRecord) -> dict[str, Any]:
    """One run as JSON data: campaign, index, situation, seed, status, failure_kind,
    outcome, wall_time."""
    return {
        "campaign": run.campaign,
        "index": run.index,
        "situation": run.situation.to_dict(),
        "seed": run.seed,
        "status": run.status,
        "failure_kind": run.failure_kind,
        "outcome": run.outcome.to_dict() if run.outcome is not None else None,
        "wall_time": run.wall_time,
        "replay_of": run.replay_of,
    }


def situation_label(run: RunRecord) -> str:
    """A readable test-case name: ``#INDEX element=bin, ...``."""
    return f"#{run.index} " + ", ".join(f"{e}={b}" for e, b in run.bins.items())


def export_junit(store: Store, out: IO[str], campaign: str | None = None) -> int:
    """JUnit XML: a ``testsuite`` per campaign, a ``testcase`` per run.

    ``fail`` runs get a ``<failure>``, ``error``/``timeout`` runs an ``<error>``, pending
    runs ``<skipped>``; the run's seed and situation id are properties of the case.
    """
    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    out.write('<?xml version="1.0" encoding="UTF-8"?>\n<testsuites name="sitcov">\n')
    n = 0
    for info in infos:
        counts = store.status_counts(info.name)
        total = sum(counts.values())
        time = total_wall_time(store, info.name)  # in SQL: no second decoding pass
        out.write(
            f'  <testsuite name={quoteattr(info.name)} tests="{total}" '
            f'failures="{counts["fail"]}" errors="{counts["error"] + counts["timeout"]}" '
            f'skipped="{counts["pending"]}" time="{time:.3f}" '
            f"timestamp={quoteattr(info.created)}>\n"
        )
        for run in store.iter_runs(info.name):
            out.write(_testcase(run))
            n += 1
        out.write("  </testsuite>\n")
    out.write("</testsuites>\n")
    return n


def _testcase(run: RunRecord) -> str:
    replay = quoteattr(f"sitcov replay {run.campaign}:{run.index}")
    head = (
        f"    <testcase classname={quoteattr('sitcov.' + run.campaign)} "
        f'name={quoteattr(situation_label(run))} time="{(run.wall_time or 0.0):.3f}">\n'
        "      <properties>"
        f'<property name="seed" value="{run.seed}"/>'
        f'<property name="situation_id" value="{run.situation.id}"/>'
        f'<property name="replay" value={replay}/>'
        "</properties>\n"
    )
    body = ""
    outcome = run.outcome
    if run.status == "pending":
        body = '      <skipped message="not run yet"/>\n'
    elif run.status == "fail" and outcome is not None:
        detail = json.dumps(outcome.to_dict(), sort_keys=True)
        body = (
            f"      <failure message={quoteattr(outcome.end_reason)} "
            f"type={quoteattr(outcome.kind)}>"
            f"{escape(detail)}</failure>\n"
        )
    elif run.status in ("error", "timeout") and outcome is not None:
        body = (
            f"      <error message={quoteattr((outcome.message or run.status).splitlines()[0])} "
            f"type={quoteattr(run.status)}>{escape(outcome.message or '')}</error>\n"
        )
    return head + body + "    </testcase>\n"


def export_parquet(store: Store, path: str, campaign: str | None = None) -> int:
    """Write a Parquet file (pyarrow), in row groups of 5,000 runs.

    Raises:
        MissingExtraError: pyarrow is not installed.
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise MissingExtraError("parquet export", "parquet", "pyarrow") from None
    columns, rows = flat_rows(store, campaign)
    types = {
        "index": pa.int64(),
        "seed": pa.int64(),
        "collision": pa.bool_(),
        "aeb_fired": pa.bool_(),
        **{c: pa.float64() for c in ("sim_time", "collision_time", "collision_speed")},
        **{c: pa.float64() for c in ("min_distance", "min_ttc", "pet", "aeb_time", "wall_time")},
        **{c: pa.float64() for c in PROGRESS_COLUMNS[:4]},
        "ego_stationary": pa.bool_(),
    }
    schema = pa.schema([(c, types.get(c, pa.string())) for c in columns])
    n = 0
    with pq.ParquetWriter(path, schema) as writer:
        chunk: list[dict] = []
        for row in rows:
            chunk.append({c: _typed(row[c], types.get(c)) for c in columns})
            if len(chunk) == 5000:
                writer.write_table(pa.Table.from_pylist(chunk, schema=schema))
                n, chunk = n + len(chunk), []
        if chunk or n == 0:
            writer.write_table(pa.Table.from_pylist(chunk, schema=schema))
            n += len(chunk)
    return n


def _typed(value: Any, kind: Any) -> Any:
    if value is None or kind is not None:
        return value
    return value if isinstance(value, str) else json.dumps(value)


def export(store: Store, fmt: str, out: IO[str] | str, campaign: str | None = None) -> int:
    """Export in ``fmt`` (one of :data:`FORMATS`) to a text stream or (parquet) a path."""
    if fmt not in FORMATS:
        raise ConfigError(field="--format", value=fmt, expected=" | ".join(FORMATS))
    if fmt == "parquet":
        if not isinstance(out, str):
            raise ConfigError("parquet export needs --out FILE (it is a binary format)")
        return export_parquet(store, out, campaign)
    if isinstance(out, str):
        with open(out, "w", encoding="utf-8", newline="") as fh:
            return export(store, fmt, fh, campaign)
    writer = {"csv": export_csv, "json": export_json, "junit": export_junit}[fmt]
    return writer(store, out, campaign)
