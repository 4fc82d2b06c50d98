"""Processes dying under a campaign: the parent, a worker, a worker out of memory.

Every case ends with the campaign complete: killed parents are resumed to the rows of an
uninterrupted run, a killed worker's run is stored as ``error`` and every other run is
exactly the uninterrupted campaign's.
"""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import numpy as np
import pytest
from campaign_fakes import fake_outcome
from campaign_helpers import db_rows, fake_config
from cli_helpers import run_cli
from needs import not_on_this_machine
from reliability_fakes import hogs
from reliability_helpers import (
    finished,
    lock_rows,
    processes_mentioning,
    reaped,
    start_cli,
    stat,
    wait_for,
    write_config,
)

from sitcov.campaign import open_store, run_campaign

PROCESSES = {"executor": "processes", "workers": 2}


def reference_rows(tmp_path: Path, **changes) -> dict[int, tuple]:
    """Index -> row of the campaign run serially, undisturbed."""
    path = tmp_path / "reference.db"
    with open_store(path) as store:
        run_campaign(fake_config(**{**changes, "executor": "serial", "workers": 1}), store)
    return {row[1]: row for row in db_rows(path)}


def workers_of(pid: int) -> list[int]:
    """The campaign worker processes (multiprocessing ``spawn`` children) of ``pid``."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit() and (st := stat(int(entry))) and st[1] == pid and st[0] != "Z":
            try:
                cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
            except OSError:
                continue
            if b"spawn_main" in cmdline:
                found.append(int(entry))
    return found


# -- the parent -------------------------------------------------------------------------------


@pytest.mark.slow
def test_sigkill_of_the_sitcov_run_command_then_resume_gives_identical_rows(tmp_path):
    """Through the CLI, with worker processes: each kill leaves a lock whose owner is dead,
    which the next ``sitcov run`` takes over (seeded kill moments)."""
    changes = {**PROCESSES, "runs": 160, "batch_size": 16, "backend_options": {"sleep": 0.01}}
    path, cfg = tmp_path / "c.db", write_config(tmp_path / "c.yaml", **changes)
    rng = np.random.default_rng(1515)
    kills, takeovers, stale = [], 0, False
    for attempt in range(8):
        with reaped(start_cli("run", "--db", str(path), "--config", str(cfg))) as proc:
            if attempt < 5:
                before = finished(path)
                wait_for(
                    lambda: finished(path) > before or proc.poll() is not None,  # noqa: B023
                    what="a stored result",
                )
                time.sleep(float(rng.uniform(0.0, 0.5)))
                if proc.poll() is None:
                    proc.send_signal(signal.SIGKILL)
                    proc.wait()
                    kills.append(finished(path))
                    # a kill after the last run may land while the process exits, its lock
                    # already released; before that, the dead owner's lock must remain
                    stale = bool(lock_rows(path))
                    assert stale or kills[-1] == 160, "the killed process left its lock"
                    continue
            assert proc.wait(timeout=300) == 0, proc.stderr.read().decode()
            takeovers += b"took over campaign 'default'" in proc.stderr.read()
            break
    assert len(kills) >= 3 and sum(0 < k < 160 for k in kills) >= 2, kills
    assert takeovers == int(stale) and lock_rows(path) == []
    print(f"parent SIGKILLs at {kills} finished runs of 160; resumed to identical rows")
    reference = reference_rows(tmp_path, **{**changes, "backend_options": {}})
    assert {row[1]: row for row in db_rows(path)} == reference
    time.sleep(0.5)  # orphaned workers notice their closed pipe and exit
    assert processes_mentioning(str(cfg)) == []


# -- a worker ---------------------------------------------------------------------------------


@pytest.mark.slow
def test_sigkill_of_a_worker_stores_its_run_as_error_and_the_campaign_completes(tmp_path):
    changes = {**PROCESSES, "runs": 120, "backend_options": {"sleep": 0.04}}
    path, cfg = tmp_path / "c.db", write_config(tmp_path / "c.yaml", **changes)
    rng = np.random.default_rng(77)
    killed = 0
    with reaped(start_cli("run", "--db", str(path), "--config", str(cfg))) as live:
        for _ in range(3):
            before = finished(path)
            wait_for(lambda: finished(path) >= before + 10, what="more results")  # noqa: B023
            time.sleep(float(rng.uniform(0.0, 0.3)))
            workers = sorted(workers_of(live.pid))
            if workers and live.poll() is None:
                os.kill(workers[int(rng.integers(len(workers)))], signal.SIGKILL)
                killed += 1
        assert live.wait(timeout=300) == 0, live.stderr.read().decode()
    assert killed == 3
    with open_store(path) as store:
        runs = store.runs("default")
    assert len(runs) == 120 and {r.status for r in runs} <= {"pass", "fail", "error"}
    errors = [r for r in runs if r.status == "error"]
    print(f"{killed} worker SIGKILLs -> {len(errors)} error runs of 120, all others exact")
    assert 1 <= len(errors) <= killed, errors  # the run in hand when killed, nothing more
    for run in errors:
        assert run.outcome.message.startswith(
            "the worker process died (exit code -9: killed by SIGKILL"
        ), run.outcome.message
    for run in runs:  # every other stored outcome is exactly its situation's and seed's
        if run.status != "error":
            expected = fake_outcome(run.situation, run.seed)
            got = run.outcome
            assert (got.status, got.sim_time, got.min_distance) == (
                expected.status,
                expected.sim_time,
                expected.min_distance,
            )
    # up to the first error the learning generator saw the same outcomes: identical plan
    reference = reference_rows(tmp_path, **{**changes, "backend_options": {}})
    first = min(r.index for r in errors)
    rows = {row[1]: row for row in db_rows(path)}
    assert all(rows[i] == reference[i] for i in range(first - first % 8))


# -- a worker out of memory -------------------------------------------------------------------


#: Where the unified (v2) hierarchy is mounted: alone, or beside v1 controllers (hybrid).
CGROUP2_MOUNTS = (Path("/sys/fs/cgroup"), Path("/sys/fs/cgroup/unified"))
MEMORY_LIMIT = 64 << 20


def memory_cgroup(
    name: str, v1: Path = Path("/sys/fs/cgroup/memory"), v2: tuple[Path, ...] = CGROUP2_MOUNTS
) -> tuple[Path | None, str]:
    """A memory cgroup limited to 64 MiB that a worker can join by writing its pid to
    ``cgroup.procs``: cgroup v1's memory controller (``memory.limit_in_bytes``), else a
    cgroup v2 hierarchy whose root offers the memory controller (``memory.max``, no swap).
    Returns (group, "") or (None, why not: what this machine lacks)."""
    if os.geteuid() != 0:
        return None, "needs root to create a memory cgroup"
    if (v1 / "memory.limit_in_bytes").is_file():
        group = v1 / name
        try:
            group.mkdir()
            (group / "memory.limit_in_bytes").write_text(str(MEMORY_LIMIT))
        except OSError as exc:
            return None, f"cannot create a cgroup-v1 memory group under {v1}: {exc}"
        return group, ""
    for root in v2:
        controllers = root / "cgroup.controllers"
        if not controllers.is_file():
            continue
        if "memory" not in controllers.read_text().split():
            continue  # a hybrid unified tree whose memory controller is bound to v1
        group = root / name
        try:
            enabled = (root / "cgroup.subtree_control").read_text().split()
            if "memory" not in enabled:
                (root / "cgroup.subtree_control").write_text("+memory")
            group.mkdir()
            (group / "memory.max").write_text(str(MEMORY_LIMIT))
            if (group / "memory.swap.max").exists():
                (group / "memory.swap.max").write_text("0")  # killed, not swapped out
        except OSError as exc:
            return None, f"cannot create a cgroup-v2 memory group under {root}: {exc}"
        return group, ""
    mounts = ", ".join(str(m) for m in (v1, *v2))
    return None, f"no writable memory controller (cgroup v1 or v2) at {mounts}"


def test_a_cgroup_v2_memory_group_is_made_where_the_controller_is(tmp_path, monkeypatch):
    """The v2 branch of memory_cgroup on a stand-in hierarchy (files as the kernel shows
    them): memory enabled for children, the limit and no swap written."""
    monkeypatch.setattr(os, "geteuid", lambda: 0)
    root = tmp_path / "cgroup2"
    root.mkdir()
    (root / "cgroup.controllers").write_text("cpuset cpu io memory pids\n")
    (root / "cgroup.subtree_control").write_text("cpu\n")
    real_mkdir = Path.mkdir

    def mkdir(self, *args, **kw):  # the kernel creates a new group's interface files
        real_mkdir(self, *args, **kw)
        for f in ("memory.max", "memory.swap.max", "cgroup.procs"):
            (self / f).write_text("max\n")

    monkeypatch.setattr(Path, "mkdir", mkdir)
    group, why = memory_cgroup("g", v1=tmp_path / "no-v1", v2=(root,))
    assert why == "" and group == root / "g"
    assert (root / "cgroup.subtree_control").read_text() == "+memory"
    assert (group / "memory.max").read_text() == str(64 << 20)
    assert (group / "memory.swap.max").read_text() == "0"
    hybrid = tmp_path / "unified"
    hybrid.mkdir()
    (hybrid / "cgroup.controllers").write_text("\n")  # memory bound to v1
    group, why = memory_cgroup("g", v1=tmp_path / "no-v1", v2=(hybrid,))
    assert group is None and "no writable memory controller" in why
    monkeypatch.setattr(os, "geteuid", lambda: 1000)
    assert memory_cgroup("g", v1=tmp_path, v2=(root,)) == (
        None,
        "needs root to create a memory cgroup",
    )


@pytest.mark.slow
@pytest.mark.parametrize("limit", ["oom-killer", "rlimit"])
def test_a_run_exceeding_a_memory_limit_is_an_error_and_the_campaign_goes_on(
    tmp_path, capsys, limit
):
    """``oom-killer``: the worker joins a 64 MiB memory cgroup (v1 or v2) and the kernel
    SIGKILLs it (root only); ``rlimit``: an address-space limit makes the allocation fail
    inside the worker, which keeps serving."""
    group, why = (None, "")
    if limit == "oom-killer":
        group, why = memory_cgroup(f"sitcov-test-{os.getpid()}-{tmp_path.name}")
        if group is None:
            not_on_this_machine(f"{why} (the rlimit case runs)")
    options = {"hog_rate": 0.1, "cgroup": str(group) if group else None, "limit_mb": 200}
    changes = {**PROCESSES, "runs": 40, "backend": "reliability_fakes:HogBackend"}
    cfg = write_config(tmp_path / "c.yaml", **changes, backend_options=options)
    path = tmp_path / "c.db"
    try:
        began = time.perf_counter()
        code, out, err = run_cli(capsys, "run", "--db", str(path), "--config", str(cfg))
        took = time.perf_counter() - began
    finally:
        if group is not None:
            group.rmdir()
    assert code == 0, err
    with open_store(path) as store:
        runs = store.runs("default")
    hog = [r.index for r in runs if hogs(r.seed, 0.1)]
    assert hog and [r.index for r in runs if r.status == "error"] == hog
    expected = (
        "the worker process died (exit code -9: killed by SIGKILL" if group else "MemoryError"
    )
    assert all(expected in runs[i].outcome.message for i in hog)
    assert all(r.status in ("pass", "fail") for r in runs if r.index not in hog)
    print(f"{limit}: {len(hog)} runs out of memory of 40, campaign took {took:.1f} s")
