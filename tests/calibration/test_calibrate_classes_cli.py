"""``sitcov calibrate --classes``: bad input is one message; a small fit writes a file the
PEM loads, headed by the command that made it, with its calibration seed."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from cli_helpers import run_cli

from sitcov.perception._pem_classes import load_class_params


def sitcov(*args: str, timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", "from sitcov.cli import main; main()", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
    )


@pytest.mark.parametrize("classes", ["car", "pedestrian,bogus", ""])
def test_bad_classes_are_one_message(classes: str, capsys) -> None:
    code, out, err = run_cli(capsys, "calibrate", "--classes", classes, "--frames", "50")
    assert code == 2
    assert "--classes" in err
    assert "Traceback" not in err + out


@pytest.mark.slow
def test_small_fit_writes_a_loadable_file(tmp_path: Path, ssd_model: Path) -> None:
    out = tmp_path / "pem_classes.yaml"
    args = ("calibrate", "--classes", "pedestrian", "--frames", "120", "--runs", "3",
            "--seed", "5", "--model", str(ssd_model), "--out", str(out))  # fmt: skip
    result = sitcov(*args, timeout=900)
    assert result.returncode == 0, result.stderr
    text = out.read_text()
    assert "sitcov calibrate --classes pedestrian --frames 120 --runs 3 --seed 5" in text[:400]
    meta = yaml.safe_load(text)["meta"]
    assert meta["calibration_seeds"] == [5]
    assert meta["pedestrian"]["camera_runs"]["runs"] == 3
    label, params = load_class_params(out)["pedestrian"]
    assert label == "person" and params.noise_sigma > 0


def test_bad_from_samples_is_one_message(tmp_path: Path, capsys) -> None:
    """Without --classes, a missing file, a bad row: each one line naming what is wrong."""
    good = tmp_path / "s.jsonl"
    good.write_text('{"kind": "pedestrian", "sweep": [30.0, 0.0, 0.0], "score": 0.4}\n')
    bad = tmp_path / "bad.jsonl"
    bad.write_text("not json\n")
    cases = (
        (("--from-samples", str(good)), "line 1"),  # cars: not a car samples file
        (("--classes", "pedestrian", "--from-samples", str(tmp_path / "none.jsonl")), "none"),
        (("--classes", "pedestrian", "--from-samples", str(bad)), "line 1"),
        (("--classes", "cyclist", "--from-samples", str(good)), "kind"),
        (("--classes", "pedestrian", "--cv-folds", "3"), "--cv-folds"),
    )
    for args, needle in cases:
        code, out, err = run_cli(capsys, "calibrate", *args)
        assert code == 2, (args, err)
        assert needle in err and "Traceback" not in err + out
