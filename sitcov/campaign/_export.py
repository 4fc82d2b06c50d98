"""Exports of stored runs: CSV, Parquet, JSON and JUnit XML.

All formats stream the runs from the store (memory stays flat for large campaigns). One
row / test case per run; a run's bins and concrete values become ``bin.ELEMENT`` and
``value.ELEMENT`` columns (mappings such as an intersection situation as JSON text), and
its ``actor_kinds`` and ``conflict_types`` (``;``-separated, see
:mod:`sitcov.analysis._breakdown`) so that failure rates can be broken down by road user,
and ``hit_kind``, the kind of road user the ego collided with (empty without a collision),
then the closest and the hit road user's name, kind, min distance, min TTC and PET
(:mod:`sitcov.campaign._export_actors`; ``--per-actor`` writes one row per run and actor
instead). Parquet columns are typed and the file's metadata names each campaign's setup.
Every format carries each run's ``failure_kind`` (``pass``, a kind of
``sitcov.sim.FAILURE_KINDS``, ``error``, ``timeout``; empty while pending) and its route
progress facts (:data:`PROGRESS_COLUMNS`: route completion, time to goal, blocked and
route-incomplete times, stationary collision, stop reason) and where it collided
(:data:`COLLISION_COLUMNS`: contact point, the ego's heading and speed then, and the run's
largest DRAC); the JSON export has them in the outcome's metrics; the JSON export also
gives each campaign's ``physics``, ``judge`` and ``world_model``, its ``breakdowns``
(failure rates by actor kind and conflict type, and collisions by the road user hit, as
``sitcov summary``) and its ``route_completion`` (mean, goal rate, distribution, as
``sitcov summary``).
"""

from __future__ import annotations

import csv
import shlex
from collections.abc import Iterator
from typing import IO, Any
from xml.sax.saxutils import escape, quoteattr

from sitcov.analysis._breakdown import HIT_UNSTORED, run_hit, run_roles
from sitcov.campaign import _json
from sitcov.campaign._export_actors import (
    ACTOR_COLUMNS,
    BOOL_COLUMNS,
    FLOAT_COLUMNS,
    RUN_COLUMNS,
    actor_rows,
    hit_description,
    run_columns,
)
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
#: Where the ego collided and how hard the run braked at most (``Outcome.metrics``, empty
#: for runs stored before schema 5 or without a collision): the contact point in the map
#: frame [m], the ego's heading [rad] and speed [m/s] at contact, and the run's largest
#: DRAC over every road user [m/s^2] (docs/metrics.md); ``hit_kind`` names the road user.
COLLISION_COLUMNS = (
    "collision_x",
    "collision_y",
    "collision_heading",
    "ego_collision_speed",
    "max_drac",
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
    return _json.dumps(value, sort_keys=True) if isinstance(value, dict | list) else value


def flat_rows(store: Store, campaign: str | None = None) -> tuple[list[str], Iterator[dict]]:
    """The column names and a stream of one flat dict per run."""
    elements = _elements(store, campaign)
    columns = [
        *_BASE_COLUMNS,
        *_TAIL_COLUMNS,
        *PROGRESS_COLUMNS,
        *COLLISION_COLUMNS,
        *RUN_COLUMNS,
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
            row.update(collision_facts(metrics))
            values = run.situation.to_dict()["values"]
            kinds, types = run_roles(values, typing.get(run.campaign))
            row["actor_kinds"], row["conflict_types"] = ";".join(kinds), ";".join(types)
            row["hit_kind"] = _hit_kind(run, values)
            row.update(run_columns(run, values))
            for e in elements:
                row[f"bin.{e}"] = run.bins.get(e)
                row[f"value.{e}"] = _cell(values.get(e))
            yield row

    return columns, rows()


def collision_facts(metrics: dict[str, Any]) -> dict[str, float | None]:
    """The :data:`COLLISION_COLUMNS` of a run's metrics (None where not stored)."""
    point = metrics.get("collision_point")
    x, y = point if isinstance(point, list | tuple) and len(point) == 2 else (None, None)
    return {
        "collision_x": x,
        "collision_y": y,
        "collision_heading": metrics.get("collision_heading"),
        "ego_collision_speed": metrics.get("ego_collision_speed"),
        "max_drac": metrics.get("max_drac"),
    }


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


def export_actors_csv(store: Store, out: IO[str], campaign: str | None = None) -> int:
    """Write the actor table (:data:`ACTOR_COLUMNS`) as CSV; returns the number of rows."""
    writer = csv.DictWriter(out, fieldnames=list(ACTOR_COLUMNS), lineterminator="\n")
    writer.writeheader()
    n = 0
    for row in actor_rows(store.iter_runs(campaign)):
        writer.writerow(row)
        n += 1
    return n


def export_json(store: Store, out: IO[str], campaign: str | None = None) -> int:
    """Write ``{"campaigns": [...], "runs": [...]}`` (full outcomes, no traces)."""
    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    out.write('{"campaigns": ')
    out.write(
        _json.dumps(
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
            sort_keys=True,
        )
    )
    out.write(', "runs": [')
    n = 0
    for run in store.iter_runs(campaign):
        out.write(",\n" if n else "\n")
        out.write(_json.dumps(run_to_json(run), sort_keys=True))
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
    """The run's bins as text: ``element=bin, ...``."""
    return ", ".join(f"{e}={b}" for e, b in run.bins.items())


def export_junit(store: Store, out: IO[str], campaign: str | None = None) -> int:
    """JUnit XML: a ``testsuite`` per campaign, a ``testcase`` per run.

    A case is named by its situation id (``#2``, ``#3``, ... for the second and later runs
    of the same situation in a campaign, in run order), so two builds of the same campaign
    give the same names. ``fail`` runs get a ``<failure>`` whose message is the failure
    kind, what was hit and when (:func:`failure_message`), ``error``/``timeout`` runs an
    ``<error>``, pending runs ``<skipped>``; the run's index, seed, situation id, bins and
    replay command (with ``--db``) are properties of the case.
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
        seen: dict[str, int] = {}
        for run in store.iter_runs(info.name):
            seen[run.situation.id] = seen.get(run.situation.id, 0) + 1
            repeat = seen[run.situation.id]
            name = run.situation.id + (f" #{repeat}" if repeat > 1 else "")
            out.write(_testcase(run, name, store.location))
            n += 1
        out.write("  </testsuite>\n")
    out.write("</testsuites>\n")
    return n


def replay_command(db: str, campaign: str, index: int) -> str:
    """``sitcov replay --db DB CAMPAIGN:INDEX``, quoted for a POSIX shell: runs as printed."""
    return f"sitcov replay --db {shlex.quote(db)} {shlex.quote(f'{campaign}:{index}')}"


def failure_message(run: RunRecord) -> str:
    """What failed, what was hit and when: ``collision with actor2 (pedestrian) at 12.3 s``,
    ``road_departure at 8.1 s`` (the judge's failure kind; its time from the outcome, the
    end of the run if the event ended it and stores no time)."""
    outcome = run.outcome
    if outcome is None:
        return run.failure_kind or run.status
    kind = run.failure_kind or outcome.kind
    if kind in ("collision", "ego_stationary"):
        hit = hit_description(run, run.situation.to_dict()["values"])
        text = f"collision with {hit}" if hit else "collision"
        if kind == "ego_stationary":
            text += " while the ego stood still"
        time = outcome.collision_time
    else:
        text, time = kind, outcome.metrics.get(f"{kind}_time")
    if time is None and outcome.end_reason == kind:  # the event ended the run
        time = outcome.sim_time
    if isinstance(time, int | float) and not isinstance(time, bool):
        return f"{text} at {time:.1f} s"
    return f"{text} (run ended: {outcome.end_reason} at {outcome.sim_time:.1f} s)"


def _testcase(run: RunRecord, name: str, db: str) -> str:
    replay = replay_command(db, run.campaign, run.index)
    head = (
        f"    <testcase classname={quoteattr('sitcov.' + run.campaign)} "
        f'name={quoteattr(name)} time="{(run.wall_time or 0.0):.3f}">\n'
        "      <properties>"
        f'<property name="index" value="{run.index}"/>'
        f'<property name="seed" value="{run.seed}"/>'
        f'<property name="situation_id" value="{run.situation.id}"/>'
        f'<property name="bins" value={quoteattr(situation_label(run))}/>'
        f'<property name="replay" value={quoteattr(replay)}/>'
        "</properties>\n"
    )
    body = ""
    outcome = run.outcome
    if run.status == "pending":
        body = '      <skipped message="not run yet"/>\n'
    elif run.status == "fail" and outcome is not None:
        detail = _json.dumps(outcome.to_dict(), sort_keys=True)
        body = (
            f"      <failure message={quoteattr(failure_message(run))} "
            f"type={quoteattr(run.failure_kind or outcome.kind)}>"
            f"{escape(replay)}\n{escape(detail)}</failure>\n"
        )
    elif run.status in ("error", "timeout") and outcome is not None:
        body = (
            f"      <error message={quoteattr((outcome.message or run.status).splitlines()[0])} "
            f"type={quoteattr(run.status)}>{escape(replay)}\n"
            f"{escape(outcome.message or '')}</error>\n"
        )
    return head + body + "    </testcase>\n"


def export_parquet(
    store: Store, path: str, campaign: str | None = None, *, per_actor: bool = False
) -> int:
    """Write a Parquet file (pyarrow), in row groups of 5,000 rows: the run table, or with
    ``per_actor`` the actor table (:data:`ACTOR_COLUMNS`).

    Columns are typed: integers, booleans (``collision``, ``aeb_fired``, ``collided``, ...),
    floats (times, distances, TTC, PET and every ``value.ELEMENT`` whose bins are all
    numbers), text otherwise (mappings as JSON). The schema's metadata gives the exported
    campaigns' setup (:func:`parquet_metadata`).

    Raises:
        MissingExtraError: pyarrow is not installed.
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise MissingExtraError("parquet export", "parquet", "pyarrow") from None
    kinds: dict[str, str] = {
        "index": "int",
        "seed": "int",
        "collision": "bool",
        "aeb_fired": "bool",
    }
    kinds.update(dict.fromkeys(_FLOAT_OUTCOMES, "float"))
    kinds.update(dict.fromkeys(FLOAT_COLUMNS, "float"))
    kinds.update(dict.fromkeys(BOOL_COLUMNS, "bool"))
    kinds.update(dict.fromkeys(PROGRESS_COLUMNS[:4], "float"))
    kinds.update(dict.fromkeys(COLLISION_COLUMNS, "float"))
    kinds["ego_stationary"] = "bool"
    if per_actor:
        columns, rows = list(ACTOR_COLUMNS), actor_rows(store.iter_runs(campaign))
    else:
        columns, rows = flat_rows(store, campaign)
        kinds.update({f"value.{e}": k for e, k in value_kinds(store, campaign).items()})
    arrow = {"int": pa.int64(), "float": pa.float64(), "bool": pa.bool_()}
    schema = pa.schema(
        [(c, arrow.get(kinds.get(c, ""), pa.string())) for c in columns],
        metadata=parquet_metadata(store, campaign),
    )
    n = 0
    with pq.ParquetWriter(path, schema) as writer:
        chunk: list[dict] = []
        for row in rows:
            chunk.append({c: _typed(row[c], kinds.get(c), c, store) for c in columns})
            if len(chunk) == 5000:
                writer.write_table(pa.Table.from_pylist(chunk, schema=schema))
                n, chunk = n + len(chunk), []
        if chunk or n == 0:
            writer.write_table(pa.Table.from_pylist(chunk, schema=schema))
            n += len(chunk)
    return n


#: Outcome and run columns stored as floats (seconds, metres, metres per second).
_FLOAT_OUTCOMES = (
    "sim_time",
    "collision_time",
    "collision_speed",
    "min_distance",
    "min_ttc",
    "pet",
    "aeb_time",
    "wall_time",
)


def value_kinds(store: Store, campaign: str | None = None) -> dict[str, str]:
    """Element -> ``float`` if every bin of it in the exported campaigns is a number (a
    point or a range), ``bool`` if every bin is a boolean, else ``text``."""
    seen: dict[str, set[str]] = {}
    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    for info in infos:
        for axis in info.hyperspace.get("axes", []):
            for element in axis.get("elements", []):
                kinds = seen.setdefault(str(element.get("name")), set())
                for b in element.get("bins", []):
                    kinds.add(_bin_kind(b))
    return {e: next(iter(k)) if len(k) == 1 else "text" for e, k in seen.items()}


def _bin_kind(spec: Any) -> str:
    if not isinstance(spec, dict):
        return "text"
    if spec.get("range") is not None:
        return "float"
    value = spec.get("value")
    if isinstance(value, bool):
        return "bool"
    return "float" if isinstance(value, int | float) else "text"


def parquet_metadata(store: Store, campaign: str | None = None) -> dict[bytes, bytes]:
    """Schema metadata: ``sitcov.generator``, ``sitcov.judge``, ``sitcov.physics``,
    ``sitcov.world_model`` and ``sitcov.version`` (the campaigns' value, or a JSON list when
    exported campaigns differ), ``sitcov.campaigns`` (JSON: each campaign's name, setup,
    seed, runs and creation time) and ``sitcov.exported_by`` (this sitcov's version)."""
    from sitcov._version import __version__

    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    campaigns = [
        {
            "name": c.name,
            "generator": c.generator,
            **campaign_setup(c),
            "sitcov_version": c.sitcov_version,
            "seed": c.config.get("seed"),
            "runs": c.config.get("runs"),
            "created": c.created,
        }
        for c in infos
    ]
    meta = {"sitcov.campaigns": _json.dumps(campaigns, sort_keys=True)}
    for key, field in (
        ("generator", "generator"),
        ("judge", "judge"),
        ("physics", "physics"),
        ("world_model", "world_model"),
        ("version", "sitcov_version"),
    ):
        distinct = list(dict.fromkeys(_json.dumps(c[field]) for c in campaigns))
        meta[f"sitcov.{key}"] = (
            str(_json.loads(distinct[0])) if len(distinct) == 1 else f"[{', '.join(distinct)}]"
        )
    meta["sitcov.exported_by"] = __version__
    return {k.encode(): v.encode() for k, v in meta.items()}


def _typed(value: Any, kind: str | None, column: str, store: Store) -> Any:
    """``value`` as the Parquet column's type (None stays null; mappings become JSON)."""
    if value is None:
        return None
    if kind in ("float", "int"):
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise StoreError(
                f"{store.location}: column {column!r}: expected a number, got {value!r} "
                "(damaged database?)"
            )
        return float(value) if kind == "float" else int(value)
    if kind == "bool":
        return bool(value)
    return value if isinstance(value, str) else _json.dumps(value, sort_keys=True)


def export(
    store: Store,
    fmt: str,
    out: IO[str] | str,
    campaign: str | None = None,
    *,
    per_actor: bool = False,
) -> int:
    """Export in ``fmt`` (one of :data:`FORMATS`) to a text stream or (parquet) a path;
    with ``per_actor`` (csv, parquet) the actor table, one row per run and actor."""
    if fmt not in FORMATS:
        raise ConfigError(field="--format", value=fmt, expected=" | ".join(FORMATS))
    if per_actor and fmt not in ("csv", "parquet"):
        raise ConfigError(
            f"--per-actor works with --format csv or parquet, not {fmt} (the json export "
            "has every actor in each run's outcome.metrics.actors)"
        )
    if fmt == "parquet":
        if not isinstance(out, str):
            raise ConfigError("parquet export needs --out FILE (it is a binary format)")
        return export_parquet(store, out, campaign, per_actor=per_actor)
    if isinstance(out, str):
        with open(out, "w", encoding="utf-8", newline="") as fh:
            return export(store, fmt, fh, campaign, per_actor=per_actor)
    if per_actor:
        return export_actors_csv(store, out, campaign)
    writer = {"csv": export_csv, "json": export_json, "junit": export_junit}[fmt]
    return writer(store, out, campaign)
