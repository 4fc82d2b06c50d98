"""The database under stress: disk full, read-only, locked, truncated, not a database.

Each case ends in exit code 0 or ONE ``error:`` line (exit 2) naming the file and what is
wrong - never a traceback - and a full disk loses nothing that was committed.
"""

from __future__ import annotations

import shutil
import sqlite3
import time

import numpy as np
import pytest
from campaign_helpers import db_rows, fake_config
from cli_helpers import run_cli
from needs import missing, not_on_this_machine
from reliability_helpers import one_error_line, remount, tmpfs, write_config

from sitcov.campaign import StoreError, open_store, run_campaign
from sitcov.campaign import _sqlite as sqlite_mod

#: A quick campaign on the fakes whose traces make every run take disk space.
QUICK = {"backend_options": {}, "record_traces": True, "runs": 300}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The uninterrupted campaign every damaged or resumed one is compared with."""
    path = tmp_path_factory.mktemp("ref") / "reference.db"
    with open_store(path) as store:
        run_campaign(fake_config(**{**QUICK, "batch_size": 8}), store)
    return path


def cli(capsys, path, *args):
    return run_cli(capsys, *args[:1], "--db", str(path), *args[1:])


# -- disk full --------------------------------------------------------------------------------


def test_disk_full_stops_with_one_line_and_resume_completes(tmp_path, capsys, reference):
    """A 300 KiB tmpfs fills while runs are stored; after space is freed (the tmpfs grown)
    the same command resumes to the uninterrupted campaign's rows."""
    where, cfg = tmp_path / "small", write_config(tmp_path / "c.yaml", **QUICK)
    with tmpfs(where, "300k") as mounted:
        if not mounted:
            not_on_this_machine("cannot mount a tmpfs here: the simulated case below covers it")
        path = where / "c.db"
        code, _, err = cli(capsys, path, "run", "--config", str(cfg))
        line = one_error_line(err)
        assert code == 2 and f"{path}: the disk is full" in line and "resume" in line
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
            assert db.execute("PRAGMA integrity_check").fetchone() == ("ok",)
        stored = [r for r in db_rows(path) if r[6] != "pending"]
        assert 0 < len(stored) < QUICK["runs"]
        with capsys.disabled():
            print(f"disk full after {len(stored)} of {QUICK['runs']} runs stored", end=" ")
        assert set(stored) <= set(db_rows(reference))  # what was stored is exactly right
        remount(where, "size=50m")
        code, _, err = cli(capsys, path, "run", "--config", str(cfg))
        assert code == 0, err
        assert db_rows(path) == db_rows(reference)


def test_disk_full_simulated_by_a_page_limit(tmp_path, reference):
    """Where no tmpfs can be mounted: SQLite's own page limit raises the same SQLITE_FULL."""
    path = tmp_path / "c.db"
    with open_store(path) as store:
        run_campaign(fake_config(**{**QUICK, "runs": 8}), store)
        pages = store._db.execute("PRAGMA page_count").fetchone()[0]
        store._db.execute(f"PRAGMA max_page_count = {pages + 4}")
        with pytest.raises(StoreError, match="the disk is full; nothing half-written"):
            run_campaign(fake_config(**QUICK), store)
    with open_store(path) as store:
        run_campaign(fake_config(**QUICK), store)
    assert db_rows(path) == db_rows(reference)


# -- read-only --------------------------------------------------------------------------------


def read_only_copy(source, where):
    """A copy of ``source`` in a directory nobody here can write (a read-only tmpfs as root,
    chmod otherwise); a context manager yielding its path."""
    import contextlib
    import os

    @contextlib.contextmanager
    def made():
        if os.geteuid() != 0:
            where.mkdir()
            path = shutil.copy(source, where / "c.db")
            os.chmod(path, 0o444)
            os.chmod(where, 0o555)
            try:
                yield where / "c.db"
            finally:
                os.chmod(where, 0o755)
            return
        with tmpfs(where, "20m") as mounted:
            if not mounted:
                missing("root, but cannot mount a tmpfs to make a read-only directory")
            shutil.copy(source, where / "c.db")
            remount(where, "ro")
            yield where / "c.db"

    return made()


def test_read_only_database_reads_and_refuses_writes_in_one_line(tmp_path, capsys, reference):
    cfg = write_config(tmp_path / "c.yaml", **QUICK)
    with read_only_copy(reference, tmp_path / "ro") as path:
        code, out, err = cli(capsys, path, "summary", "--json")
        assert code == 0 and '"runs": 300' in out, err
        code, out, err = cli(capsys, path, "export", "--format", "csv")
        assert code == 0 and len(out.splitlines()) == 301
        code, _, err = cli(capsys, path, "run", "--config", str(cfg), "--runs", "320")
        line = one_error_line(err)
        assert code == 2 and line == (
            f"error: {path}: cannot write: the database file or its directory is read-only"
        )


# -- locked by another connection -------------------------------------------------------------


def test_database_locked_by_another_connection(tmp_path, capsys, reference, monkeypatch):
    """Another program holds a write transaction: ``run`` gives up after the busy time-out
    with one line; readers (WAL) are not blocked. An exclusive lock blocks them too."""
    monkeypatch.setattr(sqlite_mod, "BUSY_TIMEOUT", 1.0)
    path = shutil.copy(reference, tmp_path / "c.db")
    cfg = write_config(tmp_path / "c.yaml", **QUICK)
    other = sqlite3.connect(path, isolation_level=None)
    other.execute("BEGIN IMMEDIATE")
    try:
        began = time.perf_counter()
        code, _, err = cli(capsys, path, "run", "--config", str(cfg), "--runs", "320")
        waited = time.perf_counter() - began
        assert code == 2 and "the database is locked by another connection (waited 1 s)" in (
            one_error_line(err)
        )
        assert waited < 10, waited
        with capsys.disabled():
            print(f"run on a locked database gave up after {waited:.1f} s (busy time-out 1 s)")
        code, out, err = cli(capsys, path, "summary", "--json")
        assert code == 0 and '"runs": 300' in out, err
        other.execute("ROLLBACK")
        other.execute("PRAGMA locking_mode=EXCLUSIVE")
        other.execute("BEGIN EXCLUSIVE")
        code, _, err = cli(capsys, path, "summary", "--json")
        assert code == 2 and "locked by another connection" in one_error_line(err)
    finally:
        other.close()
    code, _, err = cli(capsys, path, "run", "--config", str(cfg), "--runs", "320")
    assert code == 0, err


# -- damaged files ----------------------------------------------------------------------------


def verdict(code: int, out: str, err: str) -> str:
    """``ok`` or ``one line``; anything else (a traceback, several lines) fails the test."""
    if code == 0:
        assert "Traceback" not in out + err
        return "ok"
    one_error_line(err)
    assert code == 2, (code, err)
    return "one line"


@pytest.mark.slow
def test_truncated_database_gives_one_line_or_works(tmp_path, capsys, reference):
    """Cut at 20 seeded places (a crash while copying the file, a full disk elsewhere)."""
    cfg = write_config(tmp_path / "c.yaml", **QUICK)
    data = reference.read_bytes()
    rng = np.random.default_rng(15)
    seen = {}
    for k, cut in enumerate([0, 50, 100, *rng.integers(101, len(data), 17)]):
        path = tmp_path / f"cut{k}.db"
        path.write_bytes(data[: int(cut)])
        for args in (("summary", "--json"), ("export", "--format", "csv"), ("run", "--config",
                     str(cfg))):  # fmt: skip
            result = verdict(*cli(capsys, path, *args))
            seen[result] = seen.get(result, 0) + 1
    assert seen.get("one line", 0) >= 20, seen
    with capsys.disabled():
        print(f"truncated files, 20 cuts x 3 commands: {seen}")


def test_not_a_database_names_the_file_in_one_line(tmp_path, capsys):
    path = tmp_path / "notes.db"
    path.write_text("these are my notes, not a campaign\n" * 200)
    cfg = write_config(tmp_path / "c.yaml", **QUICK)
    for args in (("summary",), ("export", "--format", "json"), ("run", "--config", str(cfg))):
        code, _, err = cli(capsys, path, *args)
        line = one_error_line(err)
        assert code == 2 and line.startswith(f"error: {path}: not a sitcov database"), line
    assert path.read_text().startswith("these are my notes")  # never overwritten
