"""The shipped PEM files are the frame model's output, with their provenance, and pass the
held-out check."""

from __future__ import annotations

import functools
from pathlib import Path

import pytest
import yaml

from sitcov.perception._pem_classes import PEM_CLASSES_FILE, load_class_params
from sitcov.perception._pem_params import PEM_PARAMS_FILE, load_pem_params

#: One worker runs this file's tests, so each recording's check rows (about 7 CPU-s) are
#: computed once (``_check_rows`` is cached per process).
pytestmark = pytest.mark.xdist_group("frame_model_shipped_check")

ROOT = Path(__file__).resolve().parents[2]
#: The check's held-out recordings per kind: 300 runs of seed 3, a seed neither the fit
#: (seed 1) nor the model choice (seed 2's even runs) read; the car's; the pedestrian's;
#: the cyclist's scored by its rider's person boxes and by its bicycle boxes (its two PEM
#: detections, docs/pem.md). Seed 2's odd runs (30 per kind), the check before them, leave each cell
#: a run-bootstrap interval about +-0.08 wide below 10 m: too wide to judge +-0.05.
HELD_OUT = {
    "car": ROOT / "docs" / "data" / "pem-frames-top-seed3.jsonl.gz",
    "pedestrian": ROOT / "docs" / "data" / "pem-frames-pedestrian-seed3.jsonl.gz",
    "cyclist": ROOT / "docs" / "data" / "pem-frames-rider-seed3.jsonl.gz",
    "bicycle": ROOT / "docs" / "data" / "pem-frames-bicycle-seed3.jsonl.gz",
}
#: A second held-out recording of every kind (seed 4, 300 runs each), read by nothing but
#: the check.
HELD_OUT_SEED4 = {
    kind: Path(str(path).replace("seed3", "seed4")) for kind, path in HELD_OUT.items()
}


def _files(command: str, flag: str) -> list[Path]:
    words = command.split()
    return [ROOT / words[i + 1] for i, w in enumerate(words) if w == flag]


@pytest.mark.parametrize("path", [PEM_PARAMS_FILE, PEM_CLASSES_FILE], ids=["cars", "classes"])
def test_shipped_file_is_the_frame_model_with_its_provenance(path: Path) -> None:
    text = path.read_text()
    data = yaml.safe_load(text)
    meta = data["meta"]
    command = meta["command"]
    assert command.startswith("sitcov calibrate --frames-from ")
    assert f"#   {command}" in text.splitlines()
    if path == PEM_PARAMS_FILE:
        assert "--out sitcov/perception/data/pem.yaml" in command
    else:
        assert "--classes-out sitcov/perception/data/pem_classes.yaml" in command
    assert meta["calibration_seeds"] == [1] and len(meta["date"]) == 10
    assert all(p.is_file() for p in _files(command, "--frames-from") + _files(command, "--heldout"))
    kinds = ["car"] if path == PEM_PARAMS_FILE else ["pedestrian", "cyclist", "bicycle"]
    for kind in kinds:
        summary = meta[kind]
        table = summary["model_choice"]["table"]
        # the column that chose (the frames-alone likelihood of the two-stage fit; files
        # before it chose by the sequence's and do not name it)
        by = summary["model_choice"].get("by", "heldout_loglik_per_frame")
        best = max(table, key=lambda k: table[k][by])
        assert summary["model_choice"]["chosen"] == best
        assert summary["frames"] > 1000
    # no number edited by hand: the params are what the loader reads back
    if path == PEM_PARAMS_FILE:
        loaded = load_pem_params().to_dict()
        assert data["params"] == {k: v for k, v in loaded.items() if k in data["params"]}
        # every term is in the fit (a term added later has its default, no term, until the
        # next refit: the box's offsets and vertical noise, fitted for cyclists only)
        default = load_pem_params().__class__().to_dict()
        assert all(loaded[k] == default[k] for k in set(loaded) - set(data["params"]))
        assert "side_gain" in data["params"]
    else:
        loaded = load_class_params()
        for kind, entry in data["classes"].items():
            assert loaded[kind] == (entry["label"], load_pem_params().__class__(**entry["params"]))


def test_no_term_is_chosen_on_a_stacks_verdicts() -> None:
    """The frame model has no intercept shift or noise scale picked on run verdicts."""
    meta = yaml.safe_load(PEM_PARAMS_FILE.read_text())["meta"]
    assert "camera_runs" not in meta and "bias_shift" not in str(meta)


@functools.lru_cache(maxsize=2)
def _check_rows(seed: int = 3) -> list[dict]:
    import numpy as np

    from sitcov.calibration import _frame_check as fc
    from sitcov.calibration._frames import read_frames

    held = HELD_OUT if seed == 3 else HELD_OUT_SEED4
    frames = {k: read_frames(path)[k] for k, path in held.items()}
    classes = load_class_params()
    params = {k: load_pem_params() if k == "car" else classes[k][1] for k in frames}
    return fc.check_frames(frames, params, rng=np.random.default_rng(1))


def test_held_out_check_from_10_m_on() -> None:
    """On the held-out runs (seed 3, 300 per kind), from 10 m on: every judged cell within
    ±0.05 of the detector (25 of 25 with the shipped files, the bicycle's 5 at 10-20 m
    among them: there every bicycle box of the detector scores under 0.3; the largest gap
    -0.035, the person at θ = 0.5, 10-20 m; `sitcov calibrate --check
    docs/data/pem-frames-top-seed3.jsonl.gz --kinds car` and the three class recordings,
    docs/pem.md, "Held-out check") and none
    significantly off (its run-bootstrap interval wholly outside ±0.05). On seed 2's 30
    odd runs, the check before, 15 of these 20 cells passed, the largest gap +0.114: its
    cells' intervals were up to 0.2 wide."""
    rows = [r for r in _check_rows() if "ok" in r and not r["band"].startswith("0-")]
    assert len(rows) == 25  # person, rider, bicycle: too few frames beyond 20 m to judge
    assert all(r["ok"] and not r["significant"] for r in rows), rows
    assert all(r["runs"] >= 200 for r in rows)


def test_the_close_car_is_within_and_the_pem_still_under_the_detector() -> None:
    """What is closest to the line, stated as it is measured: the car below 10 m at θ
    0.5 and 0.6, where the PEM says a score >= θ less often than the detector gives one
    (docs/pem.md, "The mid-size cut car": the car cut by the image edge with a box of
    110-440 px; with its tent term and the windy rain's upper spread -0.029 and -0.041
    [-0.066, -0.018], with the tent alone -0.033 and -0.049, before it -0.048 and -0.063,
    the one miss of 44 of 45). Both within ±0.05 and under the detector; no
    cell of any class significantly off (its run-bootstrap interval reaches inside
    ±0.05)."""
    rows = [r for r in _check_rows() if "ok" in r]
    close = {r["theta"]: r for r in rows if r["kind"] == "car" and r["band"] == "0-10 m"}
    assert all(close[th]["ok"] and close[th]["difference"] < 0 for th in (0.5, 0.6)), close
    assert not any(r["significant"] for r in rows), [r for r in rows if r["significant"]]


def test_held_out_check_done_when_on_a_second_recording() -> None:
    """On seed 4's recordings (300 runs per kind, read by nothing but the check) every
    judged cell of every class is within ±0.05 of the detector: 45 of 45 (the car's
    close θ 0.6 cell -0.027 [-0.049, -0.004], the rider's close θ 0.5 -0.048; `sitcov
    calibrate --check docs/data/pem-frames-top-seed4.jsonl.gz --kinds car` and the class
    recordings, docs/pem.md)."""
    from sitcov.calibration import _frame_check as fc

    rows = _check_rows(4)
    judged = [r for r in rows if "ok" in r]
    assert len(judged) == 45 and all(r["ok"] for r in judged), fc.table_lines(rows)


def test_held_out_check_done_when() -> None:
    """The done-when check: P(score >= θ), θ = 0.3..0.7, within ±0.05 of the detector's
    per class and distance band, on the held-out runs (seed 3, 300 per kind): 45 of 45
    since the car's cut tent (docs/pem.md, "The mid-size cut car"; 44 before it)."""
    from sitcov.calibration import _frame_check as fc

    rows = _check_rows()
    judged = [r for r in rows if "ok" in r]
    assert judged and all(r["ok"] for r in judged), fc.table_lines(rows)
