"""SIGKILL a real campaign process at random (seeded) moments, resume, compare row by row."""

from __future__ import annotations

import signal
import sqlite3
import subprocess
import sys
import time

import numpy as np
import pytest
from campaign_helpers import db_rows, fake_config, subprocess_env

from sitcov.campaign import open_store, run_campaign

DRIVER = """
import sys
from campaign_helpers import fake_config
from sitcov.campaign import open_store, run_campaign
with open_store(sys.argv[1]) as store:
    run_campaign(fake_config(**CHANGES), store)
"""

CHANGES = {
    "runs": 400,
    "batch_size": 16,
    "executor": "processes",
    "workers": 2,
    "backend_options": {"sleep": 0.01},
}


def finished(path) -> int:
    """Finished runs in the file (0 before the schema exists); read-only, no locking."""
    try:
        with sqlite3.connect(f"file:{path}?mode=ro", uri=True) as db:
            return db.execute("SELECT count(*) FROM runs WHERE status != 'pending'").fetchone()[0]
    except sqlite3.Error:
        return 0


def kill_at_a_random_moment(proc, path, rng, *, startup: bool) -> bool:
    """SIGKILL ``proc`` at a random moment; False if it finished first.

    ``startup``: a moment in its first second (opening the store, starting workers);
    otherwise a random 0-0.6 s after it has stored at least one more result.
    """
    if startup:
        deadline = time.monotonic() + float(rng.uniform(0.05, 1.0))
    else:
        before, deadline = finished(path), float("inf")
    while proc.poll() is None:
        now = time.monotonic()
        if deadline == float("inf") and finished(path) > before:
            deadline = now + float(rng.uniform(0.0, 0.6))
        if now >= deadline:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            return True
        time.sleep(0.01)
    return False


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume_gives_the_uninterrupted_rows(tmp_path):
    reference = tmp_path / "reference.db"
    with open_store(reference) as store:
        # serial and without the backend's sleep (4 s of waiting): the rows do not depend
        # on either (as the references of test_reliability_processes.py)
        run_campaign(fake_config(**{**CHANGES, "executor": "serial", "backend_options": {}}), store)
    path = tmp_path / "killed.db"
    code = DRIVER.replace("CHANGES", repr(CHANGES))
    rng = np.random.default_rng(2024)
    done_at_kill = []
    for attempt in range(8):
        proc = subprocess.Popen(
            [sys.executable, "-c", code, str(path)],
            env=subprocess_env(),
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
        )
        if attempt < 6 and kill_at_a_random_moment(proc, path, rng, startup=attempt == 0):
            done_at_kill.append(finished(path))
            time.sleep(0.2)  # orphaned workers notice the closed pipe and exit
            continue
        proc.wait()
        assert proc.returncode == 0, proc.stderr.read().decode()
        break
    assert len(done_at_kill) >= 3, done_at_kill
    assert sum(0 < d < CHANGES["runs"] for d in done_at_kill) >= 2, done_at_kill
    assert db_rows(path) == db_rows(reference)
