"""Concurrent writers: one process per campaign, stale locks taken over, readers never blocked."""

from __future__ import annotations

import json
import os
import socket
import sqlite3
import subprocess
import sys
import textwrap
import time

import pytest
from campaign_helpers import db_rows, fake_config, subprocess_env
from cli_helpers import run_cli
from needs import not_on_this_machine
from reliability_helpers import (
    LIVE,
    finished,
    lock_rows,
    one_error_line,
    reaped,
    start_cli,
    wait_for,
    write_config,
)

from sitcov.campaign import CampaignBusyError, open_store, run_campaign
from sitcov.campaign import _lock as lock_mod
from sitcov.campaign._lock import process_start
from sitcov.sim import Outcome

HOST = socket.gethostname()


def put_lock(path, campaign: str, **fields) -> None:
    """Write a lock row directly (an owner that died, or lives on another host)."""
    row = {
        "token": "t-" + campaign,
        "pid": 1,
        "host": HOST,
        "pid_start": None,
        "started": "2026-01-01T00:00:00+00:00",
        "heartbeat": time.time(),
    } | fields
    with open_store(path) as store:  # creates the schema
        store.lock_campaign("_make_table").release()
    with sqlite3.connect(path) as db:
        db.execute(
            "INSERT OR REPLACE INTO campaign_locks VALUES (?,?,?,?,?,?,?)",
            (campaign, row["token"], row["pid"], row["host"], row["pid_start"], row["started"],
             row["heartbeat"]),
        )  # fmt: skip


def dead_pid() -> int:
    """The id of a process that has exited and been reaped."""
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# -- a second writer ------------------------------------------------------------------------


@pytest.mark.slow
def test_second_run_on_a_live_campaign_refuses_at_once_naming_the_owner(tmp_path, capsys):
    """Reproduces the issue's report (before: ``run default:107 has no result`` after 32
    runs); now the second command stops before running anything, and the first one's rows
    are exactly an undisturbed campaign's."""
    path, cfg = tmp_path / "c.db", write_config(tmp_path / "c.yaml")
    with reaped(start_cli("run", "--db", str(path), "--config", str(cfg))) as live:
        wait_for(lambda: finished(path) >= 3, what="the live campaign's first results")
        began = time.perf_counter()
        code, out, err = run_cli(capsys, "run", "--db", str(path), "--config", str(cfg))
        refused_in = time.perf_counter() - began
        assert live.poll() is None, "the live run ended before the second one was tried"
        done_then = finished(path)
        assert live.wait(timeout=120) == 0, live.stderr.read().decode()
    line = one_error_line(err)
    print(f"second run refused in {refused_in:.2f} s: {line}")
    assert code == 2
    assert f"pid {live.pid} on host {HOST} since 20" in line
    assert "campaign 'default' is being run by another process" in line
    assert refused_in < 5.0, refused_in  # no backend, executor or run was started
    assert "runs executed" not in out and done_then < LIVE["runs"]
    reference = tmp_path / "reference.db"
    with open_store(reference) as store:
        run_campaign(fake_config(**{**LIVE, "backend_options": {}}), store)
    assert db_rows(path) == db_rows(reference)
    assert lock_rows(path) == []  # released at the end


def test_a_campaign_is_refused_while_another_store_in_this_process_holds_it(tmp_path):
    path = tmp_path / "c.db"
    with open_store(path) as first, open_store(path) as second:
        with first.lock_campaign("default") as held:
            with pytest.raises(CampaignBusyError, match=f"pid {os.getpid()} on host"):
                run_campaign(fake_config(runs=8), second)
            assert held.previous is None
        result = run_campaign(fake_config(runs=8), second)  # released: free again
    assert result.counts["pending"] == 0 and lock_rows(path) == []


def test_lock_is_released_when_the_campaign_raises(tmp_path):
    path = tmp_path / "c.db"
    with open_store(path) as store:
        run_campaign(fake_config(runs=8, seed=3), store)
        with pytest.raises(Exception, match="different config"):
            run_campaign(fake_config(runs=8, seed=4), store)
        assert lock_rows(path) == []
        assert run_campaign(fake_config(runs=16, seed=3), store).counts["pending"] == 0


# -- stale locks ----------------------------------------------------------------------------


def test_a_dead_owners_lock_on_this_host_is_taken_over(tmp_path, caplog):
    path = tmp_path / "c.db"
    gone = dead_pid()
    put_lock(path, "default", pid=gone)
    with open_store(path) as store:
        with store.lock_campaign("default") as held:
            assert held.previous is not None and held.previous.pid == gone
        assert f"took over campaign 'default' from a dead owner: pid {gone}" in caplog.text
        assert run_campaign(fake_config(runs=8), store).counts["pending"] == 0


def test_a_recycled_pid_is_not_mistaken_for_the_owner(tmp_path):
    """The owner's pid now belongs to another process (here: this test's parent) that
    started at another moment: the lock is stale."""
    path = tmp_path / "c.db"
    other = os.getppid()
    start = process_start(other)
    if start is None:
        not_on_this_machine("no /proc start times on this system")
    put_lock(path, "default", pid=other, pid_start=start + 1)
    with open_store(path) as store, store.lock_campaign("default") as held:
        assert held.previous.pid == other
    put_lock(path, "default", pid=other, pid_start=start)  # the same process: alive
    with open_store(path) as store, pytest.raises(CampaignBusyError, match=f"pid {other} "):
        store.lock_campaign("default")


def test_another_hosts_lock_is_kept_while_its_heartbeat_is_fresh(tmp_path):
    path = tmp_path / "c.db"
    put_lock(path, "default", host="node-7.cluster", pid=4242, heartbeat=time.time() - 5)
    with open_store(path) as store:
        with pytest.raises(CampaignBusyError) as refused:
            store.lock_campaign("default")
        assert "pid 4242 on host node-7.cluster" in str(refused.value)
        assert "last heartbeat 5 s ago" in str(refused.value)
    stale = time.time() - lock_mod.STALE_AFTER - 1
    put_lock(path, "default", host="node-7.cluster", pid=4242, heartbeat=stale)
    with open_store(path) as store, store.lock_campaign("default") as held:
        assert held.previous.host == "node-7.cluster"


def test_heartbeat_thread_keeps_a_long_run_fresh(tmp_path, monkeypatch):
    monkeypatch.setattr(lock_mod, "HEARTBEAT", 0.05)
    path = tmp_path / "c.db"
    with open_store(path) as store, store.lock_campaign("default") as held:
        first = store.lock_owner("default").heartbeat
        wait_for(lambda: store.lock_owner("default").heartbeat > first, 10, "a heartbeat")
        assert store.lock_owner("default").token == held.owner.token


def test_a_writer_whose_lock_was_taken_over_stops_without_writing(tmp_path):
    """Fencing: every write checks the token in its own transaction."""
    path = tmp_path / "c.db"
    with open_store(path) as store:
        run_campaign(fake_config(runs=8), store)
        before = db_rows(path)
        held = store.lock_campaign("default")
        with sqlite3.connect(path) as db:  # another host decided this process was dead
            db.execute("UPDATE campaign_locks SET token = 'theirs', pid = 99, host = 'h2'")
        with pytest.raises(CampaignBusyError, match="taken over by another process .pid 99 on"):
            store.record_result("default", 0, Outcome.errored("x"), 0.0)
        held.release()
        assert db_rows(path) == before
        assert lock_rows(path) == [("default", 99, "h2")]  # not ours: left alone


RACER = textwrap.dedent(
    """
    import sys, time
    from pathlib import Path
    from sitcov.campaign import CampaignBusyError, open_store
    path, go, done = sys.argv[1], Path(sys.argv[2]), Path(sys.argv[3])
    store = open_store(path)
    while not go.exists():
        time.sleep(0.001)
    try:
        lock = store.lock_campaign("default")
        print("won", flush=True)
    except CampaignBusyError:
        print("busy", flush=True)
    while not done.exists():  # hold the lock until every racer has tried
        time.sleep(0.01)
    """
)


@pytest.mark.slow
def test_racing_takers_of_a_stale_lock_exactly_one_wins(tmp_path):
    path, go, done = tmp_path / "c.db", tmp_path / "go", tmp_path / "done"
    put_lock(path, "default", pid=dead_pid())
    racers = [
        subprocess.Popen(
            [sys.executable, "-c", RACER, str(path), str(go), str(done)],
            env=subprocess_env(),
            stdout=subprocess.PIPE,
            text=True,
        )
        for _ in range(6)
    ]
    try:
        time.sleep(2.0)  # all import and open the store, then wait for the signal
        go.touch()
        answers = [r.stdout.readline().strip() for r in racers]
    finally:
        done.touch()
        for r in racers:
            r.wait(timeout=60)
    assert sorted(answers) == ["busy"] * 5 + ["won"], answers


# -- two campaigns, readers -----------------------------------------------------------------


@pytest.mark.slow
def test_two_campaigns_in_one_database_run_at_the_same_time(tmp_path):
    path = tmp_path / "c.db"
    slow = {"runs": 120, "backend_options": {"sleep": 0.05}}  # ~6 s each: they overlap
    procs = {}
    for name in ("alpha", "beta"):
        cfg = write_config(tmp_path / f"{name}.yaml", name=name, **slow)
        procs[name] = start_cli("run", "--db", str(path), "--config", str(cfg))
        if name == "alpha":  # beta starts once alpha runs (no race to create the file)
            wait_for(lambda: len(lock_rows(path)) == 1, what="the first campaign's lock")
    try:
        wait_for(lambda: len(lock_rows(path)) == 2, what="both campaigns holding their locks")
        assert sorted(r[0] for r in lock_rows(path)) == ["alpha", "beta"]
        for proc in procs.values():
            assert proc.wait(timeout=180) == 0, proc.stderr.read().decode()
    finally:
        for proc in procs.values():
            if proc.poll() is None:
                proc.kill()
                proc.wait()
    # the reference without the backend's sleep (12 s of waiting in this process): the
    # rows compared do not depend on it, as for the reference of the refusal test above
    reference = tmp_path / "reference.db"
    with open_store(reference) as store:
        for name in ("alpha", "beta"):
            run_campaign(
                fake_config(**{**LIVE, **slow, "backend_options": {}, "name": name}), store
            )
    assert db_rows(path) == db_rows(reference)


@pytest.mark.slow
def test_summary_report_and_export_work_while_a_campaign_runs(tmp_path, capsys):
    path, cfg = tmp_path / "c.db", write_config(tmp_path / "c.yaml", runs=5000)
    timings = {}
    with reaped(start_cli("run", "--db", str(path), "--config", str(cfg))) as live:
        wait_for(lambda: finished(path) >= 5, what="the live campaign's first results")
        commands = {
            "summary": ["summary", "--db", str(path), "--json"],
            "export": ["export", "--db", str(path), "--format", "json"],
            "csv": ["export", "--db", str(path), "--format", "csv"],
            "report": ["report", "--db", str(path), "--out", str(tmp_path / "rep"), "--pictures",
                       "0"],
        }  # fmt: skip
        outputs = {}
        for key, args in commands.items():
            began = time.perf_counter()
            code, out, err = run_cli(capsys, *args)
            timings[key] = time.perf_counter() - began
            assert code == 0, (key, err)
            outputs[key] = out
        assert live.poll() is None, "the campaign ended before the readers were done"
        live.terminate()  # stopped like Ctrl-C; a later run resumes it
    print("reader seconds while a campaign runs:", timings)
    summary = json.loads(outputs["summary"])
    exported = json.loads(outputs["export"])["runs"]
    assert 5 <= summary["runs"] < 5000
    statuses = [r["outcome"]["status"] for r in exported if r["outcome"] is not None]
    assert set(statuses) <= {"pass", "fail"} and len(statuses) >= summary["runs"]
    assert len(outputs["csv"].splitlines()) >= 1 + summary["runs"]
    assert (tmp_path / "rep" / "index.html").is_file()
    assert max(timings.values()) < 30, timings  # readers never wait for the writer's lock
