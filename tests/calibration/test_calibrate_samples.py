"""Car calibration from stored samples: the file round-trips, refits reproduce the fit, and
the cross-validated model choice finds what made synthetic verdicts."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
import yaml

from sitcov.calibration._calibrate import Sample, fit_pem
from sitcov.calibration._camera_runs import CameraRun, RunFrame
from sitcov.calibration._cv import FitOption, cross_validate, fold_of, pick
from sitcov.calibration._recording import Recording, read_recording, write_recording
from sitcov.errors import ConfigError
from sitcov.perception import PEMFeatures, PEMParams, load_pem_params, pem_logit

TRUE = PEMParams(
    bias=-0.3, size_gain=1.2, size2_gain=-0.2, view_gain=0.3, facing2_gain=0.2,
    trunc_gain=1.5, fog_gain=0.8, illum_gain=0.5, rain_gain=1.0, noise_sigma=0.6,
    rain_sigma=0.0, rain_miss=0.0, size_max_px=150.0,
)  # fmt: skip


def _samples(n: int, seed: int) -> list[Sample]:
    """Sweep samples drawn from the PEM's own model (scores reported from 0.05 up)."""
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        rel = float(rng.uniform(-math.pi, math.pi))
        h = float(math.exp(rng.uniform(math.log(5), math.log(300))))
        feats = PEMFeatures(
            height_px=h,
            view_angle=abs(rel) if abs(rel) <= math.pi / 2 else math.pi - abs(rel),
            truncation=float(rng.choice([0.0, 0.0, rng.uniform(0, 0.8)])),
            transmittance=float(rng.choice([1.0, rng.uniform(0.05, 1.0)])),
            illumination=float(rng.choice([1.0, rng.uniform(0.25, 1.0)])),
            rain_noise=float(rng.choice([0.0, 0.3, 0.6])),
            width_px=h * float(rng.uniform(1.0, 3.0)),
            offset=float(rng.uniform(0.0, 1.0)),
            facing=math.cos(rel),
        )
        z = pem_logit(feats, TRUE) + TRUE.noise_sigma * rng.normal()
        score = 1 / (1 + math.exp(-z))
        err = tuple(float(e) for e in rng.normal(0, 0.03, 4)) if score >= 0.05 else None
        out.append(
            Sample(
                "fog_density",
                40.0,
                12.5,
                0.1,
                -0.3,
                feats.width_px,
                feats,
                score if score >= 0.05 else 0.0,
                err,
                (200, 30, 40),
            )  # fmt: skip
        )
    return out


def _recording() -> Recording:
    samples = _samples(60, 1)
    frames = tuple(RunFrame(s.features, s.score, s.box_error, s.width_px) for s in samples[:7])
    situation = {"id": "x", "values": {"wind": 10.0, "intsit": {"ego": "L-B", "ov": "R-B"}}}
    runs = (
        CameraRun(0, 123, situation, True, 3.25, frames, 1.5, 2.0),
        CameraRun(1, 456, situation, False, None, (), 0.5, 0.75),
    )
    return Recording(1, 80, tuple(samples), runs)


@pytest.mark.parametrize("name", ["rec.jsonl", "rec.jsonl.gz"])
def test_a_recording_round_trips_through_its_file(tmp_path, name) -> None:
    rec = _recording()
    write_recording(tmp_path / name, rec)
    back = read_recording(tmp_path / name)
    assert back == rec  # floats by repr: exactly equal, so refits reproduce the fit
    assert fit_pem(list(back.samples) * 20) == fit_pem(list(rec.samples) * 20)


def test_a_bad_samples_file_is_one_config_error(tmp_path) -> None:
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"meta": {"seed": 1, "frames": 5}}\n{"sweep": {"element": 3}}\n')
    with pytest.raises(ConfigError, match="line 2"):
        read_recording(bad)
    nometa = tmp_path / "nometa.jsonl"
    nometa.write_text("")
    with pytest.raises(ConfigError, match="meta"):
        read_recording(nometa)
    with pytest.raises(ConfigError, match="readable"):
        read_recording(tmp_path / "missing.jsonl")


def test_ridge_shrinks_and_drop_zeroes_coefficients() -> None:
    samples = _samples(3000, 2)
    default = fit_pem(samples)
    assert fit_pem(samples, ridge=1.0, drop=()) == default
    strong = fit_pem(samples, ridge=3000.0)
    gains = ("size_gain", "trunc_gain", "fog_gain", "illum_gain", "rain_gain")

    def norm(p: PEMParams) -> float:
        return sum((getattr(p, g) / p.noise_sigma) ** 2 for g in gains)

    assert norm(strong) < 0.5 * norm(default)
    dropped = fit_pem(samples, drop=("fog_gain", "rain_gain"))
    assert dropped.fog_gain == 0.0 and dropped.rain_gain == 0.0 and dropped.size_gain > 0
    with pytest.raises(ValueError, match="bias"):
        fit_pem(samples, drop=("bias",))


def test_folds_are_balanced_seeded_and_cover_every_run() -> None:
    fold = fold_of(103, 5, seed=4)
    counts = np.bincount(fold, minlength=5)
    assert counts.sum() == 103 and counts.max() - counts.min() <= 1
    assert np.array_equal(fold, fold_of(103, 5, seed=4))
    assert not np.array_equal(fold, fold_of(103, 5, seed=5))
    with pytest.raises(ValueError):
        fold_of(3, 5, seed=0)


def test_cross_validation_finds_the_shift_that_made_the_verdicts() -> None:
    """Camera verdicts made by a PEM firing much less readily than the frame fit (intercept
    -1.5; the refitted PEM fires readily enough that +1.5 changes few of 40 verdicts): the
    held-out agreement picks that shift, and runs never see their own fold."""
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    base = replace(load_pem_params(), noise_tau=0.0)
    truth = replace(base, bias=base.bias - 1.5)
    backend = EmbeddedBackend(perception="pem", sensor=PEMSensor(truth))
    gen = make_generator("random", load_hyperspace())
    runs = []
    for i in range(40):
        sit = gen.ask(np.random.default_rng([9, i]))
        outcome = backend.run(sit, ReferenceStack(), 100 + i)
        runs.append(CameraRun(i, 100 + i, sit.to_dict(), outcome.failed, None, ()))

    class Fixed(FitOption):
        def fit(self, recording, train):  # the score model is known: only noise is chosen
            assert len(train) == 32  # 4 of 5 folds of 40 runs
            return base

    rec = Recording(1, 0, (), tuple(runs))
    result = cross_validate(rec, [Fixed()], scales=(1.0,), shifts=(0.0, -1.5), folds=5)
    table = result["table"]
    low, high = (table[f"ridge=1 | tau=0 scale=1 shift={s}"] for s in ("0", "-1.5"))
    assert high["agreement"] > low["agreement"] and high["n"] == 40
    assert pick(result) == "ridge=1 | tau=0 scale=1 shift=-1.5"


def _sitcov(*args: str):
    import subprocess
    import sys

    return subprocess.run(
        [sys.executable, "-c", "from sitcov.cli import main; main()", *args],
        capture_output=True, text=True, timeout=300,
    )  # fmt: skip


def _pem_made_recording(n: int) -> Recording:
    """Sweep frames from the PEM's formula and runs whose verdicts a PEM made."""
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.perception import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    backend = EmbeddedBackend(perception="pem", sensor=PEMSensor(load_pem_params()))
    gen = make_generator("random", load_hyperspace())
    runs = []
    for i in range(n):
        sit = gen.ask(np.random.default_rng([5, i]))
        outcome = backend.run(sit, ReferenceStack(), 200 + i)
        runs.append(CameraRun(i, 200 + i, sit.to_dict(), outcome.failed, None, ()))
    return Recording(3, 400, tuple(_samples(400, 3)), tuple(runs))


@pytest.mark.slow
def test_calibrate_from_samples_refits_without_rendering(tmp_path, monkeypatch) -> None:
    """``sitcov calibrate --from-samples F [--cv-folds K]``: the file's seed becomes the
    calibration seed, the header names the command, the params are fit_recording's.

    The command runs in this process with ``fit_recording`` spied on (the command looks
    it up when it runs): it is given exactly the recording written (read back equal to
    ``rec``) and ``cv_folds=2``, and the file is ``pem_yaml`` of what it returned. As the
    fit is deterministic, that is the ``fit_recording(rec, cv_folds=2)`` this test used to
    compute a second time in-process (~13 CPU-s) after a subprocess ran the command."""
    from sitcov.calibration import _calibrate_cars as cal
    from sitcov.calibration._calibrate import pem_yaml
    from sitcov.cli import main

    rec = _pem_made_recording(6)
    samples = tmp_path / "s.jsonl.gz"
    write_recording(samples, rec)
    out = tmp_path / "pem.yaml"
    real, fits = cal.fit_recording, []

    def spied(recording, **kwargs):
        fits.append((recording, kwargs, real(recording, **kwargs)))
        return fits[-1][2]

    monkeypatch.setattr(cal, "fit_recording", spied)
    try:
        main(["calibrate", "--from-samples", str(samples), "--cv-folds", "2", "--out", str(out)])
    except SystemExit as exc:
        assert not exc.code, exc.code
    command = f"sitcov calibrate --from-samples {samples} --cv-folds 2 --out {out}"
    ((given, kwargs, (params, summary)),) = fits
    assert given == rec and kwargs == {"cv_folds": 2}
    assert out.read_text() == pem_yaml(params, command, summary)
    meta = yaml.safe_load(out.read_text())["meta"]
    assert meta["calibration_seeds"] == [3] and meta["command"] == command
    assert meta["camera_runs"]["cross_validation"]["folds"] == 2
    bad = tmp_path / "bad.jsonl"
    bad.write_text("not json\n")
    result = _sitcov("calibrate", "--from-samples", str(bad))
    assert result.returncode != 0 and "Traceback" not in result.stderr + result.stdout
    assert "bad.jsonl" in result.stderr + result.stdout
