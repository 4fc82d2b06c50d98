"""benchmarks/pem_cyclist_boxes.py, whose table docs/pem.md quotes ("The cyclist's detection
is its rider"): per frame the top-scoring box of each label overlapping the cyclist, the
label holding the top score, the labels whose boxes pass the AEB's test, the first firing
detection, and the summary over runs."""

from __future__ import annotations

from types import ModuleType

import pytest
from benchmark_modules import load_benchmark

from sitcov.perception._base import Detection

TRUTH = (100.0, 100.0, 200.0, 300.0)  # 100 px wide, 200 px tall


@pytest.fixture(scope="module")
def boxes() -> ModuleType:
    return load_benchmark("pem_cyclist_boxes")


def _tall(d: Detection) -> bool:
    return d.box[3] - d.box[1] >= 150.0


def test_frame_record_per_label(boxes) -> None:
    dets = [
        Detection((120.0, 100.0, 180.0, 280.0), 0.62, "person"),  # the rider: tall, passes
        Detection((120.0, 110.0, 180.0, 280.0), 0.55, "person"),  # a second, lower person box
        Detection((100.0, 180.0, 200.0, 300.0), 0.70, "bicycle"),  # top score, too short
        Detection((100.0, 100.0, 200.0, 300.0), 0.90, "car"),  # not a cyclist's label
        Detection((500.0, 100.0, 600.0, 300.0), 0.95, "person"),  # elsewhere: IoU 0
    ]
    rec = boxes.frame_record(TRUTH, 210.0, 7.5, dets, _tall)
    assert rec["h"] == 210.0 and rec["dist"] == 7.5
    assert rec["person"] == {"score": 0.62, "h": 180.0, "iou": 0.54, "pass": True}
    assert rec["bicycle"]["score"] == 0.7 and rec["bicycle"]["h"] == 120.0
    assert rec["bicycle"]["pass"] is False
    assert rec["top"] == "bicycle" and rec["top_score"] == 0.7
    assert rec["passing"] == ["person"]
    empty = boxes.frame_record(TRUTH, 210.0, 7.5, [], _tall)
    assert empty["top"] is None and empty["passing"] == [] and "person" not in empty


def test_first_firing_is_the_first_passing(boxes) -> None:
    short = Detection((100.0, 200.0, 200.0, 300.0), 0.9, "bicycle")
    tall = Detection((100.0, 100.0, 200.0, 300.0), 0.6, "person")
    assert boxes.first_firing([short, tall], _tall) is tall
    assert boxes.first_firing([short], _tall) is None


def _run(failed: bool, first: dict | None, frames: list[dict]) -> dict:
    return {"failed": failed, "first": first, "frames": frames}


def test_summary_counts_and_medians(boxes) -> None:
    def frame(top, person_h=None, passing=()):
        f = {"h": 200.0, "top": top, "top_score": 0.6, "passing": list(passing)}
        if person_h is not None:
            f["person"] = {"h": person_h}
        return f

    cam = [frame("person", 160.0, ["person"]), frame("bicycle", 180.0), frame(None)]
    pem = [{"h": 200.0, "top": "bicycle", "top_score": 0.4, "passing": []}]
    runs = [
        {"camera": _run(True, {"label": "person", "h": 150.0, "true_h": 200.0, "dist": 5.0}, cam),
         "pem": _run(False, {"label": "bicycle", "h": 260.0, "true_h": 200.0, "dist": 8.0}, pem)},
        {"camera": _run(True, None, []), "pem": _run(True, None, [])},
    ]  # fmt: skip
    s = boxes.summarise(runs)
    assert s["runs"] == 2
    c, p = s["camera"], s["pem"]
    assert c["frames"] == 3 and c["frames_with_box"] == 2
    assert c["top_label"] == {"person": 1, "bicycle": 1}
    assert c["height_ratio_median"]["person"] == pytest.approx(0.85)
    assert c["height_ratio_median"]["bicycle"] is None
    assert c["frames_passing"] == {"person": 1, "bicycle": 0}
    assert c["failed"] == 2 and p["failed"] == 1
    assert c["first_label"] == {"person": 1} and p["first_label"] == {"bicycle": 1}
    assert c["first_height_ratio_median"] == 0.75 and p["first_height_ratio_median"] == 1.3
    assert s["both_fired"] == 1 and s["pem_fired_farther"] == 1
    assert s["camera_fired_farther"] == 0
