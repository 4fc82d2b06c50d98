"""The Ray executor stores exactly what serial and multi-process executors store."""

from __future__ import annotations

import pytest
from campaign_fakes import crashes, raises
from campaign_helpers import db_rows, fake_config
from needs import need_module

from sitcov.campaign import open_store, run_campaign
from sitcov.campaign._summary import summarize_store

#: Ray tests share one xdist worker (``--dist loadgroup``), see test_ray_cluster.py.
pytestmark = pytest.mark.xdist_group("ray")

ray = need_module("ray", "ray")


@pytest.fixture(scope="module", autouse=True)
def ray_session():
    """One local Ray for the module (the executor reuses a running Ray and leaves it up)."""
    import os
    import sys

    path = os.pathsep.join(p for p in sys.path if p)
    ray.init(
        num_cpus=2,
        include_dashboard=False,
        log_to_driver=False,
        runtime_env={"env_vars": {"PYTHONPATH": path}},
    )
    yield
    ray.shutdown()


@pytest.mark.slow
def test_serial_processes_and_ray_agree_row_by_row_and_in_summary(tmp_path):
    rows, summaries = {}, {}
    options = {"raise_rate": 0.1}  # errors must land on the same runs everywhere too
    for label, changes in {
        "serial": {"executor": "serial"},
        "processes": {"executor": "processes", "workers": 2},
        "ray": {"executor": "ray", "workers": 2},
    }.items():
        path = tmp_path / f"{label}.db"
        with open_store(path) as store:
            run_campaign(fake_config(runs=40, backend_options=options, **changes), store)
            summaries[label] = summarize_store(store)
            errors = [r.index for r in store.runs(status="error")]
            assert errors == [r.index for r in store.runs() if raises(r.seed, 0.1)]
        rows[label] = db_rows(path)
    assert len(rows["serial"]) == 40
    assert rows["serial"] == rows["processes"] == rows["ray"]
    assert summaries["serial"] == summaries["processes"] == summaries["ray"]


@pytest.mark.slow
def test_ray_timeout_replaces_the_actor():
    store = open_store(None)
    cfg = fake_config(
        runs=8, executor="ray", workers=2, run_timeout=2.0, backend_options={"hang_rate": 0.2}
    )
    run_campaign(cfg, store)
    assert ray.is_initialized()  # the executor did not shut down a Ray it did not start
    runs = store.runs()
    assert {r.status for r in runs} <= {"pass", "fail", "timeout"}
    assert any(r.status == "timeout" for r in runs)
    assert all(r.status != "pending" for r in runs)


@pytest.mark.slow
def test_a_run_that_kills_its_ray_worker_every_time_is_an_error_after_3_attempts():
    from sitcov.campaign._executors import RAY_ATTEMPTS

    store = open_store(None)
    cfg = fake_config(runs=8, executor="ray", workers=2, backend_options={"crash_rate": 0.2})
    run_campaign(cfg, store)
    runs = store.runs()
    crashing = [r.index for r in runs if crashes(r.seed, 0.2)]
    assert crashing  # the seed gives at least one such run
    assert [r.index for r in runs if r.status == "error"] == crashing
    for run in runs:
        if run.index in crashing:
            assert f"the Ray worker died {RAY_ATTEMPTS} times" in run.outcome.message
        else:
            assert run.status in ("pass", "fail")
