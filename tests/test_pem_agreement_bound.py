"""benchmarks/pem_agreement_bound.py, whose noise/bias split docs/pem.md quotes: the split
of the PEM's disagreement with a camera that is a fixed function of the world."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from benchmark_modules import load_benchmark

ROOT = Path(__file__).resolve().parents[1]
ROWS = ROOT / "docs/data/agreement-stacks-seed8-100-camera.csv"


@pytest.fixture(scope="module")
def bound() -> ModuleType:
    return load_benchmark("pem_agreement_bound")


def test_a_noise_free_pem_that_matches_the_camera_has_no_noise_nor_bias(bound) -> None:
    c = np.array([1.0, 0.0, 1.0, 0.0])
    row = bound.decompose(c.copy(), c)
    assert (row["expected"], row["majority"], row["noise"], row["bias"]) == (1.0, 1.0, 0.0, 0.0)
    assert row["pem_pem_shared_world"] == 1.0 and row["uncertain_situations"] == 0


def test_noise_is_what_the_majority_verdict_gains_and_bias_what_it_keeps(bound) -> None:
    c = np.array([1.0, 1.0, 0.0, 0.0, 1.0])
    p = np.array([0.8, 0.3, 0.2, 0.6, 0.5])
    row = bound.decompose(p, c)
    # majority: 0.8 -> fail (right), 0.3 -> pass (wrong), 0.2 -> pass (right),
    # 0.6 -> fail (wrong), 0.5 -> pass (wrong): 2 of 5
    assert row["majority"] == pytest.approx(0.4)
    assert row["expected"] == pytest.approx(np.mean([0.8, 0.3, 0.8, 0.4, 0.5]))
    assert row["noise"] + row["bias"] == pytest.approx(1.0 - row["expected"], abs=1e-4)
    assert (row["pem_fails_camera_passes"], row["camera_fails_pem_passes"]) == (1, 2)
    assert row["pem_pem_shared_world"] == pytest.approx(np.mean(1 - 2 * p * (1 - p)), abs=1e-4)


def test_camera_verdicts_are_stream_a_rows_of_the_seed(bound) -> None:
    verdicts = bound.camera_verdicts([ROWS], 8)
    assert ("reference", 0) in verdicts and len(verdicts) == 400
    assert bound.camera_verdicts([ROWS], 9) == {}


def test_failure_probabilities_are_shares_of_seeded_draws(bound) -> None:
    from sitcov.campaign._agreement import SideRunner, SideSettings

    runner = SideRunner(SideSettings())
    p = bound.failure_probabilities(runner, "reference", 8, [0, 1, 2], 3)
    assert p.shape == (3,) and set(np.round(p * 3)).issubset({0.0, 1.0, 2.0, 3.0})
    again = bound.failure_probabilities(runner, "reference", 8, [0, 1, 2], 3)
    np.testing.assert_array_equal(p, again)  # seeded draws: the same shares


def test_a_missing_rows_file_is_one_clear_line(bound, tmp_path, capsys) -> None:
    assert bound.main(["--camera-rows", str(tmp_path / "none.csv")]) == 2
    assert "no such rows file" in capsys.readouterr().err
