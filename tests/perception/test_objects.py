"""Object lists: the ground truth in the ego frame, and the documented noise and miss model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitcov.errors import ConfigError
from sitcov.perception import (
    ActorView,
    ObjectMisses,
    ObjectNoise,
    PEMSensor,
    Pose,
    load_object_noise,
    object_list,
    pem_miss_processes,
)
from sitcov.perception._pem_classes import load_class_params
from sitcov.sim import conditions_from_values

EGO = Pose(10.0, 5.0, math.pi / 2)  # heading +y: ego-frame x is world +y, y is world -x


def _car(x: float, y: float, yaw: float = 0.0, kind: str = "car") -> ActorView:
    return ActorView(Pose(x, y, yaw), 4.5, 1.9, 1.5, kind=kind)


def test_ground_truth_is_every_road_user_in_the_ego_frame() -> None:
    actors = [
        (1, _car(10.0, 25.0, -math.pi / 2), 0.0, -5.0),  # 20 m ahead, coming towards it
        (2, _car(6.0, 5.0, math.pi / 2, "pedestrian"), 0.0, 1.0),  # 4 m to the left
        (3, _car(10.0, 15.0, math.pi / 2, "cyclist"), 0.0, 3.0),
    ]
    objs = object_list(EGO, actors)
    assert [o.id for o in objs] == [2, 3, 1]  # nearest first (from the ego's centre)
    far = {o.id: o for o in objs}[1]
    assert (far.x, far.y) == pytest.approx((20.0, 0.0))
    assert far.heading == pytest.approx(math.pi)  # facing the ego
    assert (far.vx, far.vy) == pytest.approx((-5.0, 0.0))  # over the ground, ego axes
    assert (far.length, far.width, far.height, far.label) == (4.5, 1.9, 1.5, "car")
    walker = {o.id: o for o in objs}[2]
    assert (walker.x, walker.y, walker.label) == pytest.approx((0.0, 4.0, "person"))
    assert {o.id: o.label for o in objs}[3] == "bicycle"
    assert far.to_dict() == {
        "id": 1, "label": "car", "position": [far.x, far.y], "heading": far.heading,
        "velocity": [far.vx, far.vy], "size": [4.5, 1.9, 1.5],
    }  # fmt: skip


def _reported(noise, dist, conditions=None, n=2000, blocker=False) -> float:
    rng = np.random.default_rng(7)
    actors = [(1, _car(10.0, 5.0 + dist, 0.0), 0.0, 0.0)]
    if blocker:  # a car across the line of sight, half-way
        actors.append((2, _car(10.0, 5.0 + dist / 2, 0.0), 0.0, 0.0))
    hits = sum(
        any(o.id == 1 for o in object_list(EGO, actors, conditions=conditions, noise=noise,
                                           rng=rng))
        for _ in range(n)
    )  # fmt: skip
    return hits / n


def test_misses_grow_with_range_fog_rain_and_occlusion() -> None:
    noise = load_object_noise()
    near, far = _reported(noise, 10.0), _reported(noise, 70.0)
    assert near == pytest.approx(noise.p_max, abs=0.02)
    assert far < 0.5 * near
    fog = conditions_from_values({"fog_density": 100.0})
    assert _reported(noise, 10.0, fog) > 0.8  # T ~ 0.2: the detector still sees it
    assert _reported(noise, 30.0, fog) < 0.1  # T ~ 0.01: it does not
    rain = conditions_from_values({"precipitation": 100.0})
    assert _reported(noise, 10.0, rain) < near - 0.05
    assert _reported(noise, 20.0, blocker=True) == 0.0  # fully hidden behind a nearer car


def test_noise_is_documented_sigma_and_seeded() -> None:
    noise = ObjectNoise(p_max=1.0, range_50=1e6, fog_t50=1e-9)  # never misses
    actors = [(1, _car(10.0, 35.0, 0.0), 2.0, 0.0)]  # 30 m ahead
    draws = [object_list(EGO, actors, noise=noise, rng=np.random.default_rng(s))[0]
             for s in range(3000)]  # fmt: skip
    xs = np.array([o.x for o in draws])
    sigma = noise.pos_sigma0 + noise.pos_sigma_per_m * 30.0
    assert xs.mean() == pytest.approx(30.0, abs=0.02)
    assert xs.std() == pytest.approx(sigma, rel=0.08)
    assert np.std([o.vy for o in draws]) == pytest.approx(noise.vel_sigma, rel=0.08)
    again = object_list(EGO, actors, noise=noise, rng=np.random.default_rng(5))
    assert again == (draws[5],)


def test_the_hook_replaces_range_and_weather_but_not_occlusion() -> None:
    seen = []

    def per_class(label, distance, transmittance, conditions) -> float:
        seen.append((label, round(distance, 6), transmittance))
        return 0.0 if label == "person" else 1.0

    noise = ObjectNoise(detection_probability=per_class)
    actors = [(1, _car(10.0, 75.0), 0.0, 0.0), (2, _car(6.0, 5.0, 0.0, "pedestrian"), 0.0, 0.0)]
    objs = object_list(EGO, actors, noise=noise, rng=np.random.default_rng(0))
    assert [o.id for o in objs] == [1]  # 70 m: the hook, not the range term, decides
    assert ("car", 70.0, 1.0) in seen
    hidden = [(1, _car(10.0, 25.0), 0.0, 0.0), (2, _car(10.0, 15.0), 0.0, 0.0)]
    assert [o.id for o in object_list(EGO, hidden, noise=noise, rng=np.random.default_rng(0))] == [
        2
    ]


def test_bad_parameters_are_one_line_errors(tmp_path) -> None:
    bad = tmp_path / "noise.yaml"
    bad.write_text("p_max: 1.5\n")
    with pytest.raises(ConfigError, match=r"noise.yaml: p_max: expected a number in \[0, 1\]"):
        load_object_noise(bad)
    bad.write_text("range50: 3\n")
    with pytest.raises(ConfigError, match="noise.yaml: range50: expected .*range_50"):
        load_object_noise(bad)
    with pytest.raises(ConfigError, match="missing.yaml: expected a readable YAML file"):
        load_object_noise(tmp_path / "missing.yaml")


# --- misses in time ------------------------------------------------------------------------

FRAME = 0.1  # the object lists' step at the backends' 10 Hz sensor rate [s]


def _misses(noise, actors, n, seed=3, conditions=None, misses=None):
    """Per frame (FRAME apart), the ids NOT reported, as a boolean array per id."""
    rng = np.random.default_rng(seed)
    misses = ObjectMisses() if misses is None else misses
    ids = [a[0] for a in actors]
    out = np.zeros((n, len(ids)), dtype=bool)
    for k in range(n):
        objs = object_list(EGO, actors, conditions=conditions, noise=noise, rng=rng,
                           misses=misses, time=k * FRAME)  # fmt: skip
        seen = {o.id for o in objs}
        out[k] = [i not in seen for i in ids]
    return out


def _mean_run(miss) -> float:
    """Mean length of the runs of consecutive True values [frames]."""
    padded = np.concatenate([[False], miss, [False]]).astype(int)
    starts, ends = np.flatnonzero(np.diff(padded) == 1), np.flatnonzero(np.diff(padded) == -1)
    return float(np.mean(ends - starts))


def _both_miss(q: float, rho: float) -> float:
    """P(n_t >= c and n_t+1 >= c) for a standard bivariate normal of correlation ``rho``,
    c such that P(n >= c) = q (quadrature over the first)."""
    from statistics import NormalDist

    c = NormalDist().inv_cdf(1.0 - q)
    x = np.linspace(c, c + 12.0, 20001)
    tail = [1.0 - NormalDist().cdf((c - rho * v) / math.sqrt(1.0 - rho * rho)) for v in x]
    dens = np.exp(-0.5 * x * x) / math.sqrt(2.0 * math.pi)
    return float(np.trapezoid(dens * np.array(tail), x))


def test_correlated_misses_keep_the_rate_and_come_in_runs_as_the_ar1_predicts() -> None:
    """A car whose P(reported) is 0.7 in every frame: the long-run miss rate is 0.3 with or
    without correlation, the mean miss run is the AR(1) law's (far above the independent
    1 / (1 - q)), and so is the lag-1 autocorrelation of the miss indicator."""
    tau, p, n = 0.5, 0.7, 40000
    actors = [(1, _car(10.0, 35.0), 0.0, 0.0)]

    def flat(label, distance, transmittance, conditions) -> float:
        return p

    runs = {}
    for share in (0.0, 0.3):
        noise = ObjectNoise(detection_probability=flat, miss_tau=tau, miss_frame_share=share)
        miss = _misses(noise, actors, n)[:, 0]
        runs[share] = _mean_run(miss)
        q = 1.0 - p
        assert miss.mean() == pytest.approx(q, abs=0.02)  # ~5 standard errors of a run of runs
        rho = (1.0 - share) * math.exp(-FRAME / tau)  # lag-1 correlation of the latent
        both = _both_miss(q, rho)
        assert _mean_run(miss) == pytest.approx(q / (q - both), rel=0.08)
        lag1 = np.corrcoef(miss[:-1], miss[1:])[0, 1]
        assert lag1 == pytest.approx((both - q * q) / (q * (1.0 - q)), abs=0.04)
    independent = _misses(ObjectNoise(detection_probability=flat, miss_tau=0.0), actors, n)
    assert _mean_run(independent[:, 0]) == pytest.approx(1.0 / (1.0 - q), rel=0.05)
    assert abs(np.corrcoef(independent[:-1, 0], independent[1:, 0])[0, 1]) < 0.03
    assert runs[0.0] > 1.8 * _mean_run(independent[:, 0])  # the pure AR(1): ~2.3x
    assert runs[0.0] > runs[0.3] > 1.3 * _mean_run(independent[:, 0])


def test_independent_misses_draw_exactly_as_before() -> None:
    """``miss_tau`` 0 (and a model without it) draws one uniform per road user in range, as
    before misses were correlated: the ids reported per frame and the rng's next value
    were recorded with that version (main at 6c187bb, seed 11)."""
    actors = [
        (1, ActorView(Pose(55.0, 3.0, 0.0), 4.5, 1.9, 1.5, kind="car"), 0.0, 0.0),
        (2, ActorView(Pose(62.0, -4.0, 1.0), 0.6, 0.6, 1.8, kind="pedestrian"), 0.0, 0.0),
    ]
    ego = Pose(0.0, 0.0, 0.0)
    for noise, misses in ((ObjectNoise(), None), (ObjectNoise(miss_tau=0.0), ObjectMisses())):
        rng = np.random.default_rng(11)
        ids = []
        for k in range(40):
            objs = object_list(ego, actors, noise=noise, rng=rng, misses=misses, time=k * FRAME)
            ids.append(sum(o.id for o in objs))
        assert "".join(map(str, ids)) == "3213223211100013113003210011011120121033"
        assert sum(o.x for o in objs) == pytest.approx(117.911194, abs=1e-6)
        assert rng.random() == pytest.approx(0.4489960917456721, abs=1e-15)


def test_correlated_misses_are_seeded() -> None:
    noise = load_object_noise()  # the shipped model: the PEM's processes per class
    actors = [(1, _car(10.0, 65.0), 0.0, 0.0), (2, _car(6.0, 40.0, 0.0, "pedestrian"), 1.0, 0.0)]
    a, b = _misses(noise, actors, 300, seed=4), _misses(noise, actors, 300, seed=4)
    assert (a == b).all()
    assert a.any() and not a.all()
    assert not (a == _misses(noise, actors, 300, seed=5)).all()


def test_a_road_user_back_in_range_continues_its_process() -> None:
    """The latent spans the time away: after a gap of g seconds its correlation with the
    last value is (1 - f) exp(-g / tau) (the PEM's actors do the same), and the state of a
    road user out of range is not drawn (the others' draws do not depend on it)."""
    tau, share = 0.5, 0.25
    process = (tau, share, 0.0)
    rng = np.random.default_rng(9)
    for gap in (0.1, 0.4, 3.0):
        misses = ObjectMisses()
        first = np.array([misses.draw(i, 0.0, process, rng) for i in range(20000)])
        again = np.array([misses.draw(i, gap, process, rng) for i in range(20000)])
        assert again.std() == pytest.approx(1.0, abs=0.03)  # stationary after any gap
        r = np.corrcoef(first, again)[0, 1]
        assert r == pytest.approx((1.0 - share) * math.exp(-gap / tau), abs=0.03)
    noise = ObjectNoise(miss_tau=tau, max_range=50.0)
    near = (2, _car(10.0, 25.0), 0.0, 0.0)
    away = (1, _car(10.0, 95.0), 0.0, 0.0)  # 90 m: out of range, never drawn
    alone = _misses(noise, [near], 200)
    assert (alone[:, 0] == _misses(noise, [near, away], 200)[:, 0]).all()


def test_the_pem_gives_the_correlation_per_class() -> None:
    """``miss_tau: pem`` (the shipped file) and a PEM-driven hook take the shipped PEM's
    fitted noise_tau and frame share per class; its AR coefficient per 0.1 s frame is the
    PEM sensor's own."""
    processes = pem_miss_processes()
    assert set(processes) >= {"car", "person", "bicycle"}
    phi = PEMSensor(frame_dt=FRAME)._phi()
    assert math.exp(-FRAME / processes["car"][0]) == pytest.approx(phi, rel=1e-12)
    shipped = load_object_noise()
    assert shipped.miss_tau == "pem"
    assert shipped.miss_process("person") == processes["person"]
    hooked = ObjectNoise(detection_probability=lambda *a: 0.5)
    assert hooked.miss_process("bicycle") == processes["bicycle"]
    # by kind, whatever label the PEM's detection carries (a cyclist's: its rider's person)
    classes = load_class_params()
    cyclist, pedestrian = classes["cyclist"][1], classes["pedestrian"][1]
    assert processes["bicycle"][0] == cyclist.noise_tau
    assert processes["person"][0] == pedestrian.noise_tau != cyclist.noise_tau
    assert ObjectNoise().miss_process("car") == (0.0, 0.0, 0.0)  # no hook: as before
    assert ObjectNoise(miss_tau=0.3).miss_process("car") == (0.3, 0.0, 0.0)


def test_bad_miss_parameters_are_one_line_errors(tmp_path) -> None:
    bad = tmp_path / "noise.yaml"
    bad.write_text("miss_tau: fast\n")
    with pytest.raises(ConfigError, match=r"noise.yaml: miss_tau: expected a number >= 0"):
        load_object_noise(bad)
    bad.write_text("miss_frame_share: 1.5\n")
    with pytest.raises(ConfigError, match=r"miss_frame_share: expected a number in \[0, 1\]"):
        load_object_noise(bad)
    bad.write_text("p_max: 0.9\n")  # a file without the key: independent, as before
    assert load_object_noise(bad).miss_process("car") == (0.0, 0.0, 0.0)
    with pytest.raises(ConfigError, match="miss_tau"):
        ObjectNoise(miss_tau=-1.0)
