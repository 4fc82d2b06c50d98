"""Per-class calibration: one kind's situations, the frames the fit uses, the intercept
shift chosen on verdicts, the stored file and the held-out seed check."""

from __future__ import annotations

from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

from sitcov.calibration._calibrate_classes import (
    ClassCalibration,
    choose_shift,
    class_agreement,
    classes_yaml,
    fit_frames,
    parse_classes,
    pick_shift,
    read_samples,
    write_samples,
)
from sitcov.calibration._camera_runs import CameraRun, RunFrame
from sitcov.calibration._class_runs import check_class_seeds, class_hyperspace
from sitcov.errors import ConfigError
from sitcov.generation import make_generator
from sitcov.perception import PEMFeatures
from sitcov.perception._pem_classes import load_class_params


@pytest.mark.parametrize("kind", ["pedestrian", "cyclist"])
def test_class_hyperspace_holds_only_that_kind(kind: str) -> None:
    space = class_hyperspace(kind)
    gen = make_generator("random", space)
    rng = np.random.default_rng(3)
    for _ in range(60):
        values = gen.ask(rng).values
        assert values["intsit"]["kind"] == kind
        assert values["actor2"] == "none"


def test_class_hyperspace_refuses_other_kinds() -> None:
    with pytest.raises(ConfigError, match="kind"):
        class_hyperspace("car")
    with pytest.raises(ConfigError, match="map"):
        class_hyperspace("pedestrian", "no-such-map")


def _feats(height: float) -> PEMFeatures:
    return PEMFeatures(height, 0.0, 0.0, 1.0, 1.0, 0.0, 0.3 * height, 0.0, 0.0, 0.0, 0.0, 0.0,
                       0.0, 0.0)  # fmt: skip


def _run(index: int, heights: list[float], failed: bool, situation: dict | None = None):
    frames = tuple(RunFrame(_feats(h), 0.6, None, 0.3 * h) for h in heights)
    return CameraRun(index, 1000 + index, situation or {}, failed, None, frames)


def test_fit_uses_every_sweep_frame_and_every_run_frame() -> None:
    sweep = [(_feats(h), 0.4) for h in (10.0, 30.0, 44.0, 50.0, 120.0)]
    runs = [_run(0, [45.0, 80.0, 0.5], False), _run(1, [60.0], True)]
    used = fit_frames(sweep, runs)
    assert sorted(f.height_px for f, _ in used) == [10.0, 30.0, 44.0, 45.0, 50.0, 60.0, 80.0,
                                                    120.0]  # fmt: skip
    assert len(fit_frames(sweep, [])) == len(sweep)


def test_parse_classes() -> None:
    assert parse_classes("pedestrian, cyclist") == ["pedestrian", "cyclist"]
    for bad in ("", "car", "pedestrian,pedestrian"):
        with pytest.raises(ConfigError, match="--classes"):
            parse_classes(bad)


def _situations(kind: str, n: int) -> list[dict]:
    gen = make_generator("random", class_hyperspace(kind))
    rng = np.random.default_rng(11)
    return [gen.ask(rng).to_dict() for _ in range(n)]


def test_choose_shift_follows_the_camera_verdicts() -> None:
    """Camera verdicts that all fail pull the intercept down (the PEM fails more), all
    passing pull it up; each choice agrees with the camera at least as well as shift 0."""
    label, params = load_class_params()["pedestrian"]
    sits = _situations("pedestrian", 12)
    shifts = (-1.5, 0.0, 1.5)
    for failed, sign in ((True, -1), (False, 1)):
        runs = [_run(i, [], failed, s) for i, s in enumerate(sits)]
        chosen, table = choose_shift("pedestrian", label, params, runs, shifts)
        shift = round((chosen.bias - params.bias) / params.noise_sigma, 3)
        assert table[f"shift={shift:g}"]["agreement"] >= table["shift=0"]["agreement"]
        assert shift * sign >= 0, (failed, table)
    agree, rate = class_agreement("pedestrian", label, replace(params, bias=-9.0), runs)
    assert rate >= table["shift=0"]["failure_rate"]  # a PEM that never sees fails more
    assert agree == pytest.approx(1.0 - rate)  # every camera run passed


def test_pick_shift_sends_near_ties_to_the_smallest_shift() -> None:
    """Within AGREEMENT_TOLERANCE (0.02) of the best agreement the smallest |shift| wins;
    a clearly better shift still wins; equal |shift| goes to the negative one."""
    p = {s: s for s in (-1.0, 0.0, 0.5, 1.0, 2.0)}
    assert pick_shift([(0.96, 0.0, p[0.0]), (0.98, 1.0, p[1.0]), (0.97, 0.5, p[0.5])]) == 0.0
    assert pick_shift([(0.90, 0.0, p[0.0]), (0.98, 2.0, p[2.0]), (0.965, 0.5, p[0.5])]) == 0.5
    assert pick_shift([(0.90, 0.0, p[0.0]), (0.98, 2.0, p[2.0]), (0.955, 0.5, p[0.5])]) == 2.0
    assert pick_shift([(0.95, 1.0, p[1.0]), (0.95, -1.0, p[-1.0])]) == -1.0
    with pytest.raises(ValueError):
        pick_shift([])


def test_samples_round_trip_and_bad_rows_are_one_error(tmp_path) -> None:
    label, params = load_class_params()["pedestrian"]
    sweep = [(_feats(h), 0.1 * i) for i, h in enumerate((12.0, 40.0, 90.0))]
    runs = [_run(0, [45.0, 80.0], False, {"a": 1}), _run(1, [], True)]
    cal = ClassCalibration("pedestrian", label, params, sweep, runs, {})
    path = tmp_path / "samples.jsonl"
    write_samples(path, [cal])
    assert read_samples(path) == {"pedestrian": (sweep, runs)}
    path.write_text('{"kind": "pedestrian", "run": {"index": 1}}\n')
    with pytest.raises(ConfigError, match="line 1"):
        read_samples(path)


def test_stored_file_round_trips(tmp_path) -> None:
    label, params = load_class_params()["cyclist"]
    cal = ClassCalibration("cyclist", label, replace(params, bias=0.123), [], [], {"frames": 0})
    path = tmp_path / "pem_classes.yaml"
    path.write_text(classes_yaml([cal], "sitcov calibrate --classes cyclist", seed=1))
    assert path.read_text().splitlines()[2].endswith("sitcov calibrate --classes cyclist")
    loaded = load_class_params(path)
    assert loaded["cyclist"] == (label, replace(params, bias=0.123))
    with pytest.raises(ConfigError, match=r"\[1\]"):
        check_class_seeds([1, 2], "cyclist", str(path), allow=False)
    check_class_seeds([2, 4], "cyclist", str(path), allow=False)
    check_class_seeds([1], "cyclist", str(path), allow=True)


def test_a_file_without_calibration_seeds_is_refused(tmp_path) -> None:
    path = tmp_path / "c.yaml"
    path.write_text("classes: {}\n")
    with pytest.raises(ConfigError, match="calibration_seeds"):
        check_class_seeds([2], "pedestrian", str(path), allow=False)
    with pytest.raises(ConfigError, match="kind"):
        check_class_seeds([2], "truck", str(path), allow=True)


def test_a_cyclists_frames_are_scored_by_its_riders_person_boxes(monkeypatch) -> None:
    """The class recorder scores a cyclist by the boxes its PEM detection stands for
    (``PEM_LABELS``: the rider's ``person`` boxes, not the bicycle's), a pedestrian by
    ``person`` boxes; the PEM's label and the recorded score are of the same box. The
    ``bicycle`` entry records the cyclists' situations by their ``bicycle`` boxes."""
    from sitcov.calibration import _camera_runs
    from sitcov.calibration._class_runs import ClassRecorder
    from sitcov.perception._base import Detection

    monkeypatch.setattr(_camera_runs._Recorder, "__init__", lambda self, *a, **k: None)
    dets = [
        Detection((0.0, 0.0, 10.0, 30.0), 0.7, "person"),
        Detection((0.0, 10.0, 10.0, 30.0), 0.9, "bicycle"),
        Detection((0.0, 0.0, 10.0, 30.0), 0.8, "car"),
    ]
    for kind in ("cyclist", "pedestrian"):
        rec = ClassRecorder(kind, None)
        assert rec.labels == ("person",)
        assert rec._candidates(dets) == [dets[0]]
    bike = ClassRecorder("bicycle", None)  # the cyclist's second detection
    assert bike.kind == "cyclist" and bike.labels == ("bicycle",)
    assert bike._candidates(dets) == [dets[1]]
    assert bike._records(SimpleNamespace(kind="cyclist"))
    assert not bike._records(SimpleNamespace(kind="bicycle"))  # no road user of that kind
