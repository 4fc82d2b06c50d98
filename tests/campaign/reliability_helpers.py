"""Helpers of the reliability tests: a live campaign in a child process, process checks."""

from __future__ import annotations

import json
import os
import signal
import sqlite3
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from campaign_fakes import BACKEND, GENERATOR, STACK
from campaign_helpers import subprocess_env

#: A campaign on the fakes that a child ``sitcov run`` takes a few seconds to finish.
LIVE = {
    "generator": GENERATOR,
    "backend": BACKEND,
    "av": STACK,
    "runs": 120,
    "seed": 3,
    "batch_size": 8,
    "executor": "serial",
    "backend_options": {"sleep": 0.03},
}


def write_config(path: Path, **changes: Any) -> Path:
    """A campaign config file (JSON is YAML) with :data:`LIVE`'s settings and ``changes``."""
    path.write_text(json.dumps({**LIVE, **changes}))
    return path


def start_cli(*args: str, stderr: Any = subprocess.PIPE) -> subprocess.Popen:
    """``python -m sitcov.cli ARGS`` in a child process that can import the fakes."""
    return subprocess.Popen(
        [sys.executable, "-m", "sitcov.cli", *args],
        env=subprocess_env(),
        stdout=subprocess.PIPE,
        stderr=stderr,
    )


def finished(path: Path, campaign: str | None = None) -> int:
    """Finished runs in the file (0 before the schema exists), read without locking."""
    where = " AND campaign = ?" if campaign else ""
    args = (campaign,) if campaign else ()
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5) as db:
            sql = f"SELECT count(*) FROM runs WHERE status != 'pending'{where}"
            return int(db.execute(sql, args).fetchone()[0])
    except sqlite3.Error:
        return 0


def lock_rows(path: Path) -> list[tuple]:
    """(campaign, pid, host) of every lock row in the file."""
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True, timeout=5) as db:
            return db.execute("SELECT campaign, pid, host FROM campaign_locks").fetchall()
    except sqlite3.Error:
        return []


def wait_for(condition: Any, timeout: float = 60.0, what: str = "condition") -> None:
    """Poll ``condition()`` every 20 ms until it is true; fail after ``timeout`` seconds."""
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.02)


def one_error_line(err: str) -> str:
    """The single ``error:`` line of a failed command's stderr (asserting there is one and
    no traceback)."""
    assert "Traceback" not in err, err
    lines = [line for line in err.splitlines() if line.strip()]
    errors = [line for line in lines if line.startswith("error:")]
    assert len(errors) == 1 and lines[-1] == errors[0], err
    return errors[0]


def stat(pid: int) -> tuple[str, int, int] | None:
    """(state, ppid, pgid) of ``pid`` from /proc, or None if it does not exist."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return fields[0], int(fields[1]), int(fields[2])


def alive(pid: int) -> bool:
    """True if ``pid`` exists and is not a zombie."""
    found = stat(pid)
    return found is not None and found[0] != "Z"


def processes_mentioning(marker: str) -> list[int]:
    """Living processes (not zombies) whose command line contains ``marker``."""
    found = []
    for entry in os.listdir("/proc"):
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
        except OSError:
            continue
        if marker.encode() in cmdline and alive(int(entry)):
            found.append(int(entry))
    return found


@contextmanager
def reaped(proc: subprocess.Popen) -> Iterator[subprocess.Popen]:
    """Kill ``proc`` (SIGKILL) on the way out if it still runs, and reap it."""
    try:
        yield proc
    finally:
        if proc.poll() is None:
            proc.send_signal(signal.SIGKILL)
        proc.wait()


@contextmanager
def tmpfs(where: Path, size: str) -> Iterator[bool]:
    """Mount a tmpfs of ``size`` (e.g. ``"300k"``) on ``where``; yields False if this
    machine does not allow it (not root, no mount), True while mounted."""
    where.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0:
        yield False
        return
    done = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(where)], capture_output=True
    )
    if done.returncode != 0:
        yield False
        return
    try:
        yield True
    finally:
        subprocess.run(["umount", "-l", str(where)], capture_output=True)


def remount(where: Path, options: str) -> None:
    """``mount -o remount,OPTIONS`` (a tmpfs mounted by :func:`tmpfs`)."""
    subprocess.run(["mount", "-o", f"remount,{options}", str(where)], check=True)
