"""The perception error model: properties of the model and of its fitting, not of one fit.

Every property is checked for the shipped ``pem.yaml`` AND for random parameter sets with
the signs docs/pem.md documents (``PARAM_SETS``): the score grows with apparent size and
falls with truncation, fog, darkness, rain and distance from the image centre; the other
terms (view, facing, box shape, colour) may take either sign. Coefficients of one fit are
never pinned: docs/pem.md says they are not stable between fits. ``sitcov calibrate``'s
fitting is checked by recovering known parameters from synthetic detector frames.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from scipy.special import ndtr

from sitcov.errors import ConfigError
from sitcov.perception import (
    PEM_PARAMS_FILE,
    ActorView,
    PEMFeatures,
    PEMParams,
    PEMSensor,
    Pose,
    load_pem_params,
    pem_logit,
    pem_score,
)
from sitcov.perception._pem import CUT_TENT_PX, NormalStream, pass_probability
from sitcov.sim import Conditions, conditions_from_values

EGO = Pose(0.0, 0.0, 0.0)
#: Terms added to the PEM after the shipped ``pem.yaml`` was fitted (their defaults there,
#: no term): the box's mean edge offsets and vertical corner noise, fitted for cyclists
#: only (docs/pem.md, "The cyclist's detection is its rider").
NOT_IN_SHIPPED_FIT: tuple[str, ...] = (
    "box_dx0", "box_dy0", "box_dx1", "box_dy1", "jitter_y",
    "noise_outlier_share", "noise_outlier_ratio", "noise_up_size_gain", "cut_gain",
    "noise_bend_gain", "noise_bend_px",
)  # fmt: skip
CLEAR = conditions_from_values({})
N_RANDOM_SETS = 8


def car(x: float, y: float = 0.0, yaw: float = 0.0) -> ActorView:
    return ActorView(Pose(x, y, yaw), 4.7, 1.85, 1.5)


def _size_slope_positive(p: PEMParams) -> bool:
    """d logit / d ln(height) > 0 over [size_min_px, size_max_px] for every view angle."""
    ends = (math.log(p.size_min_px / p.size_ref_px), math.log(p.size_max_px / p.size_ref_px))
    return all(
        p.size_gain + 2.0 * p.size2_gain * lg + p.side_size_gain * side > 0.05
        for lg in ends
        for side in (0.0, 1.0)
    )


def random_params(rng: np.random.Generator) -> PEMParams:
    """Shipped parameters with every documented coefficient redrawn (documented signs).

    Fields added later (e.g. a colour term) keep their shipped values.
    """
    u = rng.uniform
    while True:
        p = replace(
            load_pem_params(),
            bias=u(-2.0, 2.0),
            size_gain=u(0.3, 3.0),
            size2_gain=u(-0.15, 0.3),
            side_size_gain=u(-0.2, 0.2),
            size_min_px=u(4.0, 15.0),
            size_max_px=u(60.0, 300.0),
            view_gain=u(-1.0, 1.0),
            view2_gain=u(-0.5, 0.5),
            facing_gain=u(-0.5, 0.5),
            facing2_gain=u(-0.5, 0.5),
            aspect_gain=u(-0.5, 0.5),
            trunc_gain=u(0.0, 4.0),
            edge_gain=u(0.0, 1.0),
            fog_gain=u(0.0, 3.0),
            illum_gain=u(0.0, 2.0),
            rain_gain=u(0.0, 3.0),
            noise_sigma=u(0.1, 1.5),
            rain_sigma=u(0.0, 1.0),
            rain_miss=u(0.0, 0.5),
            jitter=u(0.0, 0.08),
            rain_jitter=u(0.0, 0.08),
            noise_run_share=u(0.0, 1.0),
            noise_tau=float(rng.choice([0.0, 0.2, 1.0])),
        )
        # the size term's bends: steeper above 40 px, flatter again above 80 px, the
        # net slope above 80 px not negative (the documented shape)
        bend = u(0.0, 1.5)
        p = replace(p, size_hinge40_gain=bend, size_hinge80_gain=-bend * u(0.0, 1.0))
        if _size_slope_positive(p):
            return p


PARAM_SETS = {"shipped": load_pem_params()} | {
    f"random{k}": random_params(np.random.default_rng([7, k])) for k in range(N_RANDOM_SETS)
}
params_ids = pytest.mark.parametrize("name", sorted(PARAM_SETS))


def random_features(rng: np.random.Generator, n: int) -> list[PEMFeatures]:
    """Features spread over everything a frame can show (keywords: new fields keep defaults)."""
    out = []
    for _ in range(n):
        h = math.exp(rng.uniform(math.log(6.0), math.log(300.0)))
        out.append(
            PEMFeatures(
                height_px=h,
                view_angle=rng.uniform(0.0, math.pi / 2),
                truncation=rng.uniform(0.0, 0.8) if rng.random() < 0.3 else 0.0,
                transmittance=rng.uniform(0.02, 1.0),
                illumination=rng.uniform(0.2, 1.0),
                rain_noise=rng.uniform(0.0, 1.0),
                width_px=h * math.exp(rng.uniform(math.log(0.6), math.log(3.0))),
                offset=rng.uniform(0.0, 1.0),
                facing=rng.uniform(-1.0, 1.0),
            )
        )
    return out


def nondecreasing(values: list[float]) -> bool:
    return all(b >= a - 1e-12 for a, b in zip(values, values[1:], strict=False))


def nonincreasing(values: list[float]) -> bool:
    return nondecreasing([-v for v in values])


def mean_score(sensor, actor, conditions, n=400, seed=1):
    """Mean logit-free score over ``n`` frames, counting misses as 0, and the hit rate."""
    rng = np.random.default_rng(seed)
    scores = []
    for _ in range(n):
        dets = sensor.detect(EGO, (actor,), conditions, rng)
        scores.append(dets[0].score if dets else 0.0)
    hits = sum(s > 0 for s in scores)
    return sum(scores) / n, hits / n, np.std([s for s in scores if s > 0] or [0.0])


def feats(sensor, actor, conditions=CLEAR):
    f = sensor.features(EGO, actor, conditions)
    assert f is not None
    return f


@params_ids
def test_score_grows_with_apparent_size(name):
    """The same box shape, scaled up: the score never drops, up to the height where a
    negative ``size2_gain`` turns the size curve over (the fitted detector's scores fall
    for cars that fill the image, docs/pem.md)."""
    p = PARAM_SETS[name]
    for f in random_features(np.random.default_rng(1), 200):
        slope = p.size_gain + p.side_size_gain * math.sin(f.view_angle)
        if p.size2_gain < 0 and 2.0 * f.height_px > p.size_ref_px * math.exp(
            -slope / (2.0 * p.size2_gain)
        ):
            continue
        if p.size_hinge40_gain + p.size_hinge80_gain < 0 and 2.0 * f.height_px > 80.0:
            continue  # the bends turn it over above 80 px (the shipped car: -0.17 per e-fold)
        if p.cut_tent_gain > 0.0 and f.truncation > 0.0 and 2.0 * f.height_px > CUT_TENT_PX:
            continue  # a cut box's tent falls past its peak (docs/pem.md, "The mid-size cut car")
        scaled = [
            pem_score(f._replace(height_px=f.height_px * k, width_px=f.width_px * k), p)
            for k in (0.5, 0.8, 1.0, 1.3, 2.0)
        ]
        assert nondecreasing(scaled), f


@params_ids
@pytest.mark.parametrize("yaw", [0.0, math.pi / 2, math.pi / 4, math.pi])
def test_score_falls_with_distance_straight_ahead(name, yaw):
    sensor = PEMSensor(PARAM_SETS[name])
    features = [sensor.features(EGO, car(d, 0.0, yaw), CLEAR) for d in (10, 15, 25, 40, 60, 90)]
    # where it can be detected at all (smaller boxes are dropped before scoring)
    seen = [f for f in features if f is not None and f.height_px >= sensor.params.size_min_px]
    scores = [pem_score(f, sensor.params) for f in seen]
    assert len(scores) >= 3 and nonincreasing(scores)


@params_ids
@pytest.mark.parametrize(
    ("element", "values"),
    [
        ("fog_density", (0, 20, 50, 100)),
        ("cloudiness", (0, 40, 80, 100)),
        ("precipitation", (0, 30, 60, 100)),
        ("wetness", (0, 50, 100)),
    ],
)
def test_fog_darkness_and_rain_never_raise_the_score(name, element, values):
    """Fog, rain and wetness never raise the score. Cloud is not darkness under the
    camera's auto-exposure (docs/weather.md): the refit on the current renderer's frames
    gives ``illum_gain`` about 0 (-0.03 for cars), so cloud may move the score by less
    than 0.02 either way, never more."""
    sensor = PEMSensor(PARAM_SETS[name])
    for actor in (car(12.0, 1.0, math.pi / 2), car(35.0, -4.0, 0.3), car(60.0)):
        scores = [
            pem_score(
                sensor.features(EGO, actor, conditions_from_values({element: v})), sensor.params
            )
            for v in values
        ]
        if element == "cloudiness" and sensor.params.illum_gain < 0.0:
            assert max(scores) - min(scores) < 0.02, (element, scores)
            continue
        assert nonincreasing(scores), (element, scores)


@params_ids
def test_fog_hurts_less_when_it_starts_further_away(name):
    sensor = PEMSensor(PARAM_SETS[name])
    scores = [
        pem_score(
            sensor.features(
                EGO, car(40.0), conditions_from_values({"fog_density": 60, "fog_distance": fd})
            ),
            sensor.params,
        )
        for fd in (0, 10, 25, 40)
    ]
    assert nondecreasing(scores)


@params_ids
def test_truncation_and_off_centre_never_raise_the_score(name):
    """Cut by the image edge or off the image centre, a box scores no higher, but for the
    car's cut tent (``cut_tent_gain``: a box of 110-440 px cut by the edge scores higher,
    as the detector's do; docs/pem.md, "The mid-size cut car"): without it no higher;
    with it higher by at most its gain on the logit, only inside the tent, and past the
    cut ramp (0.3 -> 0.7) never higher. A fitted ``edge_gain`` a hair below 0 (the car
    fitted with its side-on bend: -0.005, no measurable off-centre effect, docs/pem.md)
    may raise it by less than 0.01."""
    p = PARAM_SETS[name]
    flat = replace(p, cut_tent_gain=0.0)
    cuts = (0.0, 0.3, 0.7)
    for f in random_features(np.random.default_rng(2), 200):
        assert nonincreasing([pem_score(f._replace(truncation=t), flat) for t in cuts])
        z = [pem_logit(f._replace(truncation=t), p) for t in cuts]
        assert z[2] <= z[1] and z[1] - z[0] <= max(0.0, p.cut_tent_gain) + 1e-12
        if not CUT_TENT_PX / 2 < f.height_px < 2 * CUT_TENT_PX:
            assert nonincreasing(z)
        off = [pem_score(f._replace(offset=o), p) for o in (0.0, 0.4, 1.0)]
        if p.edge_gain < 0.0:
            assert p.edge_gain > -0.04 and max(off) - off[0] < 0.01, (p.edge_gain, off)
        else:
            assert nonincreasing(off)


@params_ids
def test_left_right_mirror_images_are_detected_alike(name):
    """A car at (x, y, yaw) and its mirror image (x, -y, -yaw): the same features but the
    side's sign, and with the same rng (and no side gain) the same detections at mirrored
    boxes' scores."""
    sensor = PEMSensor(PARAM_SETS[name])
    rng = np.random.default_rng(3)
    cond = conditions_from_values({"fog_density": 30, "precipitation": 40})
    for _ in range(50):
        x, y, yaw = rng.uniform(5, 60), rng.uniform(-15, 15), rng.uniform(-math.pi, math.pi)
        a, b = car(x, y, yaw), car(x, -y, -yaw)
        fa, fb = sensor.features(EGO, a, cond), sensor.features(EGO, b, cond)
        assert (fa is None) == (fb is None)
        if fa is None:
            continue
        assert fa == pytest.approx(fb._replace(side=-fb.side), abs=1e-9)
        seed = int(rng.integers(1 << 30))
        da = sensor.detect(EGO, (a,), cond, np.random.default_rng(seed))
        db = sensor.detect(EGO, (b,), cond, np.random.default_rng(seed))
        assert [d.score for d in da] == pytest.approx([d.score for d in db], abs=1e-9)


def test_side_is_the_signed_sine_of_the_heading_and_only_side_gain_reads_it():
    """``side``: a car crossing from the ego's left (moving left to right in the image, its
    right side seen) has ``side`` < 0, its mirror image from the right the opposite value;
    side-on it is -1 / +1, end-on 0. Old rows (14 features) read as ``side`` 0. With
    ``side_gain`` g the mirror images' logits differ by exactly ``2 g |side|``; with 0
    (shipped) not at all."""
    sensor = PEMSensor()
    cond = conditions_from_values({})
    left = sensor.features(EGO, car(15.0, 5.0, -math.pi / 2), cond)
    right = sensor.features(EGO, car(15.0, -5.0, math.pi / 2), cond)
    assert left is not None and right is not None
    assert -1.0 < left.side < -0.8 and right.side == pytest.approx(-left.side, abs=1e-12)
    cam_x = sensor.camera.mount_x
    side_on = sensor.features(EGO, car(cam_x + 20.0, 0.0, -math.pi / 2), cond)
    end_on = sensor.features(EGO, car(cam_x + 20.0, 0.0, 0.0), cond)
    assert side_on.side == pytest.approx(-1.0) and end_on.side == pytest.approx(0.0, abs=1e-12)
    assert PEMFeatures(*tuple(left)[:14]).side == 0.0
    shipped = load_pem_params()
    assert shipped.side_gain == 0.0
    assert pem_logit(left, shipped) == pem_logit(left._replace(side=-left.side), shipped)
    assert pem_logit(left, shipped) == pytest.approx(pem_logit(right, shipped), abs=1e-12)
    g = replace(shipped, side_gain=0.6)
    diff = pem_logit(right, g) - pem_logit(left, g)
    assert diff == pytest.approx(2 * 0.6 * right.side, abs=1e-9)
    assert pem_logit(left, g) == pytest.approx(pem_logit(left, shipped) + 0.6 * left.side)


@params_ids
def test_noise_is_deterministic_per_rng_and_reset_between_runs(name):
    """Each run's detections depend only on its rng: a sensor reused across runs, in any
    order and after any other run, gives every run the same detections."""
    sensor = PEMSensor(PARAM_SETS[name])
    actors = (car(10.0, 4.0, math.pi / 2), car(30.0, -3.0, 0.0), car(6.0, 6.5, 2.0))
    cond = conditions_from_values({"precipitation": 60, "fog_density": 40})

    def run(seed: int) -> list:
        rng = np.random.default_rng(seed)
        return [sensor.detect(EGO, actors, cond, rng) for _ in range(30)]

    first = {seed: run(seed) for seed in (1, 2, 3)}
    assert {seed: run(seed) for seed in (3, 1, 2)} == first
    assert (
        PEMSensor(PARAM_SETS[name]).detect(EGO, actors, cond, np.random.default_rng(2))
        == (first[2][0])
    )
    if any(first[1]) or any(first[2]):
        assert first[1] != first[2]  # the rng matters


@params_ids
def test_prepared_actors_give_detects_detections(name):
    """``prepare_parts`` once per run and ``detect_prepared`` with bare poses (what the
    embedded backend does) give ``detect``'s detections draw for draw: cars, a pedestrian
    and a cyclist (its rider and its bicycle) in rain and fog, an actor leaving the list
    mid-run (the keys shift)."""
    params = replace(PARAM_SETS[name], rain_miss=0.3, rain_jitter=0.05)
    cond = conditions_from_values({"precipitation": 70, "fog_density": 30})
    plain, prepared = PEMSensor(params), PEMSensor(params)
    rng_a, rng_b = np.random.default_rng(5), np.random.default_rng(5)
    kinds = ("car", "pedestrian", "cyclist", "car")
    sizes = ((4.7, 1.85, 1.5), (0.5, 0.5, 1.75), (1.8, 0.6, 1.7), (4.2, 1.8, 1.4))
    looks = [
        prepared.prepare_parts(ActorView(EGO, *size, kind=kind, color=(20 * i, 90, 200)), cond)
        for i, (kind, size) in enumerate(zip(kinds, sizes, strict=True))
    ]
    assert [len(parts) for parts in looks] == [1, 1, 2, 1]
    detections = 0
    for frame in range(60):
        ego = Pose(0.3 * frame, 0.01 * frame, 0.002 * frame)
        poses = [Pose(4.0 + 0.5 * frame + 6.0 * i, 3.0 - 2.0 * i, 0.4 * i) for i in range(4)]
        keep = range(4) if frame < 30 else (0, 2, 3)
        actors = tuple(
            ActorView(poses[i], *sizes[i], kind=kinds[i], color=(20 * i, 90, 200)) for i in keep
        )
        want = plain.detect(ego, actors, cond, rng_a)
        got = prepared.detect_prepared(
            ego.x,
            ego.y,
            ego.yaw,
            [(look, poses[i]) for i in keep for look in looks[i]],
            cond,
            rng_b,
        )
        assert got == want, frame
        detections += len(want)
    assert detections > 20
    assert rng_a.standard_normal() == rng_b.standard_normal()  # the same draws were made


@params_ids
def test_frame_detector_gives_detect_prepareds_detections(name):
    """The run-bound ``frame_detector`` gives ``detect_prepared``'s detections draw for
    draw (cars, a pedestrian and a cyclist, an actor leaving the list mid-run, a ``reset``
    mid-run), calling ``detect_prepared`` itself only to set the run up (its first frame,
    after the reset) when the compiled frame serves the scene (dry, or no class's rain
    miss), else through ``detect_prepared`` every frame."""
    for rain in (0, 40):
        _check_frame_detector(name, rain)


def _check_frame_detector(name, rain):
    """One scene of :func:`test_frame_detector_gives_detect_prepareds_detections`."""
    from sitcov.perception import _pem

    params = replace(PARAM_SETS[name], rain_jitter=0.05)
    cond = conditions_from_values({"precipitation": rain, "fog_density": 30})
    plain, bound = PEMSensor(params), PEMSensor(params)
    kinds = ("car", "pedestrian", "cyclist", "car")
    sizes = ((4.7, 1.85, 1.5), (0.5, 0.5, 1.75), (1.8, 0.6, 1.7), (4.2, 1.8, 1.4))

    def looks(sensor):  # per road user its detections' looks (a cyclist: two)
        return [
            sensor.prepare_parts(ActorView(EGO, *size, kind=kind, color=(20 * i, 90, 200)), cond)
            for i, (kind, size) in enumerate(zip(kinds, sizes, strict=True))
        ]

    looks_a, looks_b = looks(plain), looks(bound)
    normals_a = NormalStream(np.random.default_rng(5), 128)
    normals_b = NormalStream(np.random.default_rng(5), 128)
    calls = []
    detect_prepared = bound.detect_prepared
    bound.detect_prepared = lambda *args: calls.append(1) or detect_prepared(*args)
    detect = bound.frame_detector(cond, normals_b)
    detections = 0
    for frame in range(80):
        if frame == 50:
            plain.reset(frame_dt=0.1)
            bound.reset(frame_dt=0.1)
        ego = Pose(0.3 * frame, 0.01 * frame, 0.002 * frame)
        poses = [Pose(4.0 + 0.5 * frame + 6.0 * i, 3.0 - 2.0 * i, 0.4 * i) for i in range(4)]
        keep = range(4) if frame < 30 else (0, 2, 3)
        seen_a = [(look, poses[i]) for i in keep for look in looks_a[i]]
        seen_b = [(look, poses[i]) for i in keep for look in looks_b[i]]
        want = plain.detect_prepared(ego.x, ego.y, ego.yaw, seen_a, cond, normals_a)
        got = detect(ego.x, ego.y, ego.yaw, seen_b)
        assert got == want, frame
        detections += len(want)
    assert detections > 20
    assert normals_a.take(3) == normals_b.take(3)  # the same draws were made
    if _pem._FRAME_FN and bound._fstate[4]:  # the compiled frame serves the scene: the
        # bound loop served all frames but two
        assert len(calls) == 2
    else:
        assert len(calls) == 80


@pytest.mark.parametrize("block", [0, 1, 4, 7, 128])
def test_normal_streams_give_the_generators_own_sequence(block):
    """A ``NormalStream`` hands out exactly the normals the generator would have drawn
    call by call, whatever its block; without a block it leaves the generator where the
    direct draws would (so ``detect`` draws exactly what it uses)."""
    sizes = np.random.default_rng(3).choice([2, 3, 4], 200)
    direct, ahead = np.random.default_rng(21), np.random.default_rng(21)
    stream = NormalStream(ahead, block)
    for n in sizes:
        assert stream.take(int(n)) == direct.standard_normal(int(n)).tolist()
    if block == 0:
        assert ahead.standard_normal() == direct.standard_normal()


@params_ids
def test_detections_are_valid(name):
    sensor = PEMSensor(PARAM_SETS[name])
    cond = conditions_from_values({"precipitation": 60, "fog_density": 40})
    actors = (car(10.0, 4.0, math.pi / 2), car(30.0, -3.0, 0.0), car(6.0, 6.5, 2.0))
    rng = np.random.default_rng(9)
    w, h = sensor.camera.width, sensor.camera.height
    for _ in range(200):
        for d in sensor.detect(EGO, actors, cond, rng):
            x0, y0, x1, y1 = d.box
            assert 0.0 <= x0 < x1 <= w and 0.0 <= y0 < y1 <= h
            assert sensor.params.floor <= d.score <= 1.0 and d.label == "car"
    assert sensor.detect(EGO, (car(-20.0),), CLEAR, rng) == ()  # behind
    assert sensor.detect(EGO, (car(3.0, 20.0),), CLEAR, rng) == ()  # 80 deg to the left
    assert sensor.detect(EGO, (car(400.0),), CLEAR, rng) == ()  # a few pixels tall


#: Frames per probability check. A frequency of n = 1500 independent frames has a standard
#: error <= sqrt(0.25 / 1500) = 0.0129; the tolerance 0.06 is 4.65 of them, so a correct
#: sampler fails a check with probability < 3.3e-6 (normal approximation, two-sided), while
#: a sampler off by 0.12 (twice the tolerance) passes with probability < 3.3e-6 too.
N_FRAMES, TOLERANCE = 1500, 0.06


def _sampled_rate(
    sensor: PEMSensor, actor: ActorView, theta: float, rng, conditions: Conditions = CLEAR
) -> float:
    """The share of :data:`N_FRAMES` independent frames (a fresh noise track each) in
    which ``sensor`` reports ``actor`` with a score >= ``theta`` (in ``conditions``)."""
    hits = sum(
        any(d.score >= theta for d in sensor.detect(
            EGO, (actor,), conditions, np.random.default_rng(rng.integers(1 << 62))))
        for _ in range(N_FRAMES)
    )  # fmt: skip
    return hits / N_FRAMES


@params_ids
def test_sampled_frames_reach_the_aeb_threshold_as_often_as_the_model_says(name):
    """P(score >= 0.5) in dry weather as the frame model says (``pass_probability``: the
    detection term times the split-normal tail; Phi(z / sigma) for a normal law)."""
    from sitcov.calibration._frame_check import pass_probability

    sensor = PEMSensor(PARAM_SETS[name])
    rng = np.random.default_rng(11)
    for actor in (car(12.0, 1.0, math.pi / 2), car(25.0, -3.0, 0.2)):
        f = sensor.features(EGO, actor, CLEAR)
        if f.height_px < sensor.params.size_min_px:
            continue
        expected = pass_probability(sensor.params, f, 0.5)  # detection term, split normal
        hits = 0
        for _ in range(N_FRAMES):
            # a fresh rng per frame starts a fresh noise track: independent frames
            dets = sensor.detect(EGO, (actor,), CLEAR, np.random.default_rng(rng.integers(1 << 62)))
            hits += any(d.score >= 0.5 for d in dets)
        assert hits / N_FRAMES == pytest.approx(expected, abs=TOLERANCE)


def test_outlier_frames_and_the_upper_size_gain_are_sampled_as_the_model_says():
    """``noise_outlier_share``/``_ratio`` (a share of frames with a wide noise of their
    own) and ``noise_up_size_gain`` (the upper scale's own size gain): sampled frames of
    a close and a far car reach θ = 0.5 and 0.7 as often as ``pass_probability`` says;
    the outlier frames lower P(score >= 0.5) of a car whose noise-free score is above
    it, a negative upper gain lowers the close car's P(score >= θ) for a θ above its
    noise-free score, and a share of 0
    is the model without them. The upper gain without the noise's own is refused."""
    base = {"bias": 1.0, "noise_sigma": 0.5, "noise_tau": 0.0, "noise_frame_share": 0.0,
            "noise_run_share": 0.0, "noise_up_ratio": 0.8, "rain_miss": 0.0,
            "detect_bias": 8.0, "detect_gain": 0.0, "detect_ar": 0.0,
            "noise_size_gain": 0.3}  # fmt: skip
    plain = PEMSensor(base)
    wide = PEMSensor({**base, "noise_outlier_share": 0.2, "noise_outlier_ratio": 4.0})
    capped = PEMSensor({**base, "noise_up_size_gain": -0.6})
    near, far = car(8.0, 0.0, math.pi / 2), car(25.0, -2.0, 0.3)
    rng = np.random.default_rng(17)
    for actor in (near, far):
        f = plain.features(EGO, actor, CLEAR)
        for sensor in (plain, wide, capped):
            for theta in (0.5, 0.7):
                expected = pass_probability(f, sensor.params, theta)
                rate = _sampled_rate(sensor, actor, theta, rng)
                assert rate == pytest.approx(expected, abs=TOLERANCE)
    f_near = plain.features(EGO, near, CLEAR)
    assert pem_logit(f_near, plain.params) > 0.5  # noise-free score above 0.62
    assert pass_probability(f_near, wide.params, 0.5) < pass_probability(f_near, plain.params, 0.5)
    z = pem_logit(f_near, plain.params)  # a threshold above it: the upper spread decides
    above = 1.0 / (1.0 + math.exp(-(z + 0.4)))
    assert pass_probability(f_near, capped.params, above) < pass_probability(
        f_near, plain.params, above
    )
    zero = PEMSensor({**base, "noise_outlier_share": 0.0, "noise_outlier_ratio": 4.0})
    assert pass_probability(f_near, zero.params, 0.5) == pass_probability(f_near, plain.params, 0.5)
    with pytest.raises(ConfigError, match="noise_up_size_gain"):
        PEMParams.from_mapping({"noise_size_gain": 0.0, "noise_up_size_gain": -0.3})
    with pytest.raises(ConfigError, match="noise_outlier_share"):
        PEMParams.from_mapping({"noise_outlier_share": 1.5})


def test_the_upper_spread_in_windy_rain_is_sampled_as_the_model_says():
    """``noise_up_rain_wind_gain``/``_px``: in windy rain, sampled frames of a close car
    (box above the knot) and a far one reach θ = 0.5 and 0.7 as often as
    ``pass_probability`` says; the wind raises the close car's P(score >= θ) for a θ above
    its noise-free score and leaves the far car's and the calm rain's as they were; a
    gain of 0 is the model without it; a knot of 0 px is refused."""
    base = {"bias": 1.0, "noise_sigma": 0.5, "noise_tau": 0.0, "noise_frame_share": 0.0,
            "noise_run_share": 0.0, "noise_up_ratio": 0.8, "rain_miss": 0.0,
            "rain_sigma": 0.0, "detect_bias": 8.0, "detect_gain": 0.0, "detect_ar": 0.0,
            "noise_size_gain": 0.0, "noise_low_tail": 0.0, "noise_outlier_share": 0.0,
            "noise_up_size_gain": 0.0, "noise_up_rain_wind_gain": 0.0,
            "noise_up_rain_wind_px": 50.0}  # fmt: skip
    plain = PEMSensor(base)  # (the shipped car PEM has a gain of its own)
    windy_pem = PEMSensor({**base, "noise_up_rain_wind_gain": 0.8})
    windy = conditions_from_values({"precipitation": 80, "wind_intensity": 80})
    calm = conditions_from_values({"precipitation": 80, "wind_intensity": 0})
    assert windy.rain_wind == pytest.approx(0.64) and calm.rain_wind == 0.0
    near, far = car(6.0, 0.0, math.pi / 2), car(25.0, -2.0, 0.3)
    f_near, f_far = (windy_pem.features(EGO, a, windy) for a in (near, far))
    assert f_near.height_px >= 50.0 > f_far.height_px
    assert f_near.rain_wind == pytest.approx(0.64)
    rng = np.random.default_rng(23)
    for actor, f in ((near, f_near), (far, f_far)):
        for theta in (0.5, 0.7):
            expected = pass_probability(f, windy_pem.params, theta)
            rate = _sampled_rate(windy_pem, actor, theta, rng, windy)
            assert rate == pytest.approx(expected, abs=TOLERANCE)
    z = pem_logit(f_near, plain.params)
    above = 1.0 / (1.0 + math.exp(-(z + 0.5)))  # the upper spread decides
    assert (
        pass_probability(f_near, windy_pem.params, above)
        > pass_probability(f_near, plain.params, above) + 0.05
    )
    f_calm = windy_pem.features(EGO, near, calm)
    assert pass_probability(f_calm, windy_pem.params, above) == pass_probability(
        f_calm, plain.params, above
    )
    assert pass_probability(f_far, windy_pem.params, 0.7) == pass_probability(
        f_far, plain.params, 0.7
    )
    with pytest.raises(ConfigError, match="noise_up_rain_wind_px"):
        PEMParams.from_mapping({"noise_up_rain_wind_px": 0.0})


def test_the_lower_tail_is_sampled_as_the_model_says():
    """``noise_low_tail``: sampled frames of a close and a far car reach θ = 0.3 and 0.5
    as often as ``pass_probability`` says; the tail lowers P(score >= θ) for a θ more than
    one scale below the noise-free score and leaves it for a θ above it; 0 is the model
    without it, and a negative curvature is refused."""
    # one scale at every size; a frame share: P(score >= θ) smooth in θ (40 nodes)
    base = {"bias": 1.0, "noise_sigma": 0.5, "noise_tau": 0.0, "noise_frame_share": 0.3,
            "noise_run_share": 0.0, "noise_up_ratio": 0.8, "rain_miss": 0.0,
            "detect_bias": 8.0, "detect_gain": 0.0, "detect_ar": 0.0,
            "noise_size_gain": 0.0, "noise_low_tail": 0.0}  # fmt: skip
    plain = PEMSensor(base)  # (the shipped car PEM has a tail of its own)
    tail = PEMSensor({**base, "noise_low_tail": 0.5})
    near, far = car(8.0, 0.0, math.pi / 2), car(25.0, -2.0, 0.3)
    rng = np.random.default_rng(19)
    for actor in (near, far):
        f = tail.features(EGO, actor, CLEAR)
        for theta in (0.3, 0.5):
            expected = pass_probability(f, tail.params, theta)
            assert _sampled_rate(tail, actor, theta, rng) == pytest.approx(expected, abs=TOLERANCE)
    f_near = plain.features(EGO, near, CLEAR)
    z = pem_logit(f_near, plain.params)
    deep = 1.0 / (1.0 + math.exp(-(z - 1.5 * 0.5)))  # 1.5 scales below the mean
    above = 1.0 / (1.0 + math.exp(-(z + 0.2)))
    assert (
        pass_probability(f_near, tail.params, deep)
        < pass_probability(f_near, plain.params, deep) - 0.01
    )
    assert pass_probability(f_near, tail.params, above) == pass_probability(
        f_near, plain.params, above
    )
    zero = PEMSensor({**base, "noise_low_tail": 0.0})
    assert pass_probability(f_near, zero.params, deep) == pass_probability(
        f_near, plain.params, deep
    )
    with pytest.raises(ConfigError, match="noise_low_tail"):
        PEMParams.from_mapping({"noise_low_tail": -0.2})


def test_the_score_ceiling_is_sampled_as_the_model_says():
    """The score's ceiling (``noise_ceiling_*``): sampled frames of a close and a far car
    reach θ as often as ``pass_probability`` says; past the knee (its documented formula)
    a θ is reached less often than without the ceiling, below it as often; a smaller box
    has a lower ceiling; slope 1 is no ceiling (the same numbers), and a slope outside
    (0, 1] is refused."""
    from sitcov.perception._pem import ceiling, ceiling_inverse, ceiling_knee

    base = {
        "bias": 1.0,
        "noise_sigma": 0.6,
        "noise_tau": 0.0,
        "noise_frame_share": 0.3,
        "noise_run_share": 0.0,
        "noise_up_ratio": 1.0,
        "rain_miss": 0.0,
        "detect_bias": 8.0,
        "detect_gain": 0.0,
        "detect_ar": 0.0,
        "noise_size_gain": 0.0,
        "noise_low_tail": 0.0,
        "noise_ceiling_slope": 1.0,
    }  # fmt: skip  (the shipped car PEM has a ceiling)
    plain = PEMSensor(base)
    ceil = PEMSensor({**base, "noise_ceiling_logit": 2.0, "noise_ceiling_size_gain": 0.5,
                      "noise_ceiling_slope": 0.4})  # fmt: skip
    near, far = car(6.0, 0.0, math.pi / 2), car(25.0, -2.0, 0.3)
    rng = np.random.default_rng(23)
    for actor in (near, far):
        f = ceil.features(EGO, actor, CLEAR)
        for theta in (0.6, 0.7):
            expected = pass_probability(f, ceil.params, theta)
            assert _sampled_rate(ceil, actor, theta, rng) == pytest.approx(expected, abs=TOLERANCE)
    p = ceil.params
    for actor in (near, far):
        f = ceil.features(EGO, actor, CLEAR)
        z = pem_logit(f, p)
        h = min(max(f.height_px, 1.0), p.noise_size_max_px)
        knee = max(2.0 + 0.5 * math.log(h / p.size_ref_px) - z, 0.0)
        assert ceiling_knee(z, f.height_px, 2.0, 0.5, p.size_ref_px, p.noise_size_max_px) == knee
        below, past = z + 0.5 * knee, z + knee + 0.8

        def score(v: float) -> float:
            return 1.0 / (1.0 + math.exp(-v))

        assert pass_probability(f, p, score(below)) == pytest.approx(
            pass_probability(f, plain.params, score(below)), abs=1e-9
        )
        assert (
            pass_probability(f, p, score(past))
            < pass_probability(f, plain.params, score(past)) - 0.005
        )
    assert {
        ceiling_knee(pem_logit(ceil.features(EGO, a, CLEAR), p), ceil.features(EGO, a, CLEAR)
                     .height_px, 2.0, 0.5, p.size_ref_px, p.noise_size_max_px) > 0.0
        for a in (near, far)
    } == {True, False}  # the far car's mean is past its ceiling, the close one's below  # fmt: skip
    knees = [ceiling_knee(0.0, h, -0.3, 0.5, 25.0, 450.0) for h in (40.0, 80.0, 200.0)]
    assert knees == sorted(knees) and knees[0] < knees[-1]  # it rises with the box
    assert ceiling(1.5, 1.0, 0.4) == pytest.approx(1.2) and ceiling(0.5, 1.0, 0.4) == 0.5
    assert ceiling_inverse(ceiling(2.3, 0.7, 0.4), 0.7, 0.4) == pytest.approx(2.3)
    off = PEMSensor({**base, "noise_ceiling_logit": -0.3, "noise_ceiling_size_gain": 0.5,
                     "noise_ceiling_slope": 1.0})  # fmt: skip
    f = off.features(EGO, near, CLEAR)
    assert pass_probability(f, off.params, 0.7) == pass_probability(f, plain.params, 0.7)
    for slope in (0.0, 1.2):
        with pytest.raises(ConfigError, match="noise_ceiling_slope"):
            PEMParams.from_mapping({"noise_ceiling_slope": slope})


def test_rain_noise_and_misses_when_the_model_has_them():
    # The calibrated detector shows no extra noise or misses in rain (rain_sigma and
    # rain_miss fit to ~0); the model form still supports them, which this checks.
    s = PEMSensor({"bias": 2.0, "noise_sigma": 0.3, "rain_sigma": 1.5, "rain_miss": 0.3,
                   "rain_gain": 0.0, "noise_tau": 0.0, "noise_run_share": 0.0,
                   "noise_frame_share": 0.0, "noise_up_ratio": 1.0, "detect_bias": 8.0,
                   "detect_gain": 0.0, "detect_ar": 0.0})  # fmt: skip
    actor = car(12.0, 2.0, math.pi / 2)  # close: almost always detected when dry
    _, dry_hits, dry_sd = mean_score(s, actor, CLEAR, n=600)
    wet = conditions_from_values(
        {"precipitation": 100, "precipitation_deposits": 100, "wetness": 100}
    )
    _, wet_hits, wet_sd = mean_score(s, actor, wet, n=600)
    assert dry_hits > 0.9
    assert wet_hits < dry_hits - 0.1
    assert wet_sd > 1.5 * dry_sd


def test_box_jitter_grows_with_rain():
    s = PEMSensor(
        params={
            "rain_miss": 0.0,
            "floor": 0.0,
            "jitter": 0.03,
            "rain_jitter": 0.05,
            "detect_bias": 8.0,
            "detect_gain": 0.0,
            "detect_ar": 0.0,
        }
    )
    actor = car(15.0, 0.0, 0.0)

    def width_sd(cond):
        rng = np.random.default_rng(3)
        widths = [s.detect(EGO, (actor,), cond, rng)[0].box for _ in range(300)]
        return np.std([b[2] - b[0] for b in widths])

    assert width_sd(Conditions(rain_noise=1.0)) > 1.5 * width_sd(Conditions())


def _boxes(params: dict, actor: ActorView, n: int = 200, python: bool = False, monkeypatch=None):
    """The boxes of ``n`` frames of ``actor`` (always detected), and its true box."""
    from sitcov.perception._camera import project_box

    base = {"rain_miss": 0.0, "floor": 0.0, "detect_bias": 8.0, "detect_gain": 0.0}
    s = PEMSensor(params={**base, "detect_ar": 0.0, **params})
    rng = np.random.default_rng(3)
    boxes = np.asarray([s.detect(EGO, (actor,), CLEAR, rng)[0].box for _ in range(n)])
    return boxes, np.asarray(project_box(s.camera, EGO, actor).box)


def test_box_offsets_move_each_edge_by_its_share_of_the_true_box():
    """``box_dx0`` ... ``box_dy1`` move the detected box's edges by that share of the true
    box's width or height (the same draws: without jitter exactly so), and the corner
    noise scatters around the moved box; 0 leaves the box on the true box."""
    actor = car(12.0, 0.5, 0.3)
    offsets = {"box_dx0": 0.1, "box_dy0": 0.05, "box_dx1": -0.2, "box_dy1": -0.08}
    still, truth = _boxes({"jitter": 0.0, "jitter_y": 0.0}, actor, n=5)
    moved, _ = _boxes({"jitter": 0.0, "jitter_y": 0.0, **offsets}, actor, n=5)
    w, h = truth[2] - truth[0], truth[3] - truth[1]
    assert np.array_equal(still, np.tile(truth, (5, 1)))
    want = truth + np.array([0.1 * w, 0.05 * h, -0.2 * w, -0.08 * h])
    assert np.allclose(moved, np.tile(want, (5, 1)), atol=1e-9)
    noisy, _ = _boxes({"jitter": 0.05, "jitter_y": 0.05, **offsets}, actor, n=2000)
    assert np.allclose(noisy.mean(axis=0), want, atol=0.01 * h)


def test_jitter_y_sets_the_vertical_corner_noise_and_defaults_to_jitter():
    """``jitter_y`` is the vertical corners' noise (a share of the box height), ``jitter``
    the horizontal ones'; a negative ``jitter_y`` (the default: files written before it)
    is ``jitter``, the same boxes bit for bit."""
    actor = car(12.0, 0.5, 0.3)
    assert PEMParams(jitter=0.07).jitter_vertical == 0.07
    assert PEMParams(jitter=0.07, jitter_y=0.01).jitter_vertical == 0.01
    same, truth = _boxes({"jitter": 0.2}, actor)
    also, _ = _boxes({"jitter": 0.2, "jitter_y": 0.2}, actor)
    assert np.array_equal(same, also)
    split, _ = _boxes({"jitter": 0.2, "jitter_y": 0.02}, actor, n=2000)
    w, h = truth[2] - truth[0], truth[3] - truth[1]
    assert np.std(split[:, 1]) / h == pytest.approx(0.02, rel=0.1)
    assert np.std(split[:, 3]) / h == pytest.approx(0.02, rel=0.1)
    assert np.std(split[:, 0]) / w == pytest.approx(0.2, rel=0.1)


def test_shipped_file_sets_every_parameter():
    import yaml

    data = yaml.safe_load(PEM_PARAMS_FILE.read_text())
    # but the terms added since the shipped fit, 0 until the next refit (docs/pem.md)
    assert set(PEMParams().to_dict()) - set(data["params"]) <= set(NOT_IN_SHIPPED_FIT)
    assert set(data["params"]) <= set(PEMParams().to_dict())
    default = PEMParams()
    assert all(
        getattr(load_pem_params(), name) == getattr(default, name) for name in NOT_IN_SHIPPED_FIT
    )
    assert load_pem_params() == PEMParams.from_mapping(data["params"])


def test_parameter_file_errors(tmp_path):
    bad = tmp_path / "pem.yaml"
    bad.write_text("params:\n  bias: 1.0\n  sise_gain: 2\n")
    with pytest.raises(ConfigError, match=r"sise_gain.*size_gain"):
        load_pem_params(bad)
    bad.write_text("params:\n  floor: 2\n")
    with pytest.raises(ConfigError, match="floor"):
        load_pem_params(bad)
    good = tmp_path / "ok.yaml"
    good.write_text("params:\n  bias: -1.0\n")
    assert PEMSensor(good).params.bias == -1.0
    with pytest.raises(ConfigError, match="noise_sigma"):
        PEMSensor({"noise_sigma": -1})


def test_box_shape_and_image_offset_terms():
    # aspect_gain > 0: a wider box of the same height scores higher; edge_gain > 0: a box
    # away from the image centre scores lower. Both vanish with their gains at 0.
    p = PEMParams(aspect_gain=0.7, edge_gain=0.5, view2_gain=0.3)
    f = PEMFeatures(40.0, 0.0, 0.0, width_px=40.0, offset=0.0)
    assert pem_score(f._replace(width_px=100.0), p) > pem_score(f, p)
    assert pem_score(f._replace(offset=0.8), p) < pem_score(f, p)
    oblique = pem_score(f._replace(view_angle=math.pi / 4), p)
    assert oblique > pem_score(f._replace(view_angle=math.pi / 4), PEMParams(aspect_gain=0.7))
    plain = PEMParams()
    assert pem_score(f._replace(width_px=100.0, offset=0.8), plain) == pytest.approx(
        pem_score(f, plain)
    )


def test_features_measure_box_width_and_offset_from_the_geometry():
    s = PEMSensor()
    rear = feats(s, car(20.0))
    side = feats(s, car(20.0, 0.0, math.pi / 2))
    assert side.width_px > 2.0 * rear.width_px  # a side view is wider for the same height
    assert rear.offset == pytest.approx(0.0, abs=0.02)
    left = feats(s, car(20.0, 8.0))
    assert 0.2 < left.offset <= 1.0


def documented_logit(f: PEMFeatures, p: PEMParams) -> float:
    """The module docstring's formula with the builtins ``min`` and ``max``, term by term
    in the order the PEM adds them."""
    size = math.log(min(max(f.height_px, p.size_min_px), p.size_max_px) / p.size_ref_px)
    shape = 0.0
    if f.width_px > 0.0 and f.height_px > 0.0:
        shape = math.log(min(max(f.width_px / f.height_px, 0.25), 4.0))
    side = math.sin(f.view_angle)
    return (
        p.bias
        + (p.size_gain + p.size2_gain * size + p.side_size_gain * side) * size
        - p.view_gain * side
        + p.view2_gain * math.sin(2.0 * f.view_angle)
        + p.facing_gain * f.facing
        + p.facing2_gain * (2.0 * f.facing * f.facing - 1.0)
        - p.trunc_gain * f.truncation
        + p.fog_gain * math.log(max(f.transmittance, 1e-9))
        + p.illum_gain * math.log(max(f.illumination, 1e-9))
        - p.rain_gain * f.rain_noise
        + p.aspect_gain * shape
        - p.edge_gain * f.offset
        + p.contrast_gain * f.contrast
        + p.detail_gain * f.detail
        + p.chroma_gain * f.chroma
        + p.red_green_gain * f.red_green
        + p.yellow_blue_gain * f.yellow_blue
        + p.side_gain * f.side
        + p.size3_gain * size * size * size
        + (_bends(f.height_px, side, p, f.truncation) + _head_on(f, p))  # one sum, as the PEM
    )


def _head_on(f: PEMFeatures, p: PEMParams) -> float:
    """The close car seen head-on from the front: ``head_on_gain`` times a tent in the view
    angle (1 head-on, 0 at ``HEAD_ON_DEG``) on a front view of a box of ``HEAD_ON_PX``."""
    from sitcov.perception._pem import HEAD_ON_DEG, HEAD_ON_PX

    inside = f.facing < 0.0 and HEAD_ON_PX[0] <= f.height_px < HEAD_ON_PX[1]
    tent = 1.0 - f.view_angle / math.radians(HEAD_ON_DEG)
    return p.head_on_gain * tent if p.head_on_gain != 0.0 and inside and tent > 0.0 else 0.0


def _bends(h: float, view_sine: float, p: PEMParams, truncation: float = 0.0) -> float:
    """The size term's bends at 40 and 80 px of the unclamped height, then the side-on
    bend at 40 px, then the step of a box cut by the image edge and its tent at
    ``CUT_TENT_PX`` (the PEM adds them as one sum, in that order)."""
    from sitcov.perception._pem import CUT_RAMP, CUT_TENT_PX

    bend = 0.0
    if p.size_hinge40_gain != 0.0 and h > 40.0:
        bend += p.size_hinge40_gain * math.log(h / 40.0)
    if p.size_hinge80_gain != 0.0 and h > 80.0:
        bend += p.size_hinge80_gain * math.log(h / 80.0)
    if p.view_hinge40_gain != 0.0 and h > 40.0:
        bend += p.view_hinge40_gain * view_sine * math.log(h / 40.0)
    ramp = min(1.0, truncation / CUT_RAMP)
    if p.cut_gain != 0.0 and truncation > 0.0:
        bend += p.cut_gain * ramp
    tent = 1.0 - abs(math.log(h / CUT_TENT_PX)) / math.log(2.0) if h > 0.0 else 0.0
    if p.cut_tent_gain != 0.0 and truncation > 0.0 and tent > 0.0:
        bend += p.cut_tent_gain * ramp * tent
    return bend


@params_ids
def test_pem_logit_is_the_documented_formula_bit_for_bit(name):
    """``pem_logit`` (its clamps written out for the compiled score) gives the formula's
    bits, clamped features included: boxes below and above the size range, extreme
    shapes, no width, full fog and darkness."""
    p = replace(PARAM_SETS[name], contrast_gain=0.4, chroma_gain=-0.3, yellow_blue_gain=0.2)
    p = replace(p, side_gain=-0.35, size3_gain=-0.4, view_hinge40_gain=0.3)
    p = replace(p, cut_gain=0.2, cut_tent_gain=0.45)  # the cut box's step and tent
    p = replace(p, head_on_gain=-0.6)  # and the close car seen head-on from the front
    rng = np.random.default_rng(11)
    features = [f._replace(side=rng.uniform(-1.0, 1.0)) for f in random_features(rng, 400)]
    features += [
        f._replace(height_px=h, width_px=w, transmittance=t, illumination=i)
        for f, h, w, t, i in zip(
            features,
            rng.choice([0.5, 3.0, 400.0, 1e4], 400),
            rng.choice([0.0, 0.1, 1.0, 5e3], 400),
            rng.choice([0.0, 1e-12, 0.5], 400),
            rng.choice([0.0, 1e-10, 0.7], 400),
            strict=False,
        )
    ]
    assert sum(_head_on(f, p) != 0.0 for f in features) > 10  # the head-on term is tried
    for f in features:
        assert repr(pem_logit(f, p)) == repr(documented_logit(f, p)), f


def test_detect_scores_as_features_then_pem_logit(monkeypatch):
    """``detect``'s one-call score (projection, features and logit, compiled when numba
    is there) is ``pem_logit(features(...))``: without noise every detection's score is
    the sigmoid of that logit, bit for bit, in fog and darkness, near and far."""
    p = replace(PARAM_SETS["random1"], noise_sigma=0.0, rain_sigma=0.0, jitter=0.0, floor=0.0)
    p = replace(p, rain_jitter=0.0, rain_miss=0.0, detect_bias=8.0, detect_gain=0.0)
    p = replace(p, detect_ar=0.0)  # the actor always output: every frame has its score
    p = replace(p, side_gain=0.45)  # the side's term computed in the view too
    p = replace(p, view_hinge40_gain=0.3)  # and the side-on bend
    p = replace(p, cut_gain=0.2, cut_tent_gain=0.45)  # and the cut box's step and tent
    p = replace(p, head_on_gain=-0.6)  # and the close car seen head-on from the front
    sensor = PEMSensor(p)
    rng = np.random.default_rng(12)
    detected = 0
    for _ in range(600):
        cond = Conditions(fog_extinction=float(rng.choice([0.0, 0.02])), illumination=0.6)
        ego = Pose(*rng.uniform(-5.0, 5.0, 2), rng.uniform(-4.0, 4.0))
        actor = car(*rng.uniform(-60.0, 60.0, 2), rng.uniform(-4.0, 4.0))
        dets = sensor.detect(ego, (actor,), cond, rng)
        f = sensor.features(ego, actor, cond)
        if f is None or f.height_px < p.size_min_px:
            assert dets == ()
            continue
        z = pem_logit(f, p)
        assert [d.score for d in dets] == [1.0 / (1.0 + math.exp(-z)) if z >= 0 else
                                           math.exp(z) / (1.0 + math.exp(z))]  # fmt: skip
        detected += 1
    assert detected > 60


# -- the fitting procedure of `sitcov calibrate`: recovers known parameters ----------------

#: The detector the synthetic frames come from (every documented term switched on).
TRUE = replace(
    PEMParams(),
    bias=-0.5, size_gain=1.2, size2_gain=0.1, side_size_gain=0.0, view_gain=0.3,
    view2_gain=0.2, facing_gain=0.1, facing2_gain=0.15, trunc_gain=1.5, fog_gain=0.8,
    illum_gain=0.6, rain_gain=1.0, aspect_gain=0.3, edge_gain=0.4, noise_sigma=0.4,
    size_min_px=10.0, size_max_px=150.0, jitter=0.04, rain_sigma=0.0, rain_miss=0.0,
    rain_jitter=0.0, noise_tau=0.0, noise_run_share=0.0,
)  # fmt: skip
#: Terms the fit identifies one by one, and the tolerance on each. Measured over 10 seeds of
#: this test (12,000 frames): the errors' standard deviations were 0.013-0.057 (largest:
#: trunc_gain), so 0.25 is >= 4.4 standard deviations for every term (a correct fit fails
#: with probability < 1e-5 each, normal approximation), while a fit that drops or
#: mis-signs a term (error >= 0.3) fails.
IDENTIFIED = ("trunc_gain", "fog_gain", "illum_gain", "rain_gain", "aspect_gain",
              "edge_gain", "facing_gain", "facing2_gain")  # fmt: skip
COEF_TOLERANCE = 0.25
N_SYNTHETIC = 12_000


def synthetic_samples(params: PEMParams, rng: np.random.Generator, n: int) -> list:
    """Frames of a detector that behaves exactly like ``params`` (score and box errors)."""
    from sitcov.calibration._calibrate import Sample

    out = []
    for f in random_features(rng, n):
        z = pem_logit(f, params) + params.noise_sigma * rng.standard_normal()
        score = 1.0 / (1.0 + math.exp(-z))
        if score < 0.05 or f.height_px < params.size_min_px:
            score = 0.0  # below the detector's output threshold, or too small: no box
        error = tuple(rng.normal(0.0, params.jitter, 4)) if score > 0 else None
        out.append(
            Sample(
                element="clear",
                value=0.0,
                distance=20.0,
                bearing=0.0,
                view=f.view_angle,
                width_px=f.width_px,
                features=f,
                score=score,
                box_error=error,
            )  # fmt: skip
        )
    return out


@pytest.mark.slow
def test_calibrate_fit_recovers_known_parameters_from_synthetic_frames():
    """Known parameters -> synthetic detector frames -> ``fit_pem`` -> the same detector.

    The size and view terms are collinear (docs/pem.md), so they are checked through what
    the fit predicts: the probability that a frame reaches the AEB threshold, on held-out
    features. Measured over 10 seeds: mean |error| 0.005-0.010 and 95th percentile
    0.020-0.047, so the tolerances 0.02 and 0.08 leave >= 5 standard deviations.
    """
    from sitcov.calibration._calibrate import fit_pem

    fit = fit_pem(synthetic_samples(TRUE, np.random.default_rng(2026), N_SYNTHETIC))
    for name in IDENTIFIED:
        assert getattr(fit, name) == pytest.approx(getattr(TRUE, name), abs=COEF_TOLERANCE), name
    assert fit.noise_sigma == pytest.approx(TRUE.noise_sigma, rel=0.15)
    assert fit.jitter == pytest.approx(TRUE.jitter, rel=0.1)
    assert fit.size_min_px >= TRUE.size_min_px  # never reports boxes the detector cannot see
    held = [
        f
        for f in random_features(np.random.default_rng(99), 3000)
        if f.height_px >= fit.size_min_px
    ]
    p_true = np.array([ndtr(pem_logit(f, TRUE) / TRUE.noise_sigma) for f in held])
    p_fit = np.array([ndtr(pem_logit(f, fit) / fit.noise_sigma) for f in held])
    error = np.abs(p_fit - p_true)
    assert error.mean() < 0.02 and np.percentile(error, 95) < 0.08


def test_calibrate_fit_finds_no_effect_where_the_detector_has_none():
    """A detector blind to fog, darkness and rain gives gains near 0 (not the defaults)."""
    from sitcov.calibration._calibrate import fit_pem

    blind = replace(TRUE, fog_gain=0.0, illum_gain=0.0, rain_gain=0.0)
    fit = fit_pem(synthetic_samples(blind, np.random.default_rng(7), 4000))
    # at 4,000 frames the errors' standard deviation is about sqrt(3) times the one above
    # (<= 0.06 for these terms): 0.3 is 5 of them
    for name in ("fog_gain", "illum_gain", "rain_gain"):
        assert abs(getattr(fit, name)) < 0.3, (name, getattr(fit, name))


def test_the_detection_term_drops_boxes_that_fill_or_leave_the_image():
    """``detect_trunc_gain``/``detect_fill_gain``: a car side-on 5 m ahead (a box wider than
    the image, cut by both edges) is output as often as ``pass_probability`` says, far
    less often than without the terms; a car 30 m ahead (narrower than 5 % of the image,
    not cut) is not affected. Gains of 0 draw nothing more (files without them)."""
    from sitcov.perception._pem import detect_offset, fill_of

    assert fill_of(30.0, 800.0) == 0.0 and fill_of(900.0, 800.0) == pytest.approx(math.log(20))
    base = {"bias": 3.0, "noise_sigma": 0.3, "noise_tau": 0.0, "noise_frame_share": 0.0,
            "noise_run_share": 0.0, "noise_up_ratio": 1.0, "rain_miss": 0.0,
            "detect_bias": 2.0, "detect_gain": 0.0, "detect_ar": 0.0,
            "size_max_px": 450.0, "detect_trunc_gain": 0.0, "detect_fill_gain": 0.0}  # fmt: skip
    plain = PEMSensor(base)
    edge = PEMSensor({**base, "detect_trunc_gain": 1.0, "detect_fill_gain": 1.0})
    near, far = car(5.0, 0.0, math.pi / 2), car(30.0, 0.0, 0.0)
    f_near, f_far = edge.features(EGO, near, CLEAR), edge.features(EGO, far, CLEAR)
    assert f_near.truncation > 0.15 and f_near.width_px > 800.0
    assert detect_offset(f_far, edge.params) == 0.0
    rng = np.random.default_rng(5)
    for actor, f in ((near, f_near), (far, f_far)):
        for sensor in (plain, edge):
            expected = pass_probability(f, sensor.params, 0.3)
            hits = sum(
                bool(
                    sensor.detect(
                        EGO, (actor,), CLEAR, np.random.default_rng(rng.integers(1 << 62))
                    )
                )
                for _ in range(N_FRAMES)
            )
            assert hits / N_FRAMES == pytest.approx(expected, abs=TOLERANCE)
    assert (
        pass_probability(f_near, edge.params, 0.3)
        < pass_probability(f_near, plain.params, 0.3) - 0.5
    )
    assert pass_probability(f_far, edge.params, 0.3) == pass_probability(f_far, plain.params, 0.3)


def _flat_params(**changes: float) -> dict[str, float]:
    """A PEM with no size, side or detection terms (a car that is always output) and a
    noise whose frames are 30 % fresh, so that what a test sets is what acts; ``changes``
    on top. (With the whole noise in the AR part ``pass_probability``'s 40-node
    quadrature is a step function of the threshold.)"""
    base = {"bias": 0.0, "size_gain": 0.0, "size2_gain": 0.0, "side_size_gain": 0.0,
            "noise_sigma": 0.3, "noise_tau": 0.0, "noise_frame_share": 0.3,
            "noise_run_share": 0.0, "noise_up_ratio": 1.0, "rain_miss": 0.0,
            "detect_bias": 8.0, "detect_gain": 0.0, "detect_ar": 0.0, "floor": 0.05,
            "detect_trunc_gain": 0.0, "detect_fill_gain": 0.0, "noise_size_gain": 0.0,
            "size_ref_px": 25.0, "size_max_px": 450.0, "size_hinge40_gain": 0.0,
            "size_hinge80_gain": 0.0}  # fmt: skip
    return {**base, **changes}


def test_the_score_noise_grows_with_the_box_height_as_noise_size_gain_says():
    """``noise_size_gain``: the logit noise's scale is ``(h / size_ref_px) ** gain``, ``h``
    capped at ``noise_size_max_px``. Sampled frames of a close (large) and a far (small)
    car pass θ = 0.5 as often as ``pass_probability`` says; with a positive gain the close
    car's scores spread more (more frames reach a threshold above its noise-free score)
    and the cap stops the growth; a gain of 0 is the model without the term."""
    from sitcov.perception._pem import noise_scale

    assert noise_scale(0.0, 300.0, 10.0, 450.0, 25.0) == 1.0
    assert noise_scale(0.5, 100.0, 10.0, 450.0, 25.0) == pytest.approx(2.0)
    assert noise_scale(0.5, 400.0, 10.0, 100.0, 25.0) == pytest.approx(2.0)  # capped
    # a frame share > 0: with the whole noise in the AR part pass_probability's 40-node
    # quadrature is a step function of the threshold (it missed the far car's sampled
    # rate by 0.075 once the refit put its score near 0.5)
    base = _flat_params(bias=-0.6, noise_size_gain=0.0)
    plain = PEMSensor(base)
    grown = PEMSensor({**base, "noise_size_gain": 0.8})
    near, far = car(6.0), car(40.0)
    f_near, f_far = grown.features(EGO, near, CLEAR), grown.features(EGO, far, CLEAR)
    assert f_near.height_px > 60.0 > f_far.height_px
    rng = np.random.default_rng(11)
    for actor, f in ((near, f_near), (far, f_far)):
        for sensor in (plain, grown):
            expected = pass_probability(f, sensor.params, 0.5)
            hits = 0
            for _ in range(N_FRAMES):
                dets = sensor.detect(
                    EGO, (actor,), CLEAR, np.random.default_rng(rng.integers(1 << 62))
                )
                hits += any(d.score >= 0.5 for d in dets)
            assert hits / N_FRAMES == pytest.approx(expected, abs=TOLERANCE)
    # a wider spread: more frames reach a threshold 0.3 logit above the noise-free score
    above = 1.0 / (1.0 + math.exp(-(pem_logit(f_near, plain.params) + 0.3)))
    p_plain, p_grown = (pass_probability(f_near, p, above) for p in (plain.params, grown.params))
    assert p_grown > p_plain + 0.1
    capped = replace(grown.params, noise_size_max_px=25.0)  # no growth above the reference
    assert pass_probability(f_near, capped, 0.5) == pass_probability(f_near, plain.params, 0.5)


def test_the_noises_size_bend_changes_its_gain_above_the_knot_only():
    """``noise_bend_gain``/``noise_bend_px``: the scale's log slope in the box height is
    ``noise_size_gain`` below the knot and that plus the bend's gain above it (continuous
    at the knot, capped with the height); a box below the knot draws as without it;
    sampled frames of a close car with a bend pass θ as ``pass_probability`` says; a bend
    with the upper scale's own size gain is refused (its power of the whole factor would
    change)."""
    from sitcov.perception._pem import noise_scale

    args = (10.0, 450.0, 25.0)
    assert noise_scale(0.0, 300.0, *args, 0.0, 100.0) == 1.0
    assert noise_scale(0.5, 80.0, *args, -1.0, 100.0) == noise_scale(0.5, 80.0, *args)
    assert noise_scale(0.5, 100.0, *args, -1.0, 100.0) == pytest.approx(2.0)  # continuous
    slope = math.log(noise_scale(0.5, 400.0, *args, -1.0, 100.0) / 2.0) / math.log(4.0)
    assert slope == pytest.approx(-0.5)  # 0.5 - 1.0 above the knot
    assert noise_scale(0.0, 200.0, *args, 1.0, 100.0) == pytest.approx(2.0)  # alone too
    capped = noise_scale(0.5, 900.0, 10.0, 200.0, 25.0, -1.0, 100.0)  # h counts as 200 px
    assert capped == pytest.approx(math.sqrt(200.0 / 25.0) / 2.0)
    base = _flat_params(bias=0.2, noise_size_gain=0.3)
    plain, bent = PEMSensor(base), PEMSensor({**base, "noise_bend_gain": 1.2,
                                               "noise_bend_px": 60.0})  # fmt: skip
    near, far = car(6.0), car(40.0)
    f_near, f_far = bent.features(EGO, near, CLEAR), bent.features(EGO, far, CLEAR)
    assert f_near.height_px > 60.0 > f_far.height_px
    for theta in (0.5, 0.7):
        assert pass_probability(f_far, bent.params, theta) == pass_probability(
            f_far, plain.params, theta
        )
    above = 1.0 / (1.0 + math.exp(-(pem_logit(f_near, plain.params) + 0.3)))
    assert pass_probability(f_near, bent.params, above) > (
        pass_probability(f_near, plain.params, above) + 0.1
    )
    rng = np.random.default_rng(12)
    for theta in (0.5, above):
        rate = _sampled_rate(bent, near, theta, rng)
        assert rate == pytest.approx(pass_probability(f_near, bent.params, theta), abs=TOLERANCE)
    with pytest.raises(ConfigError, match="noise_bend_gain"):
        PEMParams.from_mapping({"noise_size_gain": 0.3, "noise_up_size_gain": -0.3,
                                "noise_bend_gain": 0.5})  # fmt: skip
    with pytest.raises(ConfigError, match="noise_bend_px"):
        PEMParams.from_mapping({"noise_bend_px": 0.0})
