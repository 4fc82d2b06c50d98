"""``--carla-launch``: a CARLA server that dies mid-campaign is started again with the
launch command, the backend waits (bounded) until it accepts connections, and goes on.

The fake server stands in for CARLA: :meth:`FakeServer.kill` loses its world, and it comes
back once its ``revive_file`` exists, which is what the launch command (``touch FILE``, a
real shell command run by the backend) creates.
"""

from __future__ import annotations

import time

import pytest
from carla_testkit import SERVERS, DrivingStack, fake_backend, situation, small_map

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.errors import BackendUnavailableError, ConfigError
from sitcov.sim.carla import carla_backend_options


def _relaunching(tmp_path, **options):
    flag = tmp_path / "server-up"
    backend, server = fake_backend(
        small_map(tmp_path), launch=f"touch {flag}", launch_timeout=20.0, **options
    )
    server.revive_file = flag
    return backend, server


def test_server_killed_between_runs_is_relaunched(tmp_path) -> None:
    backend, server = _relaunching(tmp_path)
    first = backend.run(situation(), DrivingStack(), seed=1)
    server.kill()
    second = backend.run(situation(), DrivingStack(), seed=1)
    assert second.status in ("pass", "fail") and backend.launches == 1
    assert server.reachable and not server.actors
    assert [e for e in server.log if e[0] == "load_world"] == [("load_world", "Town03")] * 2
    # a fresh server gives the same run (the retry is the only difference)
    assert (first.status, first.min_distance) == (second.status, second.min_distance)


def test_server_killed_during_a_run_is_relaunched_and_the_run_retried(tmp_path) -> None:
    backend, server = _relaunching(tmp_path)
    tick = server._tick

    def dying_tick() -> int:
        if server.ticks == 40 and not server.kills:
            server.kill()
        return tick()

    server._tick = dying_tick
    outcome = backend.run(situation(), DrivingStack(), seed=1)
    assert outcome.status in ("pass", "fail") and outcome.metrics["attempts"] == 2
    assert server.kills == 1 and backend.launches == 1 and not server.actors


def test_launch_command_that_fails_is_one_clear_error(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path), launch="exit 3", launch_timeout=20.0)
    server.kill()
    outcome = backend.run(situation(), DrivingStack(), seed=1)
    assert outcome.status == "error" and "exited with status 3" in outcome.message
    with pytest.raises(BackendUnavailableError, match="exited with status 3"):
        backend.run(situation(), DrivingStack(), seed=1)


def test_waiting_for_a_launched_server_is_bounded(tmp_path) -> None:
    backend, server = fake_backend(small_map(tmp_path), launch="true", launch_timeout=1.5)
    server.kill()
    backend.run(situation(), DrivingStack(), seed=1)  # error outcome after the wait
    start = time.monotonic()
    with pytest.raises(BackendUnavailableError, match=r"within 1.5s of running --carla-launch"):
        backend.run(situation(), DrivingStack(), seed=1)
    assert 1.5 <= time.monotonic() - start < 10.0
    assert backend.launches == 2


def test_launch_command_gets_host_and_port_and_is_validated(tmp_path) -> None:
    backend, _ = fake_backend(small_map(tmp_path), port=2004, launch="run.sh -port={port}")
    assert backend.launch == "run.sh -port=2004"
    with pytest.raises(ConfigError, match="carla_launch"):
        fake_backend(small_map(tmp_path), launch="run.sh {gpu}")
    with pytest.raises(ConfigError, match="carla_launch"):
        carla_backend_options(launch="  ")
    assert carla_backend_options(launch="CarlaUE4.sh")["launch"] == "CarlaUE4.sh"


@pytest.mark.slow
def test_campaign_goes_on_when_the_server_dies_mid_campaign(tmp_path, ssd_model_dir) -> None:
    """The reference stack brakes on its camera detector: the model comes from the fixture
    (issue 26: without it this test failed on every machine with an empty user cache)."""
    flag = tmp_path / "server-up"
    options = {
        "map": str(small_map(tmp_path)),
        "server_key": "relaunch",
        "revive_file": str(flag),
        "launch": f"touch {flag}",
        "launch_timeout": 20.0,
    }
    config = CampaignConfig(
        name="c",
        backend="carla_testkit:FakeCarlaBackend",
        backend_options=options,
        av="reference",
        runs=12,
        batch_size=4,
        executor="serial",
        workers=1,
        seed=2,
    )
    killed = []

    def progress(p) -> None:
        if p.event == "run" and p.done in (3, 8):
            SERVERS["relaunch"].kill()
            killed.append(p.done)

    store = open_store(None)
    result = run_campaign(config, store, progress=progress)
    assert killed == [3, 8] and SERVERS["relaunch"].kills == 2
    assert result.counts["pending"] == result.counts["error"] == 0
    assert sum(result.counts.values()) == 12
