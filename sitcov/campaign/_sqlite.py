"""The SQLite campaign store: one file, WAL journal, versioned schema with migrations.

Durability: the file uses ``journal_mode=WAL`` with ``synchronous=NORMAL``. In WAL mode a
committed transaction survives a crash of the process (SIGKILL, an exception, a power-off
of the *program*); only an operating-system crash or power loss can lose the last few
commits, and never corrupts the file. A lost commit is harmless here: the batch plan and
the generator state are one transaction, so they are lost together, and a lost result
leaves its run ``pending``, which resume re-runs with the same situation and seed. FULL
would fsync on every result (one per run) for no gain in what a resumed campaign contains.

Schema versions: ``MIGRATIONS[i]`` upgrades version ``i`` to ``i + 1``; a new file runs
them all. A file from a newer sitcov is refused with a clear error. Opening a file at the
current version writes nothing, so readers (``summary``, ``report``, ``export``) work on a
read-only file and never wait for a running campaign's write transactions (WAL readers).

Concurrent writers: a campaign being run holds a row of ``campaign_locks`` (owner pid,
host, start, heartbeat; see :mod:`sitcov.campaign._lock`). The row is taken in a
``BEGIN IMMEDIATE`` transaction - SQLite's write lock makes check-and-take atomic, so of
two processes taking a campaign (or a stale owner's row) at once exactly one wins - and
every later write of the run loop checks, in its own transaction, that the row still
holds this process's token. The table is operational state, created when first needed,
not part of the versioned schema (older sitcov versions still open the file).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import sqlite3
import threading
import time
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sitcov.campaign import _json, _lock
from sitcov.campaign._lock import LockOwner
from sitcov.campaign._records import RunRecord
from sitcov.campaign._store import (
    CampaignBusyError,
    CampaignInfo,
    PlannedRun,
    Store,
    StoreError,
    _statuses,
)
from sitcov.hyperspace import Situation
from sitcov.sim import Outcome, Trace

#: Outcome fields stored as their own columns (for SQL queries); the full outcome is JSON.
OUTCOME_COLUMNS = (
    "end_reason",
    "sim_time",
    "collision",
    "collision_time",
    "collision_speed",
    "min_distance",
    "min_ttc",
    "pet",
    "aeb_fired",
    "aeb_time",
    "message",
)
#: Run facts kept in ``outcome.metrics`` and copied to columns of their own (schema 5, for
#: SQL queries; readers decode the outcome): where the ego collided (map frame [m]), its
#: heading then [rad], the kind of road user hit, the run's largest DRAC [m/s^2].
METRIC_COLUMNS = ("collision_x", "collision_y", "collision_heading", "collision_kind", "max_drac")

_V1 = """
CREATE TABLE schema_version (version INTEGER NOT NULL);
CREATE TABLE campaigns (
    name TEXT PRIMARY KEY,
    config TEXT NOT NULL,
    hyperspace TEXT NOT NULL,
    sitcov_version TEXT NOT NULL,
    created TEXT NOT NULL,
    generator TEXT NOT NULL,
    generator_state TEXT,
    batch_start INTEGER NOT NULL DEFAULT 0,
    tags TEXT NOT NULL DEFAULT '{}'
);
CREATE TABLE runs (
    campaign TEXT NOT NULL REFERENCES campaigns(name),
    idx INTEGER NOT NULL,
    situation_id TEXT NOT NULL,
    bins TEXT NOT NULL,
    vals TEXT NOT NULL,
    seed INTEGER NOT NULL,
    status TEXT NOT NULL,
    end_reason TEXT,
    sim_time REAL,
    collision INTEGER,
    collision_time REAL,
    collision_speed REAL,
    min_distance REAL,
    min_ttc REAL,
    pet REAL,
    aeb_fired INTEGER,
    aeb_time REAL,
    message TEXT,
    outcome TEXT,
    wall_time REAL,
    trace TEXT,
    PRIMARY KEY (campaign, idx)
);
CREATE INDEX runs_by_status ON runs (campaign, status);
"""

_V2 = """
ALTER TABLE runs ADD COLUMN replay_of TEXT;
CREATE INDEX runs_by_situation ON runs (situation_id);
"""

# Failure kinds and world-model versions: every run failed before by collision; campaigns
# stored before have no world version (NULL = the legacy world model).
_V3 = """
ALTER TABLE runs ADD COLUMN failure_kind TEXT;
UPDATE runs SET failure_kind = CASE status WHEN 'fail' THEN 'collision'
    WHEN 'pending' THEN NULL ELSE status END;
ALTER TABLE campaigns ADD COLUMN world_version INTEGER;
"""

#: Every stored JSON cell, by table (rewritten by :func:`_v4_strict_json`).
_JSON_CELLS: dict[str, tuple[str, ...]] = {
    "campaigns": ("config", "hyperspace", "generator_state", "tags"),
    "runs": ("bins", "vals", "outcome", "trace"),
}


def _v4_strict_json(db: Any, location: str) -> None:
    """Version 4: cells holding the bare ``Infinity``/``NaN`` tokens that sitcov wrote before
    (not JSON: SQLite's JSON functions reject them, and every summary with them) are
    rewritten in the stored form of :mod:`sitcov.campaign._json`. The file is checked first
    (``PRAGMA quick_check``): a damaged file is refused unchanged, never half-repaired."""
    problems = [r[0] for r in db.execute("PRAGMA quick_check").fetchall()]
    if problems != ["ok"]:
        raise StoreError(
            f"{location}: damaged database, refused before changing it "
            f"(integrity check: {' '.join(' '.join(problems).split())[:160]})"
        )
    for table, columns in _JSON_CELLS.items():
        for column in columns:
            rows = db.execute(
                f"SELECT rowid, {column} FROM {table} "
                f"WHERE {column} IS NOT NULL AND NOT json_valid({column})"
            ).fetchall()
            fixed = []
            for rowid, text in rows:
                with _decoding(location, f"{table}.{column} of row {rowid}"):
                    fixed.append((_dumps(_json.loads(text)), rowid))
            db.executemany(f"UPDATE {table} SET {column} = ? WHERE rowid = ?", fixed)


def _v5_collision_and_drac(db: Any, location: str) -> None:
    """Version 5: columns for the collision location (x, y [m], the ego's heading [rad],
    the kind of road user hit) and the run's largest DRAC [m/s^2] (:data:`METRIC_COLUMNS`).
    Filled from what older runs stored: ``collision_kind`` from the outcome's metrics (the
    paper's two-car runs hit the car), the point from a stored trace (the midpoint of the
    two centres, what traces held then); the rest stays NULL (not recorded then).

    A function, not SQL, so that a read-only version-4 file is read as it is: readers
    decode the outcome JSON and never select these columns."""
    have = {row[1] for row in db.execute("PRAGMA table_info(runs)").fetchall()}
    for column, kind in zip(METRIC_COLUMNS, ("REAL", "REAL", "REAL", "TEXT", "REAL"), strict=True):
        if column not in have:  # a file whose version was set back by hand may have them
            db.execute(f"ALTER TABLE runs ADD COLUMN {column} {kind}")
    db.execute(
        "UPDATE runs SET "
        "collision_kind = coalesce(json_extract(outcome, '$.metrics.collision_kind'), "
        "  CASE WHEN collision THEN 'car' END), "
        "collision_x = json_extract(trace, '$.meta.collision_point[0]'), "
        "collision_y = json_extract(trace, '$.meta.collision_point[1]') "
        "WHERE collision"
    )


#: ``MIGRATIONS[i]`` takes a version-``i`` file to version ``i + 1``: SQL statements, or a
#: function of (connection, location) for what SQL cannot express or what a reader of a
#: read-only file can do without (data repairs, columns readers never select).
MIGRATIONS: tuple[Any, ...] = (_V1, _V2, _V3, _v4_strict_json, _v5_collision_and_drac)
#: The schema version this sitcov writes.
SCHEMA_VERSION = len(MIGRATIONS)

#: Seconds a statement waits for another connection's write lock before giving up.
BUSY_TIMEOUT = 30.0

log = logging.getLogger("sitcov.campaign")

_LOCKS = """
CREATE TABLE IF NOT EXISTS campaign_locks (
    campaign TEXT PRIMARY KEY,
    token TEXT NOT NULL,
    pid INTEGER NOT NULL,
    host TEXT NOT NULL,
    pid_start INTEGER,
    started TEXT NOT NULL,
    heartbeat REAL NOT NULL
)"""
_LOCK_FIELDS = "campaign, token, pid, host, pid_start, started, heartbeat"

_RUN_FIELDS = "campaign, idx, situation_id, bins, vals, seed, status, outcome, wall_time, replay_of"


def _dumps(obj: Any) -> str:
    """Compact strict JSON that keeps key order (generator states and bins may rely on it);
    non-finite floats are stored as documented in :mod:`sitcov.campaign._json`."""
    return _json.dumps(obj, separators=(",", ":"))


class SQLiteStore(Store):
    """A store in one SQLite file (see the module docstring for durability and schema).

    Args:
        path: the database file; created with the current schema if absent.
    """

    def __init__(self, path: Path) -> None:
        self.path = Path(path)
        self.location = str(self.path)
        if self.path.is_dir():
            raise StoreError(f"{self.location}: is a directory, expected a database file")
        if not self.path.parent.is_dir():
            raise StoreError(f"{self.location}: directory {str(self.path.parent)!r} does not exist")
        self._configs: dict[str, dict[str, Any]] = {}
        self._tokens: dict[str, str] = {}  # campaign -> token of the lock this store holds
        self._checked = False  # see check()
        try:
            self._connect()
        except (sqlite3.DatabaseError, UnicodeDecodeError) as exc:  # a damaged schema page
            operational = _operational(self.location, exc)
            if operational is not None:
                raise operational from None
            detail = " ".join(str(exc).split())[:200]
            raise StoreError(f"{self.location}: not a sitcov database ({detail})") from None
        self._db = _Guarded(self._db, self.location)  # damaged pages: one-line StoreError

    def _connect(self) -> None:
        """Open the file read-write; a file that cannot be written (read-only file, directory
        or file system) is opened read-only, so reading commands still work on it."""
        try:
            self._open(str(self.path), read_only=False)
            return
        except sqlite3.OperationalError:
            writable = os.access(self.path, os.W_OK) and os.access(self.path.parent, os.W_OK)
            if writable or not self.path.is_file():
                raise
        uri = self.path.resolve().as_uri() + "?mode=ro"
        try:
            self._open(uri, read_only=True)
        except sqlite3.OperationalError:  # WAL without a writable directory for its -shm:
            self._open(uri + "&immutable=1", read_only=True)  # nobody here can change it

    def _open(self, target: str, *, read_only: bool) -> None:
        self._db = sqlite3.connect(
            target, uri=read_only, isolation_level=None, timeout=BUSY_TIMEOUT
        )
        try:
            if not read_only:
                self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute("PRAGMA foreign_keys=ON")
            self._migrate(read_only)
        except BaseException:
            self._db.close()
            raise

    # -- schema ------------------------------------------------------------------------------
    def schema_version(self) -> int:
        """The file's schema version (0 for an empty file)."""
        has = self._db.execute(
            "SELECT 1 FROM sqlite_master WHERE type='table' AND name='schema_version'"
        ).fetchone()
        if not has:
            tables = self._db.execute("SELECT count(*) FROM sqlite_master").fetchone()[0]
            if tables:
                raise StoreError(f"{self.location}: not a sitcov database (no schema_version)")
            return 0
        row = self._db.execute("SELECT max(version) FROM schema_version").fetchone()
        return int(row[0] or 0)

    def _migrate(self, read_only: bool = False) -> None:
        version = self.schema_version()
        if version == SCHEMA_VERSION:
            return  # nothing to write: readers never take the write lock
        if (
            read_only
            and 0 < version < SCHEMA_VERSION
            and all(callable(step) for step in MIGRATIONS[version:])
        ):
            return  # only data repairs or unread columns are missing: read as it is
        self._db.execute("BEGIN IMMEDIATE")
        try:
            version = self.schema_version()
            if version > SCHEMA_VERSION:
                raise StoreError(
                    f"{self.location}: database schema version {version} is newer than this "
                    f"sitcov supports ({SCHEMA_VERSION}); upgrade sitcov to open it"
                )
            for target in range(version, SCHEMA_VERSION):
                step = MIGRATIONS[target]
                if callable(step):
                    step(self._db, self.location)
                else:
                    for statement in step.split(";"):
                        if statement.strip():
                            self._db.execute(statement)
                self._db.execute("DELETE FROM schema_version")
                self._db.execute("INSERT INTO schema_version VALUES (?)", (target + 1,))
            self._db.execute("COMMIT")
        except BaseException:
            if self._db.in_transaction:  # SQLite may have rolled back already (disk full)
                self._db.execute("ROLLBACK")
            raise

    # -- campaigns ---------------------------------------------------------------------------
    def _info(self, row: sqlite3.Row | tuple) -> CampaignInfo:
        with _decoding(self.location, f"campaign {row[0]!r}"):
            return self._decode_info(row)

    def _decode_info(self, row: sqlite3.Row | tuple) -> CampaignInfo:
        name, config, hyper, version, created, gen, state, batch_start, tags, world = row
        return CampaignInfo(
            name=name,
            config=_json.loads(config),
            hyperspace=_json.loads(hyper),
            sitcov_version=version,
            created=created,
            generator=gen,
            generator_state=_json.loads(state) if state is not None else None,
            batch_start=int(batch_start),
            tags=_json.loads(tags),
            world_version=world,
        )

    _CAMPAIGN_COLS = (
        "name, config, hyperspace, sitcov_version, created, generator, generator_state, "
        "batch_start, tags, world_version"
    )

    def campaigns(self) -> list[CampaignInfo]:
        rows = self._db.execute(
            f"SELECT {self._CAMPAIGN_COLS} FROM campaigns ORDER BY created, name"
        ).fetchall()
        return [self._info(r) for r in rows]

    def find_campaign(self, name: str) -> CampaignInfo | None:
        row = self._db.execute(
            f"SELECT {self._CAMPAIGN_COLS} FROM campaigns WHERE name = ?", (name,)
        ).fetchone()
        return self._info(row) if row else None

    def create_campaign(self, info: CampaignInfo, runs: Sequence[PlannedRun] = ()) -> None:
        with self._transaction():
            if self.find_campaign(info.name) is not None:
                raise StoreError(f"{self.location}: campaign {info.name!r} already exists")
            self._db.execute(
                f"INSERT INTO campaigns ({self._CAMPAIGN_COLS}) VALUES (?,?,?,?,?,?,?,?,?,?)",
                (
                    info.name,
                    _dumps(dict(info.config)),
                    _dumps(dict(info.hyperspace)),
                    info.sitcov_version,
                    info.created,
                    info.generator,
                    _dumps(info.generator_state) if info.generator_state is not None else None,
                    runs[0].index if runs else info.batch_start,
                    _dumps(dict(info.tags)),
                    info.world_version,
                ),
            )
            self._insert_runs(info.name, runs)

    def update_config(self, name: str, config: Mapping[str, Any]) -> None:
        self.campaign(name)
        with self._transaction():
            self._db.execute(
                "UPDATE campaigns SET config = ? WHERE name = ?", (_dumps(dict(config)), name)
            )
        self._configs.pop(name, None)

    def check(self) -> None:
        """``PRAGMA integrity_check`` (pages and indexes: ``quick_check`` misses a damaged
        index that the summary's queries then read), then decode every campaign and every
        run with its trace as the readers do; once per store object (a campaign writes
        only after it: ``sitcov run`` on a damaged file leaves it byte-identical).

        Cost: one pass over the file, about 5 CPU-s per 100,000 runs (83,360 runs: 3.9
        CPU-s, ``SQLiteStore.check`` timed with ``time.process_time``)."""
        if self._checked:
            return
        problems = [r[0] for r in self._db.execute("PRAGMA integrity_check").fetchall()]
        if problems != ["ok"]:
            detail = " ".join(" ".join(problems).split())[:160]
            raise StoreError(f"{self.location}: damaged database (integrity check: {detail})")
        self.campaigns()
        cursor = self._db.execute(f"SELECT {_RUN_FIELDS}, trace FROM runs ORDER BY campaign, idx")
        while rows := cursor.fetchmany(500):
            for row in rows:
                self._record(row[:-1], row[-1])
        self._checked = True

    def mark_checked(self) -> None:
        self._checked = True

    # -- concurrent writers ------------------------------------------------------------------
    def lock_campaign(self, name: str, *, stale_after: float = _lock.STALE_AFTER) -> CampaignLock:
        """Take campaign ``name`` for this process (see the module docstring).

        Raises:
            CampaignBusyError: another live process holds it (the message names it).
        """
        me = LockOwner.me(name)
        with self._transaction():
            self._db.execute(_LOCKS)
            row = self._db.execute(
                f"SELECT {_LOCK_FIELDS} FROM campaign_locks WHERE campaign = ?", (name,)
            ).fetchone()
            previous = LockOwner(*row) if row else None
            if previous is not None and previous.alive(stale_after):
                raise CampaignBusyError(
                    f"{self.location}: campaign {name!r} is being run by another process, "
                    f"{previous.describe()}; wait for it to end, or stop it and run again "
                    "to resume"
                )
            self._db.execute(
                f"INSERT OR REPLACE INTO campaign_locks ({_LOCK_FIELDS}) VALUES (?,?,?,?,?,?,?)",
                (name, me.token, me.pid, me.host, me.pid_start, me.started, me.heartbeat),
            )
        if previous is not None:
            log.warning("took over campaign %r from a dead owner: %s", name, previous.describe())
        _lock.HELD.add(me.token)
        self._tokens[name] = me.token
        return CampaignLock(self, me, previous)

    def lock_owner(self, name: str) -> LockOwner | None:
        """The recorded owner of campaign ``name`` (alive or not), None if there is none."""
        has = self._db.execute(
            "SELECT 1 FROM sqlite_master WHERE type='table' AND name='campaign_locks'"
        ).fetchone()
        if not has:
            return None
        row = self._db.execute(
            f"SELECT {_LOCK_FIELDS} FROM campaign_locks WHERE campaign = ?", (name,)
        ).fetchone()
        return LockOwner(*row) if row else None

    def _still_mine(self, name: str) -> None:
        """In a write transaction: refresh the heartbeat; refuse if the lock was taken over."""
        token = self._tokens.get(name)
        if token is None:
            return  # written outside run_campaign (tests, tools): no lock to keep
        cur = self._db.execute(
            "UPDATE campaign_locks SET heartbeat = ? WHERE campaign = ? AND token = ?",
            (time.time(), name, token),
        )
        if cur.rowcount != 1:
            owner = self.lock_owner(name)
            who = owner.describe() if owner else "nobody"
            raise CampaignBusyError(
                f"{self.location}: campaign {name!r} was taken over by another process "
                f"({who}) while this one ran it; stopped without writing more"
            )

    def _unlock(self, name: str, token: str) -> None:
        self._tokens.pop(name, None)
        _lock.HELD.discard(token)
        # a row left behind (database gone bad) belongs to a dead owner: it is stale anyway
        with contextlib.suppress(StoreError, sqlite3.Error), self._transaction():
            self._db.execute(
                "DELETE FROM campaign_locks WHERE campaign = ? AND token = ?", (name, token)
            )

    # -- runs --------------------------------------------------------------------------------
    def _transaction(self) -> _Transaction:
        return _Transaction(self._db)

    def _insert_runs(self, name: str, runs: Sequence[PlannedRun]) -> None:
        self._db.executemany(
            "INSERT INTO runs (campaign, idx, situation_id, bins, vals, seed, status, replay_of)"
            " VALUES (?,?,?,?,?,?,'pending',?)",
            [
                (
                    name,
                    r.index,
                    r.situation.id,
                    _dumps(dict(r.situation.bins)),
                    _dumps(r.situation.to_dict()["values"]),
                    int(r.seed),
                    r.replay_of,
                )
                for r in runs
            ],
        )

    def plan_batch(
        self,
        name: str,
        generator_state: Mapping[str, Any] | None,
        runs: Sequence[PlannedRun],
    ) -> None:
        with self._transaction():
            cur = self._db.execute(
                "UPDATE campaigns SET generator_state = ?, batch_start = ? WHERE name = ?",
                (
                    _dumps(generator_state) if generator_state is not None else None,
                    runs[0].index if runs else self.campaign(name).batch_start,
                    name,
                ),
            )
            if cur.rowcount != 1:
                raise StoreError(f"{self.location}: no campaign {name!r}")
            self._insert_runs(name, runs)
            self._still_mine(name)

    def record_result(self, name: str, index: int, outcome: Outcome, wall_time: float) -> None:
        data = outcome.to_dict()
        trace = outcome.trace
        values = [data[c] for c in OUTCOME_COLUMNS] + _metric_columns(data["metrics"])
        with self._transaction():
            cur = self._db.execute(
                "UPDATE runs SET status = ?, "
                + ", ".join(f"{c} = ?" for c in (*OUTCOME_COLUMNS, *METRIC_COLUMNS))
                + ", failure_kind = ?, outcome = ?, wall_time = ?, trace = ?"
                " WHERE campaign = ? AND idx = ?",
                (
                    outcome.status,
                    *values,
                    outcome.kind,
                    _dumps(data),
                    float(wall_time),
                    _dumps(_trace_dict(trace)) if trace is not None else None,
                    name,
                    int(index),
                ),
            )
            if cur.rowcount != 1:
                raise StoreError(f"{self.location}: no run {name}:{index}")
            self._still_mine(name)

    def _where(
        self, campaign: str | None, status: str | Sequence[str] | None, start: int = 0
    ) -> tuple[str, list[Any]]:
        clauses, params = [], []
        if campaign is not None:
            clauses.append("campaign = ?")
            params.append(campaign)
        wanted = _statuses(status)
        if wanted is not None:
            clauses.append(f"status IN ({','.join('?' * len(wanted))})")
            params.extend(wanted)
        if start:
            clauses.append("idx >= ?")
            params.append(int(start))
        return (" WHERE " + " AND ".join(clauses)) if clauses else "", params

    def _config(self, name: str) -> dict[str, Any]:
        if name not in self._configs:
            info = self.find_campaign(name)
            self._configs[name] = dict(info.config) if info else {}
        return self._configs[name]

    def _record(self, row: tuple, trace: str | None = None) -> RunRecord:
        with _decoding(self.location, f"run {row[0]}:{row[1]}"):
            return self._decode_record(row, trace)

    def _decode_record(self, row: tuple, trace: str | None = None) -> RunRecord:
        name, idx, _sid, bins, vals, seed, status, outcome, wall, replay_of = row
        _typed(name, str), _typed(status, str), _typed(replay_of, (str, type(None)))
        _typed(wall, (int, float, type(None)))  # a damaged cell may come back as a blob
        out = None
        if outcome is not None:
            data = _json.loads(outcome)
            if trace is not None:
                data["trace"] = _json.loads(trace)
            out = Outcome.from_dict(data)
        return RunRecord(
            campaign=name,
            index=int(idx),
            situation=Situation(bins=_json.loads(bins), values=_json.loads(vals)),
            seed=int(seed),
            status=status,
            outcome=out,
            wall_time=wall,
            config=self._config(name),
            replay_of=replay_of,
        )

    def iter_runs(
        self,
        campaign: str | None = None,
        status: str | Sequence[str] | None = None,
        *,
        start: int = 0,
    ) -> Iterator[RunRecord]:
        where, params = self._where(campaign, status, start)
        # A separate cursor streams rows; 500 at a time keeps memory flat.
        cursor = self._db.execute(
            f"SELECT {_RUN_FIELDS} FROM runs{where} ORDER BY campaign, idx", params
        )
        while True:
            rows = cursor.fetchmany(500)
            if not rows:
                return
            for row in rows:
                yield self._record(row)

    def get_run(self, campaign: str, index: int, *, with_trace: bool = True) -> RunRecord:
        row = self._db.execute(
            f"SELECT {_RUN_FIELDS}, trace FROM runs WHERE campaign = ? AND idx = ?",
            (campaign, int(index)),
        ).fetchone()
        if row is None:
            self.campaign(campaign)
            raise StoreError(f"{self.location}: campaign {campaign!r} has no run {index}")
        return self._record(row[:-1], row[-1] if with_trace else None)

    def count_runs(
        self, campaign: str | None = None, status: str | Sequence[str] | None = None
    ) -> int:
        where, params = self._where(campaign, status)
        return int(self._db.execute(f"SELECT count(*) FROM runs{where}", params).fetchone()[0])

    def close(self) -> None:
        self._db.close()


class CampaignLock:
    """A held campaign lock: a heartbeat thread keeps it fresh until :meth:`release`.

    Attributes:
        owner: this process's owner record.
        previous: the dead owner whose lock was taken over, None if the campaign was free.
    """

    def __init__(self, store: SQLiteStore, owner: LockOwner, previous: LockOwner | None) -> None:
        self._store = store
        self.owner = owner
        self.previous = previous
        self._stop = threading.Event()
        self._thread = threading.Thread(
            target=_heartbeat,
            args=(str(store.path), owner.campaign, owner.token, self._stop),
            name=f"sitcov-lock-{owner.campaign}",
            daemon=True,
        )
        self._thread.start()

    def release(self) -> None:
        """Stop the heartbeat and delete the lock row (if it is still this process's)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join(timeout=2 * BUSY_TIMEOUT)
        self._store._unlock(self.owner.campaign, self.owner.token)

    def __enter__(self) -> CampaignLock:
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _heartbeat(path: str, campaign: str, token: str, stop: threading.Event) -> None:
    """Refresh a lock's heartbeat every ``HEARTBEAT`` s from a connection of its own (runs
    may take longer than the staleness limit; a lock taken over ends the thread)."""
    try:
        db = sqlite3.connect(path, isolation_level=None, timeout=BUSY_TIMEOUT)
    except sqlite3.Error:
        return
    try:
        while not stop.wait(_lock.HEARTBEAT):
            try:
                cur = db.execute(
                    "UPDATE campaign_locks SET heartbeat = ? WHERE campaign = ? AND token = ?",
                    (time.time(), campaign, token),
                )
            except sqlite3.Error:
                continue  # busy or full now; the run loop's own writes report real trouble
            if cur.rowcount != 1:
                return  # taken over: the run loop's next write stops the campaign
    finally:
        db.close()


def _operational(location: str, exc: BaseException) -> StoreError | None:
    """The one-line error for a file that cannot be used now (locked, read-only, disk full,
    I/O error, missing directory), None for anything else (damage)."""
    text = str(exc).lower()
    if "locked" in text or "busy" in text:
        return StoreError(
            f"{location}: the database is locked by another connection (waited "
            f"{BUSY_TIMEOUT:g} s); close the program holding it and try again"
        )
    if "readonly" in text or "read-only" in text:
        return StoreError(
            f"{location}: cannot write: the database file or its directory is read-only"
        )
    if "disk is full" in text or "database or disk is full" in text:
        return StoreError(
            f"{location}: the disk is full; nothing half-written was kept (free some space, "
            "then run the same command again to resume)"
        )
    if "disk i/o error" in text:
        return StoreError(f"{location}: disk I/O error while using the database ({exc})")
    if "unable to open" in text:
        return StoreError(f"{location}: cannot open the file ({exc})")
    return None


def _damaged(location: str, what: str, exc: BaseException) -> StoreError:
    """The one-line error for a file whose pages or stored values cannot be read back."""
    detail = " ".join(f"{type(exc).__name__}: {exc}".split())[:200]
    return StoreError(f"{location}: damaged database, {what} cannot be read ({detail})")


@contextmanager
def _decoding(location: str, what: str) -> Iterator[None]:
    """Turn a stored value that no longer decodes (JSON, UTF-8, fields) into a StoreError."""
    try:
        yield
    except (ValueError, TypeError, KeyError, AttributeError) as exc:
        raise _damaged(location, what, exc) from None


class _Guarded:
    """A sqlite3 connection whose DatabaseErrors (damaged pages) become one-line StoreErrors.

    Every statement and every fetch goes through :meth:`_call`, so a damaged page found
    while streaming rows is reported as cleanly as one found when the query starts.
    """

    def __init__(self, target: Any, location: str) -> None:
        self._target = target
        self._location = location

    def _call(self, method: str, *args: Any) -> Any:
        try:
            result = getattr(self._target, method)(*args)
        except sqlite3.DatabaseError as exc:
            operational = _operational(self._location, exc)
            raise (operational or _damaged(self._location, "a page", exc)) from None
        return _Guarded(result, self._location) if isinstance(result, sqlite3.Cursor) else result

    def execute(self, *args: Any) -> Any:
        return self._call("execute", *args)

    def executemany(self, *args: Any) -> Any:
        return self._call("executemany", *args)

    def fetchone(self) -> Any:
        return self._call("fetchone")

    def fetchall(self) -> Any:
        return self._call("fetchall")

    def fetchmany(self, size: int) -> Any:
        return self._call("fetchmany", size)

    def __getattr__(self, name: str) -> Any:  # rowcount, in_transaction, close, ...
        return getattr(self._target, name)


def _typed(value: Any, types: type | tuple[type, ...]) -> None:
    """Raise TypeError (reported as damage by :func:`_decoding`) for a mistyped cell."""
    if not isinstance(value, types):
        raise TypeError(f"a stored cell holds {type(value).__name__} {value!r:.40}")


def _metric_columns(metrics: Mapping[str, Any]) -> list[Any]:
    """The :data:`METRIC_COLUMNS` values of an outcome's metrics (None where absent or not
    a number: a column holds what SQL can compare)."""
    point = metrics.get("collision_point")
    xy = point if isinstance(point, list | tuple) and len(point) == 2 else (None, None)
    kind = metrics.get("collision_kind")
    return [
        *(_real(v) for v in xy),
        _real(metrics.get("collision_heading")),
        kind if isinstance(kind, str) else None,
        _real(metrics.get("max_drac")),
    ]


def _real(value: Any) -> float | None:
    """A finite number as a float, anything else None."""
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None


def _trace_dict(trace: Trace) -> dict[str, Any]:
    """The stored form of a trace; every actor's rows too (the top-down pictures draw them)."""
    data = {"ego": trace.ego, "ov": trace.ov, "meta": trace.meta}
    if trace.actors:
        data["actors"] = trace.actors
    return data


class _Transaction:
    """``BEGIN IMMEDIATE`` ... ``COMMIT`` (``ROLLBACK`` on error); re-entrant-safe."""

    def __init__(self, db: sqlite3.Connection) -> None:
        self._db = db
        self._outer = False

    def __enter__(self) -> None:
        if not self._db.in_transaction:
            self._db.execute("BEGIN IMMEDIATE")
            self._outer = True

    def __exit__(self, exc_type: object, *exc: object) -> None:
        if not self._outer:
            return
        if not exc_type:
            self._db.execute("COMMIT")
        elif self._db.in_transaction:  # SQLite may have rolled back already (disk full)
            self._db.execute("ROLLBACK")
