"""The per-class PEM: pedestrians and cyclists scored by their own coefficients and labelled."""

from __future__ import annotations

import math
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

from sitcov.calibration._class_fit import fit_class
from sitcov.errors import ConfigError
from sitcov.perception import ActorView, PEMFeatures, PEMParams, PEMSensor, Pose, pem_score
from sitcov.perception._pem_classes import load_class_params
from sitcov.sim import conditions_from_values

EGO = Pose(0.0, 0.0, 0.0)
CLEAR = conditions_from_values({})


def _actor(kind: str, x: float, y: float = 0.0, yaw: float = 0.0) -> ActorView:
    dims = {"car": (4.5, 1.9, 1.5), "pedestrian": (0.5, 0.5, 1.75), "cyclist": (1.8, 0.6, 1.7)}
    return ActorView(Pose(x, y, yaw), *dims[kind], speed=1.0, kind=kind)


def test_shipped_file_maps_kinds_to_labels() -> None:
    classes = load_class_params()
    assert classes["pedestrian"][0] == "person"
    assert classes["cyclist"][0] == "person"  # its rider (docs/pem.md)
    for _, params in classes.values():
        assert isinstance(params, PEMParams) and params.size_min_px > 0


def test_detections_carry_the_class_of_each_kind() -> None:
    """A car is reported as ``car``, a pedestrian as ``person`` and a cyclist as its rider,
    ``person``, and its bicycle, ``bicycle`` (``PEM_LABELS``, ``PEM_PARTS``), each in at
    least a quarter of the frames (the rider and the others in at least half)."""
    sensor = PEMSensor()
    actors = {"car": _actor("car", 12.0, 4.0), "pedestrian": _actor("pedestrian", 8.0, 0.0, 1.5),
              "cyclist": _actor("cyclist", 7.0, -1.0)}  # fmt: skip
    want = {"car": {"car"}, "pedestrian": {"person"}, "cyclist": {"person", "bicycle"}}
    for kind, actor in actors.items():
        labels = []
        for seed in range(60):
            labels += [
                d.label for d in sensor.detect(EGO, (actor,), CLEAR, np.random.default_rng(seed))
            ]
        assert set(labels) == want[kind], kind
        counts = {label: labels.count(label) for label in want[kind]}
        assert all(n >= 15 for n in counts.values()), (kind, counts)
        assert max(counts.values()) >= 30, (kind, counts)


def test_pedestrian_detection_falls_with_distance_and_fog() -> None:
    """Reported (>= floor) near, not far; fog at 12 m pulls the score under the AEB's 0.5
    in most frames (the shipped fit: 66 % -> 0 % of 200 frames; tolerance 30 points)."""
    sensor = PEMSensor()

    def rate(x: float, cond, threshold: float = 0.0) -> float:
        hits = 0
        for seed in range(200):
            dets = sensor.detect(EGO, (_actor("pedestrian", x),), cond, np.random.default_rng(seed))
            hits += any(d.score >= threshold for d in dets)
        return hits / 200

    near, far = rate(7.0, CLEAR), rate(30.0, CLEAR)
    assert near > 0.8 and far < near - 0.3, (near, far)
    fog = conditions_from_values({"fog_density": 100, "fog_distance": 0})
    assert rate(12.0, fog) <= rate(12.0, CLEAR)
    assert rate(12.0, fog, 0.5) < rate(12.0, CLEAR, 0.5) - 0.3


def test_bad_class_file_is_one_config_error(tmp_path) -> None:
    bad = tmp_path / "c.yaml"
    bad.write_text("classes:\n  pedestrian: {params: {bias: 1}}\n")
    with pytest.raises(ConfigError, match="label"):
        load_class_params(bad)
    bad.write_text("classes:\n  pedestrian: {label: person, params: {bogus: 1}}\n")
    with pytest.raises(ConfigError, match="bogus"):
        load_class_params(bad)


def test_fit_recovers_a_known_model_from_censored_scores() -> None:
    """Synthetic frames from known coefficients, censored below 0.05 as the sweep is: the
    fitted model's probability of a score >= 0.5 (and >= 0.3) matches the truth's within
    0.06 on average
    over fresh frames (2000 frames; the fit's reference size differs, so coefficients are
    compared through their predictions)."""
    rng = np.random.default_rng(7)
    truth = PEMParams(bias=0.2, size_gain=1.5, size_ref_px=60.0, size_min_px=10.0,
                      size_max_px=300.0, view_gain=0.4, fog_gain=1.0, noise_sigma=0.6,
                      trunc_gain=0.0, illum_gain=0.0, rain_gain=0.0)  # fmt: skip

    def frames(n: int) -> list[PEMFeatures]:
        return [
            PEMFeatures(float(np.exp(rng.uniform(math.log(15), math.log(200)))),
                        float(rng.uniform(0, math.pi / 2)), 0.0,
                        float(np.exp(-rng.uniform(0.0, 2.0))))
            for _ in range(n)
        ]  # fmt: skip

    def draw(f: PEMFeatures) -> float:
        z = math.log(pem_score(f, truth) / (1 - pem_score(f, truth)))
        s = 1.0 / (1.0 + math.exp(-(z + truth.noise_sigma * rng.standard_normal())))
        return s if s >= 0.05 else 0.0

    train = frames(2000)
    fitted = fit_class([(f, draw(f)) for f in train], truth)
    from scipy.stats import norm

    def p_above(f: PEMFeatures, p: PEMParams, t: float) -> float:
        z = math.log(pem_score(f, p) / (1 - pem_score(f, p))) - math.log(t / (1 - t))
        return float(norm.cdf(z / p.noise_sigma))

    test = [f for f in frames(500) if f.height_px >= fitted.size_min_px]
    for t in (0.5, 0.3):  # the AEB's threshold, the reporting floor
        err = np.mean([abs(p_above(f, fitted, t) - p_above(f, truth, t)) for f in test])
        assert err < 0.06, (t, err)
    assert fitted.noise_sigma == pytest.approx(0.6, rel=0.25)


DATA = Path(__file__).parents[2] / "docs" / "data"
#: The calibration recordings per kind (seed 1): the pedestrian's, and the cyclist's
#: scored by its rider's person boxes (what its PEM detection stands for).
SAMPLES = {
    "pedestrian": DATA / "pem-frames-pedestrian-seed1.jsonl.gz",
    "cyclist": DATA / "pem-frames-rider-seed1.jsonl.gz",
}


@pytest.fixture(scope="module")
def stored_samples() -> dict:
    from sitcov.calibration._calibrate_classes import read_samples

    return {kind: read_samples(path)[kind] for kind, path in SAMPLES.items()}


@pytest.mark.parametrize(
    ("kind", "band"),
    [
        ("pedestrian", (30, 45)),
        ("pedestrian", (45, 70)),
        ("pedestrian", (70, 1000)),
        ("cyclist", (30, 45)),
        ("cyclist", (45, 70)),
        ("cyclist", (70, 1000)),
    ],
)
def test_shipped_pem_follows_the_detector_at_the_aeb_threshold(
    kind: str, band: tuple[int, int], stored_samples
) -> None:
    """Per box-height bin from 30 px up, the PEM's share of frames at >= 0.5 (its
    probability, averaged) is within 10 points of the SSD's, on the calibration sweep
    (800 frames of seed 1, ``SAMPLES``: the cyclist's scored by its rider's person box).
    Cyclists from 70 px up pass since the two-stage fit to the top score (before it: SSD
    0.88, PEM 0.60).
    The round-1 file (intercept shifted in logit units) over-reported by up to 56 points
    on the seed-2 frames."""
    from sitcov.perception._pem import pass_probability

    _, params = load_class_params()[kind]
    sweep, _ = stored_samples[kind]
    for lo, hi in (band,):
        rows = [(f, s) for f, s in sweep if lo <= f.height_px < hi]
        ssd = np.mean([s >= 0.5 for _, s in rows])
        pem = np.mean([pass_probability(f, params, 0.5) for f, _ in rows])
        assert abs(pem - ssd) <= 0.10, (kind, lo, ssd, pem)


def test_a_class_file_without_the_noises_size_gain_keeps_none(tmp_path: Path) -> None:
    """Missing names take the car PEM's values, but not the terms newer than the class
    files (``OWN_TERMS``): a class file written before the noise's size gain loads without
    it even when the car PEM has one, so it draws as it did."""
    from sitcov.perception._pem_classes import OWN_TERMS, load_class_params
    from sitcov.perception._pem_params import load_pem_params

    assert load_pem_params().noise_size_gain != 0.0  # the shipped car PEM has one
    path = tmp_path / "classes.yaml"
    path.write_text("classes:\n  pedestrian: {label: person, params: {bias: 0.3}}\n")
    (label, params) = load_class_params(path)["pedestrian"]
    assert label == "person" and params.bias == 0.3
    assert params.noise_size_gain == 0.0 and params.noise_size_max_px == 450.0
    assert params.box_dy0 == 0.0 and params.jitter_y == -1.0  # no box offsets: centred
    car = load_pem_params()
    assert car.view_hinge40_gain != 0.0 and car.size_hinge40_gain != 0.0  # car terms
    assert params.view_hinge40_gain == params.size_hinge40_gain == 0.0  # not the class's
    assert params.size_hinge80_gain == 0.0
    assert set(OWN_TERMS) == {
        "noise_size_gain", "noise_size_max_px", "box_dx0", "box_dy0", "box_dx1", "box_dy1",
        "jitter_y", "size_hinge40_gain", "size_hinge80_gain", "view_hinge40_gain",
        "noise_outlier_share", "noise_outlier_ratio", "noise_up_size_gain", "noise_low_tail",
        "cut_gain", "cut_tent_gain", "noise_bend_gain", "noise_bend_px",
        "noise_up_rain_wind_gain", "noise_up_rain_wind_px", "noise_tau_size_gain",
        "head_on_gain", "noise_ceiling_logit", "noise_ceiling_size_gain", "noise_ceiling_slope",
    }  # fmt: skip
    assert params.noise_ceiling_slope == 1.0  # the car's ceiling is not the class's
    assert params.noise_outlier_share == params.noise_up_size_gain == 0.0  # none inherited
    assert params.noise_up_rain_wind_gain == params.noise_tau_size_gain == 0.0
    assert params.noise_low_tail == params.noise_bend_gain == 0.0
    assert params.noise_outlier_ratio == 1.0
    assert params.noise_sigma == load_pem_params().noise_sigma  # the others: the car's


def test_the_shipped_person_boxes_are_the_detectors() -> None:
    """The pedestrian's and the rider's PEM boxes carry the detector's box as recorded
    (``BOX_OFFSET_KINDS``, docs/pem.md "The pedestrian's box"): narrower than the
    projected box (left edge in, right edge in) and scattered less up and down than
    across; the car keeps the centred box with one corner noise."""
    from sitcov.calibration._frame_model import BOX_OFFSET_KINDS
    from sitcov.perception._pem_params import load_pem_params

    classes = load_class_params()
    for kind in BOX_OFFSET_KINDS:
        _, p = classes[kind]
        assert p.box_dx0 > 0.0 > p.box_dx1, kind
        assert 0.0 <= p.jitter_y < p.jitter, kind
    car = load_pem_params()
    assert (car.box_dx0, car.box_dx1, car.jitter_y) == (0.0, 0.0, -1.0)


def _edited_classes(
    tmp_path: Path, edit: Callable[[dict], object], name: str = "classes.yaml"
) -> Path:
    """The shipped per-class file with ``edit`` applied to its ``classes`` mapping, written
    to ``tmp_path / name``."""
    import yaml

    from sitcov.perception._pem_classes import PEM_CLASSES_FILE

    data = yaml.safe_load(PEM_CLASSES_FILE.read_text())
    edit(data["classes"])
    path = tmp_path / name
    path.write_text(yaml.safe_dump(data))
    return path


def _with_bicycle(tmp_path: Path, bicycle: dict | None) -> Path:
    """The shipped per-class file with the cyclist's ``bicycle`` entry set (None: none)."""

    def edit(classes: dict) -> None:
        classes.pop("bicycle", None)
        if bicycle is not None:
            params = {**classes["cyclist"]["params"], **bicycle}
            classes["bicycle"] = {"label": "bicycle", "params": params}

    return _edited_classes(tmp_path, edit, "rider.yaml" if bicycle is None else "both.yaml")


def test_a_cyclist_gives_its_rider_and_its_bicycle(tmp_path: Path) -> None:
    """With a ``bicycle`` entry a cyclist gives two detections a frame (``PEM_PARTS``): the
    rider (``person``) and the bicycle (``bicycle``), each by its own law and box (here the
    bicycle's box offsets move its top edge 40 % of the height down, so its boxes are lower
    and shorter than the rider's), on independent noise tracks; a file without the entry
    (every file before it) gives the rider alone. Cars and pedestrians are untouched."""
    bike = {"box_dy0": 0.4, "box_dy1": 0.0, "bias": 0.5}
    both = PEMSensor(classes=_with_bicycle(tmp_path, bike))
    assert both.parts("cyclist") == ("cyclist", "bicycle")
    assert both.parts("pedestrian") == ("pedestrian",) and both.parts("car") == ("car",)
    cyclist = (_actor("cyclist", 9.0, -1.0),)
    tops: dict[str, list[float]] = {"person": [], "bicycle": []}
    heights: dict[str, list[float]] = {"person": [], "bicycle": []}
    for seed in range(80):
        dets = both.detect(EGO, cyclist, CLEAR, np.random.default_rng(seed))
        assert len(dets) <= 2
        for d in dets:
            tops[d.label].append(d.box[1])
            heights[d.label].append(d.box[3] - d.box[1])
    assert len(tops["person"]) >= 40 and len(tops["bicycle"]) >= 40
    assert np.median(tops["bicycle"]) > np.median(tops["person"]) + 20.0
    assert np.median(heights["bicycle"]) < 0.75 * np.median(heights["person"])
    alone = PEMSensor(classes=_with_bicycle(tmp_path, None))
    assert alone.parts("cyclist") == ("cyclist",)
    for seed in range(20):
        dets = alone.detect(EGO, cyclist, CLEAR, np.random.default_rng(seed))
        assert {d.label for d in dets} <= {"person"}


def test_the_embedded_backend_gives_a_cyclists_two_detections(tmp_path: Path) -> None:
    """The embedded backend's prepared path (``prepare_parts``) gives what ``detect`` gives:
    per frame the rider's and the bicycle's detections, the same draws in the same order."""
    from types import SimpleNamespace

    path = _with_bicycle(tmp_path, {"box_dy0": 0.4, "box_dy1": 0.0})
    a, b = PEMSensor(classes=path), PEMSensor(classes=path)
    actor = _actor("cyclist", 14.0, -1.0)
    looks = a.prepare_parts(actor, CLEAR)
    assert [look[2] for look in looks] == ["person", "bicycle"]
    body = SimpleNamespace(x=actor.pose.x, y=actor.pose.y, yaw=actor.pose.yaw)
    rng_a, rng_b = np.random.default_rng(3), np.random.default_rng(3)
    labels = set()
    for _ in range(30):
        got = a.detect_prepared(0.0, 0.0, 0.0, [(look, body) for look in looks], CLEAR, rng_a)
        assert got == b.detect(EGO, (actor,), CLEAR, rng_b)
        labels |= {d.label for d in got}
    assert labels == {"person", "bicycle"}


@pytest.mark.parametrize("tau, low, high", [(0.0, -0.2, 0.2), (3.0, 0.8, 1.0)])
def test_a_class_draws_its_own_noise_process(tmp_path: Path, tau, low, high) -> None:
    """A pedestrian's score noise runs by its class's ``noise_tau`` and shares, not the
    car PEM's (0.53 s): with ``noise_tau`` 0 its consecutive frames are independent, with
    3 s (an AR coefficient of 0.97 per frame) they move together. Lag-1 correlation of the
    score's logit over 600 frames of a static pedestrian, one run; no outlier frames (each
    draws a fresh noise of its own, independent of the process)."""
    own = {"noise_tau": tau, "noise_frame_share": 0.0, "noise_run_share": 0.0,
           "detect_bias": 9.0, "floor": 0.0, "noise_outlier_share": 0.0}  # fmt: skip
    path = _edited_classes(tmp_path, lambda classes: classes["pedestrian"]["params"].update(own))
    sensor = PEMSensor(classes=path)
    sensor.reset(frame_dt=0.1)
    rng = np.random.default_rng(7)
    actor = (_actor("pedestrian", 12.0, 0.0, 1.5),)
    logits = []
    for _ in range(600):
        (det,) = sensor.detect(EGO, actor, CLEAR, rng)
        logits.append(math.log(det.score / (1.0 - det.score)))
    x = np.asarray(logits)
    lag1 = float(np.corrcoef(x[:-1], x[1:])[0, 1])
    assert low <= lag1 <= high, lag1
