"""What a recording stores per road user and frame: the top score among the detections
overlapping its true box (what a stack acting on any detection sees), the best-overlap
score beside it; frames files written before that still load."""

from __future__ import annotations

import gzip
import json
from dataclasses import asdict
from pathlib import Path

import numpy as np
import pytest

from sitcov.calibration._camera_runs import (
    MATCH_IOU,
    NOT_STORED,
    CameraRun,
    RunFrame,
    best_overlap_score,
    match,
)
from sitcov.calibration._frames import KindFrames, read_frames, write_frames
from sitcov.perception._detector import Detection
from sitcov.perception._nms import iou
from sitcov.perception._pem import PEMFeatures

TRUTH = (100.0, 100.0, 200.0, 180.0)


def _iou(box: tuple[float, ...]) -> float:
    return float(iou(np.asarray(TRUTH), np.asarray([box]))[0])


def test_the_top_score_among_the_overlapping_boxes_wins_over_the_best_overlap() -> None:
    tight = Detection((102.0, 101.0, 199.0, 181.0), 0.35)  # IoU ~0.96, low score
    loose = Detection((130.0, 110.0, 230.0, 190.0), 0.72)  # IoU >= 0.3, higher score
    assert _iou(tight.box) > 0.9 and MATCH_IOU <= _iou(loose.box) < 0.9
    for dets in ([tight, loose], [loose, tight]):
        score, err = match(TRUTH, dets)
        assert score == pytest.approx(0.72)
        assert err == pytest.approx((0.3, 0.125, 0.3, 0.125))  # the loose box's error
        assert best_overlap_score(TRUTH, dets) == pytest.approx(0.35)


def test_a_higher_score_below_the_overlap_threshold_does_not_count() -> None:
    tight = Detection((102.0, 101.0, 199.0, 181.0), 0.35)
    off = Detection((170.0, 100.0, 270.0, 180.0), 0.95)  # IoU 0.18
    assert _iou(off.box) < MATCH_IOU
    assert match(TRUTH, [off, tight])[0] == pytest.approx(0.35)
    assert match(TRUTH, [off]) == (0.0, None)
    assert best_overlap_score(TRUTH, [off]) == 0.0
    assert match(TRUTH, []) == (0.0, None) and best_overlap_score(TRUTH, []) == 0.0


def test_equal_scores_take_the_better_overlap() -> None:
    a = Detection((130.0, 110.0, 230.0, 190.0), 0.6)
    b = Detection((101.0, 100.0, 201.0, 180.0), 0.6)
    assert match(TRUTH, [a, b])[1] == pytest.approx((0.01, 0.0, 0.01, 0.0))


def _run(frames: tuple[RunFrame, ...]) -> CameraRun:
    return CameraRun(0, 11, {"intsit": "x"}, False, None, frames)


def test_the_best_overlap_score_round_trips_and_old_files_load(tmp_path: Path) -> None:
    feats = PEMFeatures(40.0, 0.3, 0.0)
    new = RunFrame(feats, 0.72, (0.3, 0.1, 0.3, 0.1), 100.0, 3, 0, 12.5, 0.35)
    path = tmp_path / "new.jsonl.gz"
    write_frames(path, {"car": KindFrames(runs=[_run((new,))])})
    assert read_frames(path)["car"].runs[0].frames == (new,)
    # a run row written before score_best_iou existed reads with NOT_STORED
    row = asdict(_run((RunFrame(feats, 0.4, None, 100.0, 3, 0, 12.5),)))
    del row["frames"][0]["score_best_iou"]
    old = tmp_path / "old.jsonl"
    old.write_text(json.dumps({"kind": "car", "run": row}) + "\n")
    frame = read_frames(old)["car"].runs[0].frames[0]
    assert frame.score == 0.4 and frame.score_best_iou == NOT_STORED


def test_the_shipped_recordings_first_run_row_still_loads(tmp_path: Path) -> None:
    shipped = Path(__file__).parents[2] / "docs" / "data" / "pem-frames-seed2.jsonl.gz"
    with gzip.open(shipped, "rt") as fh:
        line = next(ln for ln in fh if '"run"' in ln)
    part = tmp_path / "part.jsonl"
    part.write_text(line)
    runs = read_frames(part)["car"].runs
    assert runs and runs[0].frames
    assert all(f.score_best_iou == NOT_STORED for f in runs[0].frames)
