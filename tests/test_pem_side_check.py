"""benchmarks/pem_side_check.py, whose per-side table docs/pem.md quotes: each run's frames
go to its situation's approach side and distance band, and the rates are the held-out
check's (detector share of frames at θ, the PEM's mean probability)."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from benchmark_modules import load_benchmark

from sitcov.calibration._frame_check import pass_probability
from sitcov.calibration._frames import KindFrames, read_frames, write_frames
from sitcov.hyperspace._situation import approach_side
from sitcov.perception._pem_params import load_pem_params

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def side_check() -> ModuleType:
    return load_benchmark("pem_side_check")


def _side(run) -> str:
    return approach_side(run.situation["bins"], run.situation["values"])


def test_rates_per_side_and_band_are_the_checks_on_those_frames(side_check, tmp_path) -> None:
    runs = read_frames(ROOT / "docs/data/pem-frames-seed2.jsonl.gz")["car"].runs
    left = [r for r in runs if _side(r) == "left"][:2]
    right = [r for r in runs if _side(r) == "right"][:1]
    path = tmp_path / "frames.jsonl.gz"
    write_frames(path, {"car": KindFrames(runs=left + right)})
    lines = side_check.side_table(str(path), "car")
    assert {line.split()[0] for line in lines} == {"left", "right"}
    params = load_pem_params()
    near = [
        (f.features, f.score)
        for r in left
        for f in r.frames
        if 10.0 <= f.distance < 20.0 and f.features.height_px >= 1.0
    ]
    line = next(x for x in lines if x.split()[:2] == ["left", "10-20"])
    assert f"n={len(near):5d}" in line
    det = np.mean([s >= 0.5 for _, s in near])
    pem = np.mean([pass_probability(params, feats, 0.5) for feats, _ in near])
    assert f"θ 0.5: detector {det:.2f} PEM {pem:.2f}" in line


@pytest.fixture(scope="module")
def side_fit() -> ModuleType:
    return load_benchmark("pem_side_fit")


def test_side_fit_pairs_each_candidate_with_its_side_version(side_fit) -> None:
    from sitcov.calibration import _frame_model as fm

    cands = side_fit.candidates(["ar1_edge_scale", "ar1_edge_scale_image_size_side"])
    names = [c[0] for c in cands]
    assert names == ["ar1_edge_scale", "ar1_edge_scale_side", "ar1_edge_scale_image_size_side"]
    assert [fm._flags(c)[5] for c in cands] == [False, True, True]
    assert fm._flags(cands[1])[:5] == fm._flags(cands[0])[:5]


def test_side_fit_rates_are_the_side_checks(side_fit, side_check, tmp_path) -> None:
    runs = read_frames(ROOT / "docs/data/pem-frames-seed2.jsonl.gz")["car"].runs[:6]
    path = tmp_path / "frames.jsonl.gz"
    write_frames(path, {"car": KindFrames(runs=runs)})
    rates = side_fit.side_rates(read_frames(path)["car"], load_pem_params())
    for line in side_check.side_table(str(path), "car"):
        key = " ".join(line.split()[:3])
        if key in rates:
            n, det, pem = rates[key]
            assert f"n={n:5d}" in line and f"θ 0.5: detector {det:.2f} PEM {pem:.2f}" in line
    assert rates
