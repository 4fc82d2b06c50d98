"""A campaign that cannot run at all (camera model missing) stops at once with one line."""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.errors import MissingExtraError, SetupError, SitcovError


def test_setup_errors_are_sitcov_errors_and_keep_their_old_bases() -> None:
    from sitcov.perception import ModelNotFoundError

    assert issubclass(ModelNotFoundError, SetupError)
    assert issubclass(MissingExtraError, SetupError) and issubclass(MissingExtraError, ImportError)
    assert issubclass(SetupError, SitcovError)


def test_serial_camera_campaign_without_model_raises_and_stores_no_result(
    tmp_path, monkeypatch
) -> None:
    monkeypatch.setenv("SITCOV_MODEL_DIR", str(tmp_path / "empty"))
    config = CampaignConfig(
        runs=3, executor="serial", workers=1, backend_options={"perception": "camera"}
    )
    store = open_store(tmp_path / "c.db")
    with pytest.raises(SetupError, match="sitcov models fetch"):
        run_campaign(config, store)
    assert all(r.outcome is None for r in store.runs())


@pytest.mark.parametrize("workers", ["1", "2"])
def test_cli_camera_campaign_without_model_prints_one_line(tmp_path, workers: str) -> None:
    env = dict(os.environ, SITCOV_MODEL_DIR=str(tmp_path / "empty"))
    db = tmp_path / "cam.db"
    proc = subprocess.run(
        [sys.executable, "-c", "from sitcov.cli import main; main()", "run",
         "--perception", "camera", "--runs", "4", "--workers", workers, "--db", str(db)],
        env=env, capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert proc.returncode == 2
    errors = [line for line in proc.stderr.splitlines() if line.startswith("error:")]
    assert len(errors) == 1 and "sitcov models fetch" in errors[0]
    assert "Traceback" not in proc.stderr
    store = open_store(db)
    assert not [r for r in store.runs() if r.outcome is not None]
