"""The check per track (``--check-tracks``): the PEM's chance that some frame of a road
user's track reaches θ, a filter over the noise's AR(1) state, against what the sensor
samples and what the recorded frames show."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sitcov.calibration import _frame_check as fc
from sitcov.calibration._camera_runs import CameraRun, RunFrame
from sitcov.calibration._frames import KindFrames, read_frames, write_frames
from sitcov.errors import SitcovError
from sitcov.perception import ActorView, Pose
from sitcov.perception._pem import PEMFeatures, PEMSensor, pass_given_state, pass_probability
from sitcov.perception._pem_params import load_pem_params
from sitcov.weather import conditions_from_values

EGO = Pose(0.0, 0.0, 0.0)
CLEAR = conditions_from_values({})
DATA = Path(__file__).resolve().parents[2] / "docs" / "data"


def _approach(sensor: PEMSensor, frames: int = 12) -> list[tuple[int, PEMFeatures]]:
    """A car crossing ahead from 30 m to 8 m, side-on, ``frames`` consecutive frames."""
    out = []
    for k, x in enumerate(np.linspace(30.0, 8.0, frames)):
        actor = ActorView(Pose(float(x), 2.0, math.pi / 2), 4.7, 1.85, 1.5)
        out.append((k, sensor.features(EGO, actor, CLEAR)))
    return out


def test_the_state_averages_to_the_frames_law() -> None:
    """``pass_given_state`` averaged over the AR state's prior is ``pass_probability``,
    and a one-frame track's chance is the frame's."""
    params = load_pem_params()
    sensor = PEMSensor(params)
    for _, f in _approach(sensor, 4):
        nodes = np.linspace(-6.0, 6.0, 241)
        prior = np.exp(-0.5 * nodes**2)
        mixed = float(np.dot(pass_given_state(f, params, 0.6, nodes), prior / prior.sum()))
        assert mixed == pytest.approx(pass_probability(f, params, 0.6), abs=1e-4)
        one = fc.track_pass_probability(params, [(0, f)], 0.6)
        assert one == pytest.approx(pass_probability(f, params, 0.6), abs=1e-3)


def test_persistence_sets_the_chance_between_its_bounds() -> None:
    """Without persistence (``noise_tau`` 0) the frames are independent: 1 - prod(1 -
    p_i). With it, the chance lies between the likeliest frame's and that, and a longer
    time constant lowers it (the high frames come together, in fewer tracks)."""
    params = load_pem_params()
    frames = _approach(PEMSensor(params))
    p = [pass_probability(f, params, 0.7) for _, f in frames]
    independent = 1.0 - float(np.prod([1.0 - x for x in p]))
    free = fc.track_pass_probability(replace(params, noise_tau=0.0), frames, 0.7)
    assert free == pytest.approx(independent, abs=1e-3)
    chances = [
        fc.track_pass_probability(replace(params, noise_tau=tau), frames, 0.7)
        for tau in (0.2, 0.5311, 2.0)
    ]
    assert all(max(p) - 1e-3 <= c <= independent + 1e-3 for c in chances)
    assert chances[0] > chances[1] + 0.02 > chances[2] + 0.04
    # the time constant shrinking on a larger box (all of these are above the reference
    # size): the frames forget faster, so some frame passes more often
    faster = fc.track_pass_probability(replace(params, noise_tau_size_gain=0.8), frames, 0.7)
    assert chances[1] + 0.02 < faster <= independent + 1e-3


@pytest.mark.parametrize(("theta", "tau_gain"), [(0.5, None), (0.7, None), (0.7, 0.8)])
def test_the_chance_is_what_the_sensor_samples(theta: float, tau_gain: float | None) -> None:
    """The car PEM (shipped, or with the AR part's time constant shrinking on a larger
    box, ``noise_tau_size_gain``) drawn frame by frame along one approach (1,500 runs,
    each its own generator): the share of runs with some reported score >= θ is the
    filter's chance within 3.5 standard errors (plus the grid's 0.005)."""
    gain = {} if tau_gain is None else {"noise_tau_size_gain": tau_gain}
    sensor = PEMSensor(gain or None)
    frames = _approach(sensor)
    actors = [
        ActorView(Pose(float(x), 2.0, math.pi / 2), 4.7, 1.85, 1.5)
        for x in np.linspace(30.0, 8.0, len(frames))
    ]
    rng = np.random.default_rng(5)
    runs, hits = 1500, 0
    for _ in range(runs):
        sensor.reset()
        run_rng = np.random.default_rng(rng.integers(1 << 62))
        hits += any(
            d.score >= theta for a in actors for d in sensor.detect(EGO, (a,), CLEAR, run_rng)
        )
    expected = fc.track_pass_probability(sensor.params, frames, theta)
    se = math.sqrt(expected * (1.0 - expected) / runs)
    assert hits / runs == pytest.approx(expected, abs=3.5 * se + 0.005)


def test_the_grid_is_fine_enough_on_recorded_tracks() -> None:
    """On recorded car tracks (seed 2's, the first 20 runs) the shipped grid's chances
    are within 0.002 of a four times finer grid's."""
    data = read_frames(DATA / "pem-frames-top-seed2.jsonl.gz")["car"]
    data = KindFrames(runs=data.runs[:20])
    params = load_pem_params()
    for band in fc.BANDS:
        for track, _, _ in fc.tracks_of_runs(data, band):
            frames = [(n, f) for n, f, _ in track]
            coarse = fc.track_pass_probability(params, frames, 0.6)
            fine = fc.track_pass_probability(params, frames, 0.6, nodes=161)
            assert coarse == pytest.approx(fine, abs=0.002)


def _runs(seed: int, runs: int, shift_from: str | None = None) -> KindFrames:
    """Runs of a car closing from 40 to 4 m whose scores are drawn by the sensor with
    :data:`PLAIN` (independent frames), two routes alternating (bins ``intsit``); the
    scores of ``shift_from``'s runs (a route) scaled down 20 % in the logit's distance
    from 0.5 when above it."""
    rng = np.random.default_rng(seed)
    sensor = PEMSensor(PLAIN)
    out = KindFrames()
    for r in range(runs):
        route = ("IntSit-2", "IntSit-10")[r % 2]
        run_rng = np.random.default_rng(rng.integers(1 << 62))
        sensor.reset()
        frames = []
        for k, x in enumerate(np.linspace(40.0, 4.0, 25)):
            actor = ActorView(Pose(float(x), 1.5, math.pi / 2), 4.7, 1.85, 1.5)
            feats = sensor.features(EGO, actor, CLEAR)
            got = sensor.detect(EGO, (actor,), CLEAR, run_rng)
            score = max((d.score for d in got), default=0.0)
            if route == shift_from and score > 0.5:
                score = 1.0 / (1.0 + math.exp(-0.6 * math.log(score / (1.0 - score))))
            frames.append(RunFrame(feats, score, None, feats.width_px, k, 0, float(x)))
        situation = {"bins": {"intsit": route}, "values": {"precipitation": 0.0}}
        out.runs.append(CameraRun(r, r, situation, False, None, tuple(frames)))
    return out


#: A PEM whose frames are independent (no AR part), so its sampled runs are its own law.
PLAIN = replace(load_pem_params(), noise_tau=0.0)


def test_the_track_check_finds_its_own_law_right_and_a_route_that_scores_lower() -> None:
    """Tracks drawn by the PEM itself: every judged cell within the tolerance; one route
    whose high scores are pulled down: split by ``bin:intsit`` that route's close cells
    at θ 0.7 are off significantly (the PEM over), the other route's are not; the
    groups' tracks add up to the band's."""
    rng = np.random.default_rng(0)
    own = fc.check_tracks({"car": _runs(1, 80)}, {"car": PLAIN}, rng=rng)
    judged = [r for r in own if "ok" in r]
    assert judged and all(r["ok"] for r in judged), fc.table_lines(own)
    data = {"car": _runs(2, 120, shift_from="IntSit-10")}
    rows = fc.check_tracks(data, {"car": PLAIN}, rng=rng, split="bin:intsit")
    close = [r for r in rows if r["band"] == "0-10 m" and r["theta"] == 0.7 and "ok" in r]
    shifted = [r for r in close if r["group"] == "IntSit-10"]
    assert shifted and all(r["significant"] and r["difference"] > 0 for r in shifted)
    assert not any(r["significant"] for r in close if r["group"] == "IntSit-2"), rows
    whole = fc.check_tracks(data, {"car": PLAIN})
    for row in whole:
        mine = [r for r in rows if (r["band"], r["theta"]) == (row["band"], row["theta"])]
        assert sum(r["n"] for r in mine) == row["n"]
    assert [r["group"] for r in rows[:2]] == ["IntSit-2", "IntSit-2"]  # natural order


def test_the_track_check_refuses_a_split_by_frame_and_a_run_constant_noise() -> None:
    """A split that changes from frame to frame (view, cut) is refused for tracks, and so
    is a PEM with a noise part constant over a run (the filter does not carry it)."""
    data = {"car": _runs(3, 4)}
    with pytest.raises(SitcovError, match="splits by the run only"):
        fc.check_tracks(data, {"car": PLAIN}, split="view")
    with pytest.raises(SitcovError, match="noise_run_share"):
        fc.check_tracks(data, {"car": replace(PLAIN, noise_run_share=0.3)})


def test_check_tracks_on_the_command_line(tmp_path: Path, capsys) -> None:
    """``sitcov calibrate --check FILE --check-tracks --check-by bin:intsit``: the table
    says it counts tracks and has a row per route; a split by frame is one error line
    naming the splits there are, exit 2."""
    from sitcov.cli import main

    frames = tmp_path / "frames.jsonl"
    write_frames(frames, {"car": _runs(4, 12)})
    args = ["calibrate", "--check", str(frames), "--kinds", "car", "--check-tracks"]
    try:
        main([*args, "--check-by", "bin:intsit"])
    except SystemExit as exc:  # 1 when a cell is off: the table is printed either way
        assert exc.code == 1
    out = capsys.readouterr().out
    assert "per track" in out and " IntSit-2 " in out and " IntSit-10 " in out
    with pytest.raises(SystemExit) as exc:
        main([*args, "--check-by", "view"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and err.count("\n") == 0 and "approach | rain" in err
