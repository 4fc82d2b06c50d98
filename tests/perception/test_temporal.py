"""The PEM's noise is correlated in time as specified, and the noise state never leaks from
one run into the next."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitcov.perception import ActorView, PEMSensor, Pose, pem_logit
from sitcov.sim import conditions_from_values

EGO = Pose(0.0, 0.0, 0.0)
CLEAR = conditions_from_values({})
CAR = ActorView(Pose(15.0, 0.5, 0.3), 4.7, 1.85, 1.5)
#: The shipped file's noise shape, its size gain, score ceiling and detection term switched
#: off: these tests set the noise structure they check (a normal law of one scale; the actor
#: always output).
PLAIN = {"detect_bias": 8.0, "detect_gain": 0.0, "detect_ar": 0.0, "noise_up_ratio": 1.0,
         "noise_frame_share": 0.0, "noise_size_gain": 0.0,
         "noise_ceiling_slope": 1.0}  # fmt: skip


def _noise_series(sensor: PEMSensor, runs: int, frames: int) -> np.ndarray:
    """(runs, frames) of the standardised logit noise the sensor added (floor 0: all reported)."""
    z = pem_logit(sensor.features(EGO, CAR, CLEAR), sensor.params)
    sigma = sensor.params.noise_sigma
    out = np.empty((runs, frames))
    for r in range(runs):
        rng = np.random.default_rng([11, r])
        for f in range(frames):
            (det,) = sensor.detect(EGO, (CAR,), CLEAR, rng)
            s = det.score
            out[r, f] = (math.log(s / (1 - s)) - z) / sigma
    return out


def _pooled_corr(x: np.ndarray, lag: int) -> float:
    c = x - x.mean()
    return float((c[:, :-lag] * c[:, lag:]).mean() / c.var())


def test_sensor_noise_has_the_specified_run_share_and_correlation_time() -> None:
    share, tau = 0.3, 0.5
    sensor = PEMSensor({**PLAIN, "noise_run_share": share, "noise_tau": tau, "floor": 0.0,
                        "bias": 0.0, "noise_sigma": 0.5, "rain_miss": 0.0})  # fmt: skip
    x = _noise_series(sensor, runs=300, frames=40)
    assert x.std() == pytest.approx(1.0, abs=0.08)
    for lag in (1, 5, 20):
        expected = share + (1 - share) * math.exp(-lag * 0.1 / tau)
        assert _pooled_corr(x, lag) == pytest.approx(expected, abs=0.07), lag
    # the per-run offset: run means vary far more than independent frames would allow
    assert x.mean(axis=1).var() > 0.2


def test_frame_share_is_fresh_noise_on_top_of_the_ar1_part() -> None:
    """The frame model's noise: lag-k correlation ``(1 - frame share) * phi^k``, unit variance."""
    fresh, tau = 0.25, 1.0
    sensor = PEMSensor({**PLAIN, "noise_frame_share": fresh, "noise_tau": tau,
                        "noise_run_share": 0.0, "floor": 0.0, "bias": 0.0,
                        "noise_sigma": 0.5})  # fmt: skip
    x = _noise_series(sensor, runs=300, frames=40)
    assert x.std() == pytest.approx(1.0, abs=0.08)
    for lag in (1, 3, 10):
        expected = (1 - fresh) * math.exp(-lag * 0.1 / tau)
        assert _pooled_corr(x, lag) == pytest.approx(expected, abs=0.07), lag


def test_independent_frames_when_the_correlation_is_off() -> None:
    sensor = PEMSensor({**PLAIN, "noise_run_share": 0.0, "noise_tau": 0.0, "floor": 0.0,
                        "bias": 0.0, "noise_sigma": 0.5, "rain_miss": 0.0})  # fmt: skip
    x = _noise_series(sensor, runs=100, frames=30)
    assert abs(_pooled_corr(x, 1)) < 0.06
    assert x.mean(axis=1).var() < 0.08  # ~1/30 for independent frames


def test_rain_misses_come_in_runs() -> None:
    sensor = PEMSensor({**PLAIN, "noise_tau": 1.0, "rain_miss": 0.5, "floor": 0.0})
    wet = conditions_from_values({"precipitation": 100, "precipitation_deposits": 100,
                                  "wetness": 100})  # fmt: skip
    hits = np.array(
        [
            [bool(sensor.detect(EGO, (CAR,), wet, rng)) for _ in range(60)]
            for rng in (np.random.default_rng([3, r]) for r in range(80))
        ],
        dtype=float,
    )
    p = 1 - hits.mean()
    assert p == pytest.approx(0.5 * wet.rain_noise, abs=0.06)  # the marginal miss rate is kept
    # a miss is followed by a miss much more often than the marginal rate
    after_miss = hits[:, 1:][hits[:, :-1] == 0]
    assert 1 - after_miss.mean() > p + 0.3


def test_a_reused_sensor_gives_each_run_its_own_noise() -> None:
    sensor = PEMSensor({**PLAIN, "noise_run_share": 0.5, "noise_tau": 1.0})

    def run(s: PEMSensor, seed: int) -> list:
        rng = np.random.default_rng(seed)
        return [s.detect(EGO, (CAR,), CLEAR, rng) for _ in range(20)]

    fresh = run(PEMSensor({**PLAIN, "noise_run_share": 0.5, "noise_tau": 1.0}), 5)
    run(sensor, 4)  # another run first: its state must not leak
    assert run(sensor, 5) == fresh
    rng = np.random.default_rng(5)
    sensor.detect(EGO, (CAR,), CLEAR, rng)
    sensor.reset()  # an explicit reset restarts the state even with the same rng object
    assert sensor._tracks == {} and sensor._frame == 0


def test_backend_reusing_its_sensor_is_deterministic_per_run() -> None:
    from sitcov.av import ReferenceStack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim.embedded import EmbeddedBackend

    gen = make_generator("random", load_hyperspace())
    sits = [gen.ask(np.random.default_rng([1, i])) for i in range(3)]
    backend = EmbeddedBackend(perception="pem")
    stack = ReferenceStack()
    first = [backend.run(s, stack, 17 + i) for i, s in enumerate(sits)]
    again = [backend.run(s, stack, 17 + i) for i, s in reversed(list(enumerate(sits)))][::-1]
    assert first == again
