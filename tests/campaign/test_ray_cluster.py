"""A real multi-node Ray cluster on this machine: a head and a worker node as separate
``ray start`` processes, a campaign joining it with ``ray_address``, and a worker node
killed (its raylet, SIGKILL) in the middle of a campaign.

Each node has one CPU and every campaign actor needs one, so a two-worker campaign has
exactly one actor on each node: killing the worker node loses an actor and the run it
was running. The campaign must still end with the serial executor's rows.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from campaign_helpers import db_rows, fake_config, subprocess_env
from needs import need_module

from sitcov.campaign import open_store, run_campaign

ray = need_module("ray", "ray")

#: Ray tests share one xdist worker (``--dist loadgroup``): a second local cluster
#: started beside them could be joined by their ``ray.init``.
pytestmark = [pytest.mark.slow, pytest.mark.xdist_group("ray")]

#: Runs of the test campaigns; each sleeps SLEEP s so the kill lands mid-campaign.
RUNS, SLEEP, KILL_AT = 40, 0.25, 10


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return int(sock.getsockname()[1])


def _ray_cli() -> list[str]:
    return [sys.executable, "-m", "ray.scripts.scripts"]


def _node_ports() -> list[str]:
    """Ports of one node, all free ones (other Ray users on this machine keep theirs)."""
    return [
        f"--node-manager-port={_free_port()}",
        f"--object-manager-port={_free_port()}",
        f"--metrics-export-port={_free_port()}",
        f"--runtime-env-agent-port={_free_port()}",
        f"--dashboard-agent-grpc-port={_free_port()}",
        f"--dashboard-agent-listen-port={_free_port()}",
    ]


#: No usage stats; no token authentication (a token left in ~/.ray by another cluster
#: would make the test's driver fail to connect with "Missing authorization header").
_RAY_ENV = {"RAY_USAGE_STATS_ENABLED": "0", "RAY_AUTH_MODE": "disabled"}


def _env() -> dict[str, str]:
    env = subprocess_env()
    root = str(Path(__file__).resolve().parents[2])
    env["PYTHONPATH"] = os.pathsep.join([env["PYTHONPATH"], root])
    env.update(_RAY_ENV)
    # notice a dead node within seconds, not the default ~30 s
    env["RAY_health_check_period_ms"] = "500"
    env["RAY_health_check_timeout_ms"] = "500"
    env["RAY_health_check_failure_threshold"] = "3"
    env["RAY_health_check_initial_delay_ms"] = "0"
    return env


def _start(args: list[str]) -> subprocess.Popen:
    """``ray start ... --block`` in its own process group (teardown kills the whole group)."""
    return subprocess.Popen(
        [*_ray_cli(), "start", "--block", "--num-cpus=1", "--disable-usage-stats", *args],
        env=_env(),
        start_new_session=True,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )


def _stop(proc: subprocess.Popen) -> None:
    """Stop a node: SIGTERM to its process group, then SIGKILL to what is left."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        try:
            os.killpg(proc.pid, sig)
        except ProcessLookupError:
            return
        try:
            proc.wait(10)
        except subprocess.TimeoutExpired:
            continue
    _kill_group_leftovers(proc.pid)


def _kill_group_leftovers(pgid: int) -> None:
    for pid in _group_pids(pgid):
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGKILL)


def _group_pids(pgid: int) -> list[int]:
    out = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            try:
                if os.getpgid(int(entry)) == pgid:
                    out.append(int(entry))
            except ProcessLookupError:
                continue
    return out


def _raylet_of(proc: subprocess.Popen) -> int:
    """The pid of the raylet a ``ray start`` process group runs."""
    for pid in _group_pids(proc.pid):
        try:
            name = Path(f"/proc/{pid}/comm").read_text().strip()
        except OSError:
            continue
        if name == "raylet":
            return pid
    raise AssertionError("the worker node has no raylet")


def _wait_cpus(n: float, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while ray.cluster_resources().get("CPU", 0) != n:
        if time.monotonic() > deadline:
            raise AssertionError(f"the cluster did not reach {n} CPUs: {ray.cluster_resources()}")
        time.sleep(0.5)


@pytest.fixture(scope="module")
def head() -> Iterator[tuple[str, str, subprocess.Popen]]:
    """A Ray head node (1 CPU) in its own temp dir; yields (address, temp dir, process)."""
    if ray.is_initialized():
        ray.shutdown()
    saved = {k: os.environ.get(k) for k in _RAY_ENV}
    os.environ.update(_RAY_ENV)  # this process is the driver
    temp = tempfile.mkdtemp(prefix="sitcov-ray-", dir="/tmp")  # short: Ray's socket paths
    port = _free_port()
    proc = _start(
        [
            "--head",
            f"--port={port}",
            "--include-dashboard=false",
            f"--temp-dir={temp}",
            *_node_ports(),
        ]
    )
    try:
        yield f"127.0.0.1:{port}", temp, proc
    finally:
        _stop(proc)
        for key, value in saved.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


@pytest.fixture
def cluster(head: tuple[str, str, subprocess.Popen]) -> Iterator[tuple[str, subprocess.Popen]]:
    """The head plus a worker node (1 CPU), joined; this process is connected as driver."""
    address, temp, head_proc = head
    worker = _start(
        [
            f"--address={address}",
            f"--temp-dir={temp}",
            *_node_ports(),
        ]
    )
    path = os.pathsep.join(p for p in sys.path if p)
    try:
        deadline = time.monotonic() + 120
        while True:
            try:
                ray.init(
                    address=address,
                    include_dashboard=False,
                    log_to_driver=False,
                    runtime_env={"env_vars": {"PYTHONPATH": path}},
                )
                break
            except ConnectionError:
                for name, proc in (("head", head_proc), ("worker", worker)):
                    if proc.poll() is not None:
                        raise AssertionError(
                            f"ray start ({name}) exited: {proc.returncode}"
                        ) from None
                if time.monotonic() > deadline:
                    raise
                time.sleep(1)
        _wait_cpus(2)
        yield address, worker
    finally:
        ray.shutdown()
        _stop(worker)


def _serial_rows(tmp_path: Path) -> list[tuple]:
    path = tmp_path / "serial.db"
    with open_store(path) as store:
        run_campaign(fake_config(runs=RUNS, backend_options={"sleep": 0.0}), store)
    return db_rows(path)


def _ray_config(address: str):
    return fake_config(
        runs=RUNS,
        executor="ray",
        workers=2,
        ray_address=address,
        backend_options={"sleep": SLEEP},
    )


def test_two_node_cluster_stores_the_serial_rows(cluster, tmp_path):
    address, _ = cluster
    path = tmp_path / "ray.db"
    start = time.perf_counter()
    with open_store(path) as store:
        run_campaign(_ray_config(address), store)
    elapsed = time.perf_counter() - start
    nodes = [n for n in ray.nodes() if n["Alive"]]
    assert len(nodes) == 2  # head + worker, separate raylets
    assert db_rows(path) == _serial_rows(tmp_path)
    # two actors on two nodes: well under the serial sleep total of RUNS * SLEEP
    assert elapsed < RUNS * SLEEP + 30


def test_killing_a_worker_node_mid_campaign_loses_nothing(cluster, tmp_path, caplog):
    address, worker = cluster
    path = tmp_path / "ray-killed.db"
    killed: list[int] = []

    def progress(p) -> None:
        if p.event == "run" and p.done == KILL_AT and not killed:
            raylet = _raylet_of(worker)
            os.kill(raylet, signal.SIGKILL)
            killed.append(raylet)

    with caplog.at_level(logging.WARNING, logger="sitcov.campaign"), open_store(path) as store:
        result = run_campaign(_ray_config(address), store, progress=progress)
    assert killed, "the campaign ended before the node could be killed"
    assert result.counts == {**result.counts, "pending": 0, "error": 0}
    rows = db_rows(path)
    assert len(rows) == RUNS
    assert rows == _serial_rows(tmp_path)
    # the node's actor really was lost: its run was re-run on the surviving node
    assert any("lost with its Ray worker" in r.getMessage() for r in caplog.records)
    deadline = time.monotonic() + 30  # the head notices the dead node within seconds
    while sum(n["Alive"] for n in ray.nodes()) != 1:
        assert time.monotonic() < deadline, ray.nodes()
        time.sleep(0.5)
