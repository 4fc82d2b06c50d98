"""Executors and kill-and-resume on the REAL embedded backend and reference stack (slow).

The fakes (test_campaign_runner.py, test_kill_resume.py) pin the protocol; these check the
same guarantees where a bug would matter: the embedded physics, the PEM's noise state, the
learning ``sitcov`` generator and the trace recording, in worker processes and across a
SIGKILL of the ``sitcov run`` process itself.
"""

from __future__ import annotations

import signal
import subprocess
import sys
import time

import numpy as np
import pytest
from campaign_helpers import db_rows, subprocess_env
from test_kill_resume import finished

from sitcov.campaign import CampaignConfig, open_store, run_campaign

RUNS, BATCH = 60, 16
SETTINGS = {"generator": "sitcov", "runs": RUNS, "seed": 5, "batch_size": BATCH}


@pytest.fixture(scope="module")
def serial(tmp_path_factory) -> list[tuple]:
    """The rows of an uninterrupted serial campaign."""
    path = tmp_path_factory.mktemp("serial") / "serial.db"
    with open_store(path) as store:
        run_campaign(CampaignConfig(**SETTINGS, executor="serial", record_traces=True), store)
    return db_rows(path)


@pytest.mark.slow
def test_serial_and_processes_store_identical_rows_on_the_embedded_backend(tmp_path, serial):
    path = tmp_path / "processes.db"
    with open_store(path) as store:
        config = CampaignConfig(**SETTINGS, executor="processes", workers=2, record_traces=True)
        result = run_campaign(config, store)
    assert result.runs == RUNS and result.errors == 0
    rows = db_rows(path)
    assert len(rows) == RUNS and rows == serial
    statuses = {row[6] for row in serial}  # both outcomes occur: the comparison means something
    assert {"pass", "fail"} <= statuses, statuses


def sitcov_run(path) -> subprocess.Popen:
    """``sitcov run`` as a user types it, in its own process."""
    args = ["--db", str(path), "--generator", "sitcov", "--runs", str(RUNS), "--seed", "5",
            "--batch-size", str(BATCH), "--record", "--executor", "processes",
            "--workers", "2"]  # fmt: skip
    return subprocess.Popen(
        [sys.executable, "-m", "sitcov.cli", "run", *args],
        env=subprocess_env(),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )


def kill_after_progress(proc: subprocess.Popen, path, rng: np.random.Generator) -> bool:
    """SIGKILL ``proc`` a random 0-0.3 s after it stored one more result; False if it ended."""
    before, deadline = finished(path), float("inf")
    while proc.poll() is None:
        now = time.monotonic()
        if deadline == float("inf") and finished(path) > before:
            deadline = now + float(rng.uniform(0.0, 0.3))
        if now >= deadline:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            return True
        time.sleep(0.005)
    return False


@pytest.mark.slow
def test_sigkill_of_sitcov_run_then_resume_gives_the_uninterrupted_rows(tmp_path, serial):
    path = tmp_path / "killed.db"
    rng = np.random.default_rng(16)
    killed_at = []
    for attempt in range(4):
        proc = sitcov_run(path)
        if attempt < 2 and kill_after_progress(proc, path, rng):
            killed_at.append(finished(path))
            time.sleep(0.3)  # orphaned workers see the closed pipe and exit
            continue
        _, err = proc.communicate(timeout=300)
        assert proc.returncode == 0, err.decode()
        break
    assert any(0 < k < RUNS for k in killed_at), killed_at  # killed mid-campaign at least once
    assert db_rows(path) == serial
