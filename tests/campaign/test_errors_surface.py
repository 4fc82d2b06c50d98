"""Errors never hide: all-error campaigns fail loudly, bad parts leave no file, runs only grow."""

from __future__ import annotations

import json
import sqlite3

import pytest
from campaign_fakes import BACKEND, GENERATOR, STACK
from cli_helpers import run_cli as sitcov

from sitcov.campaign._executors import TRACEBACK_CHARS, error_message

FAKE = ["--generator", GENERATOR, "--backend", BACKEND, "--av", STACK, "--executor", "serial"]


def stored_messages(path) -> list[str]:
    with sqlite3.connect(path) as db:
        return [r[0] for r in db.execute("SELECT message FROM runs ORDER BY idx")]


def config_file(tmp_path, raise_rate: float):
    path = tmp_path / "camp.yaml"
    path.write_text(f"backend_options: {{raise_rate: {raise_rate}}}\n")
    return str(path)


def test_a_campaign_whose_runs_all_error_exits_non_zero_with_the_traceback(tmp_path, capsys):
    db = tmp_path / "c.db"
    args = ["run", "--db", str(db), *FAKE, "--runs", "12", "--config", config_file(tmp_path, 1.0)]
    code, out, err = sitcov(capsys, *args)
    assert code == 1
    assert "all 12 runs of campaign 'default'" in err and "default:0" in err
    # one block: the headline, then the first run's traceback ending in its exception
    assert "Traceback (most recent call last):" in err and "in run" in err
    assert err.rstrip().endswith("RuntimeError: fake backend exploded on seed " + err.split()[-1])
    messages = stored_messages(db)
    assert len(messages) == 12
    assert all("Traceback (most recent call last):" in m for m in messages)
    # resuming the (complete, all-error) campaign still says so
    code, _, err = sitcov(capsys, *args)
    assert code == 1 and "all 12 runs" in err


def test_some_errors_are_stored_but_do_not_fail_the_command(tmp_path, capsys):
    db = tmp_path / "c.db"
    args = ["run", "--db", str(db), *FAKE, "--runs", "30", "--config", config_file(tmp_path, 0.3)]
    code, _, err = sitcov(capsys, *args)
    statuses = json.loads(sitcov(capsys, "summary", "--db", str(db), "--json")[1])
    assert 0 < statuses["errors"] < 30  # the fake raises for ~30% of the seeds
    assert code == 0 and "ended in error" not in err


def _deep(n: int) -> None:
    """Alternates with _deeper so Python cannot fold the frames into "repeated N times"."""
    if n == 0:
        raise KeyError("deep down")
    _deeper(n - 1)


def _deeper(n: int) -> None:
    _deep(n)


def test_stored_error_message_keeps_the_end_of_a_long_traceback():
    try:
        _deep(200)
    except KeyError as exc:
        message = error_message(exc)
    head, _, trace = message.partition("\n")
    assert head == "KeyError: 'deep down'"
    assert trace.startswith("... (traceback truncated)")
    assert len(trace) <= TRACEBACK_CHARS + 40
    assert trace.endswith("KeyError: 'deep down'") and "in _deep" in trace
    try:
        _deep(1)
    except KeyError as exc:
        short = error_message(exc)
    assert "truncated" not in short and short.count("in _deep\n") == 2


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--fault", "f9"], "unknown fault 'f9'"),
        (["--generator", "nope"], "unknown generator 'nope'"),
        (["--backend", "nope"], "unknown backend 'nope'"),
        (["--av", "nosuch.module:Cls"], "cannot import module 'nosuch.module'"),
        (["--hyperspace", "/nonexistent/h.yaml"], "file not found"),
        (["--perception", "bogus"], "perception: expected pem | camera"),
        (["--runs", "-1"], "runs: expected"),
    ],
)
def test_a_bad_part_is_one_line_and_creates_no_database(tmp_path, capsys, flags, message):
    db = tmp_path / "never.db"
    code, out, err = sitcov(capsys, "run", "--db", str(db), "--executor", "serial", *flags)
    assert code == 2 and message in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in out + err
    assert list(tmp_path.iterdir()) == []


def stored_runs(path) -> int:
    with sqlite3.connect(path) as db:
        return json.loads(db.execute("SELECT config FROM campaigns").fetchone()[0])["runs"]


def test_runs_can_grow_but_never_shrink(tmp_path, capsys):
    db = tmp_path / "c.db"
    run = ["run", "--db", str(db), *FAKE]
    assert sitcov(capsys, *run, "--runs", "20")[0] == 0
    code, out, err = sitcov(capsys, *run, "--runs", "10")
    assert code == 2 and "runs: 20" in err and "runs: 10 would shrink it" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in out + err
    assert stored_runs(db) == 20
    # without --runs a stored campaign keeps its size (not the default 1000)
    code, out, _ = sitcov(capsys, *run)
    assert code == 0 and "0 runs executed" in out and stored_runs(db) == 20
    code, out, _ = sitcov(capsys, *run, "--runs", "25")
    assert code == 0 and "5 runs executed" in out and stored_runs(db) == 25


@pytest.mark.parametrize(
    ("flags", "message"),
    [(["--generators", "nope"], "unknown generator 'nope'"), (["--av", "nope"], "unknown av")],
)
def test_a_bad_fault_experiment_leaves_no_database(tmp_path, capsys, flags, message):
    db = tmp_path / "faults.db"
    args = ["experiment", "faults", "--db", str(db), "--runs", "4", "--seeds", "1", *flags]
    code, out, err = sitcov(capsys, *args, "--workers", "1")
    assert code == 2 and message in err and "Traceback" not in out + err
    assert list(tmp_path.iterdir()) == []


def test_a_database_that_cannot_be_opened_is_one_line(capsys):
    db = "/proc/sitcov-cannot-create-this.db"  # /proc takes no new files, even for root
    code, out, err = sitcov(capsys, "run", "--db", db, "--runs", "2", "--executor", "serial")
    assert code == 2 and f"{db}: cannot open the file" in err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in out + err
