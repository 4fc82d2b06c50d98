"""PEM calibration: the fit recovers known parameters; the sweep and the CLI run end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest
import yaml

from sitcov.perception import PEMFeatures, PEMParams, load_pem_params, pem_logit
from sitcov.perception._calibrate import Sample, fit_pem, pem_yaml, summarize_samples, sweep

TRUE = PEMParams(
    bias=0.4, size_gain=1.2, size_max_px=150.0, view_gain=-0.3, trunc_gain=2.0, fog_gain=0.8,
    illum_gain=0.5, rain_gain=1.5, noise_sigma=0.6, rain_sigma=0.4, rain_miss=0.0,
)  # fmt: skip


def _synthetic(n: int, rng: np.random.Generator) -> list[Sample]:
    """Samples drawn from the PEM's own model with TRUE parameters, censored at 0.05."""
    out = []
    for _ in range(n):
        rain = float(rng.choice([0.0, 0.0, 0.3, 0.6]))
        feats = PEMFeatures(
            height_px=float(math.exp(rng.uniform(math.log(5), math.log(300)))),
            view_angle=float(rng.uniform(0, math.pi / 2)),
            truncation=float(rng.choice([0.0, 0.0, 0.0, rng.uniform(0, 0.8)])),
            transmittance=float(rng.choice([1.0, 1.0, rng.uniform(0.05, 1.0)])),
            illumination=float(rng.choice([1.0, 1.0, rng.uniform(0.25, 1.0)])),
            rain_noise=rain,
        )
        z = pem_logit(feats, TRUE) + (TRUE.noise_sigma + TRUE.rain_sigma * rain) * rng.normal()
        score = 1 / (1 + math.exp(-z))
        score = score if score >= 0.05 else 0.0
        out.append(Sample("clear", 0.0, 10.0, 0.0, 0.0, feats.height_px, feats, score, None))
    return out


def test_fit_recovers_the_parameters_of_synthetic_data() -> None:
    samples = _synthetic(2000, np.random.default_rng(7))
    fit = fit_pem(samples)
    for name, tol in (("bias", 0.3), ("size_gain", 0.15), ("view_gain", 0.25),
                      ("trunc_gain", 0.4), ("fog_gain", 0.2), ("illum_gain", 0.35),
                      ("rain_gain", 0.4), ("noise_sigma", 0.12)):  # fmt: skip
        assert getattr(fit, name) == pytest.approx(getattr(TRUE, name), abs=tol), name
    assert fit.size_max_px in (100.0, 150.0, 200.0)
    assert fit.floor == 0.3


def test_fit_recovers_the_shape_view_and_offset_terms() -> None:
    true = PEMParams(bias=0.2, size_gain=1.0, size_max_px=150.0, aspect_gain=0.8,
                     view2_gain=0.5, edge_gain=0.6, noise_sigma=0.5, rain_sigma=0.0)  # fmt: skip
    rng = np.random.default_rng(3)
    samples = []
    for _ in range(2000):
        h = float(math.exp(rng.uniform(math.log(8), math.log(200))))
        feats = PEMFeatures(h, float(rng.uniform(0, math.pi / 2)), 0.0,
                            width_px=h * float(rng.uniform(0.8, 3.5)),
                            offset=float(rng.uniform(0, 1)))  # fmt: skip
        z = pem_logit(feats, true) + true.noise_sigma * rng.normal()
        score = 1 / (1 + math.exp(-z))
        samples.append(
            Sample("clear", 0.0, 10.0, 0.0, 0.0, h, feats, score if score >= 0.05 else 0.0, None)
        )
    fit = fit_pem(samples)
    for name in ("aspect_gain", "view2_gain", "edge_gain"):
        assert getattr(fit, name) == pytest.approx(getattr(true, name), abs=0.25), name


def test_fit_refuses_too_few_frames() -> None:
    from sitcov.errors import SitcovError

    with pytest.raises(SitcovError, match="too few"):
        fit_pem(_synthetic(5, np.random.default_rng(0)))


def test_pem_yaml_round_trips_through_the_pem_loader(tmp_path) -> None:
    text = pem_yaml(TRUE, "sitcov calibrate --frames 10", {"frames": 10})
    assert text.startswith("#") and "sitcov calibrate --frames 10" in text.splitlines()[3]
    path = tmp_path / "pem.yaml"
    path.write_text(text)
    assert load_pem_params(path) == TRUE
    assert yaml.safe_load(text)["meta"]["source"] == "sitcov calibrate"


def test_summary_rates_by_view_and_weather() -> None:
    f = PEMFeatures(100.0, 0.0, 0.0)
    samples = [
        Sample("clear", 0.0, 8.0, 0.0, 0.0, 120.0, f, 0.6, None),
        Sample("clear", 0.0, 8.0, 0.0, 0.1, 120.0, f, 0.0, None),
        Sample("clear", 0.0, 8.0, 0.0, math.pi, 120.0, f, 0.4, None),
        Sample("fog_density", 100.0, 8.0, 0.0, 1.5, 120.0, f, 0.0, None),
    ]
    s = summarize_samples(samples)
    assert s["clear_box_ge_10pct"]["rear"] == {"n": 2, "rate_floor": 0.5, "rate_0.5": 0.5,
                                               "mean_score": 0.3}  # fmt: skip
    assert s["clear_box_ge_10pct"]["front"]["rate_floor"] == 1.0
    assert s["box_ge_5pct_by_weather"]["fog_density=100"] == {"n": 1, "rate_floor": 0.0}


def test_sweep_with_the_real_detector(ssd_detector) -> None:
    samples = sweep(6, ssd_detector, seed=5)
    assert 0 < len(samples) <= 6
    assert all(0.0 <= s.score <= 1.0 for s in samples)
    assert all(1.0 <= s.distance <= 81.0 for s in samples)
    # Reproducible: the same seed gives the same samples.
    assert sweep(6, ssd_detector, seed=5) == samples


def test_trajectory_sweep_with_the_real_detector(ssd_detector) -> None:
    from sitcov.perception._temporal import trajectory_sweep

    tracks = trajectory_sweep(1, ssd_detector, seed=3)
    assert tracks and all(t.run == 0 and 0.0 <= t.score <= 1.0 for t in tracks)
    frames = [t.frame for t in tracks]
    assert frames == sorted(set(frames))  # one sample per 10 Hz frame, in time order
    assert any(t.score >= 0.3 for t in tracks)  # the OV is found along its approach


def test_the_shipped_file_is_calibrate_output_with_its_command() -> None:
    from sitcov.perception import PEM_PARAMS_FILE

    text = PEM_PARAMS_FILE.read_text()
    data = yaml.safe_load(text)
    command = data["meta"]["command"]
    assert command.startswith("sitcov calibrate ") and "--runs" in command
    assert command.endswith("--out sitcov/perception/data/pem.yaml")
    assert f"#   {command}" in text.splitlines()
    params = load_pem_params()
    # re-emitting the loaded parameters with the same header gives the same file body
    assert (
        pem_yaml(params, command, {"frames": data["meta"]["frames"]}).splitlines()[:4]
        == (text.splitlines()[:4])
    )
    # the temporal measurement is stored, and the fitted values are what it implies
    temporal = data["meta"]["temporal"]
    assert temporal["frames"] >= 500 and temporal["runs"] >= 10
    # the between-run share is measured but not kept as noise (systematic, not chance)
    share = temporal["between_run_share"]
    assert 0.0 <= share < 1.0 and params.noise_run_share == 0.0 and params.noise_tau > 0.0
    for lag, key in ((1, "lag1_autocorrelation"), (10, "lag10_autocorrelation")):
        implied = share + (1 - share) * math.exp(-0.1 * lag / params.noise_tau)
        assert implied == pytest.approx(temporal[key], abs=0.15), key
