"""Animations of stored runs: frames from the trace, offline formats, one-line errors."""

from __future__ import annotations

import json
import math
import re

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sitcov.av import make_stack
from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.report import _animate as anim
from sitcov.report import animate_outcome
from sitcov.sim import make_backend


@given(st.integers(1, 2000), st.integers(1, 30), st.integers(2, 300))
def test_frames_sample_the_run_and_end_on_its_last_step(n, fps, max_frames):
    times = [0.05 * i for i in range(n)]
    steps = anim._frame_steps(times, fps, max_frames)
    assert steps[0] == 0 and steps[-1] == n - 1
    assert steps == sorted(set(steps))
    assert len(steps) <= max_frames + 1
    if n > 2:
        # fps frames per simulated second (dt 0.05 s), coarser only to stay under max_frames
        every = max(round(1.0 / (fps * 0.05)), math.ceil(n / max_frames))
        gaps = np.diff(steps)
        assert (gaps[:-1] == every).all() and 1 <= gaps[-1] <= every


def test_closing_distance_and_ttc_of_two_cars_head_on():
    ego = [(0.0, 0.0, 0.0, 0.0, 5.0)]
    other = [(0.0, 20.0, 0.0, math.pi, 5.0)]
    dist, ttc = anim._closing(ego, other)
    assert dist == [pytest.approx(20.0)] and ttc == [pytest.approx(2.0)]
    apart = [(0.0, 20.0, 0.0, 0.0, 10.0)]  # driving away: never meets
    assert anim._closing(ego, apart)[1] == [math.inf]


@pytest.fixture(scope="module")
def outcome():
    hs = load_hyperspace()
    sit = hs.situation_from_bins(
        {**{e.name: e.labels[0] for e in hs.elements}, "friction": "0.1", "intsit": "IntSit-8"}
    )
    backend = make_backend("embedded")
    return backend.run(sit, make_stack("reference"), 1, record=True)


def test_a_gif_has_one_frame_per_sampled_step_and_things_move(outcome, tmp_path):
    from PIL import Image

    out = animate_outcome(outcome, tmp_path / "run.gif", fps=5, max_frames=40, dpi=50)
    times = [r[0] for r in outcome.trace.ego]
    with Image.open(out) as im:
        assert im.n_frames == len(anim._frame_steps(times, 5, 40))
        first = np.asarray(im.convert("RGB")).copy()
        im.seek(im.n_frames - 1)
        last = np.asarray(im.convert("RGB"))
    assert (first != last).any(axis=2).mean() > 0.005  # actors, cursor and text moved


def test_the_html_player_is_offline_and_holds_every_frame(outcome, tmp_path):
    out = animate_outcome(outcome, tmp_path / "run.html", fps=5, max_frames=30, dpi=40)
    page = out.read_text()
    frames = json.loads(re.search(r"f=(\[.*?\]),i=0", page, re.S)[1])
    times = [r[0] for r in outcome.trace.ego]
    assert len(frames) == len(anim._frame_steps(times, 5, 30))
    assert "http" not in page and "<script src" not in page  # nothing fetched


def test_bad_formats_are_one_clear_error(outcome, tmp_path, monkeypatch):
    with pytest.raises(ConfigError, match="--out"):
        animate_outcome(outcome, tmp_path / "run.avi")
    monkeypatch.setattr(anim.shutil, "which", lambda name: None)
    with pytest.raises(ConfigError, match="ffmpeg on PATH"):
        animate_outcome(outcome, tmp_path / "run.mp4")
    no_trace = type(outcome)(status="pass", end_reason="goal")
    with pytest.raises(ConfigError, match="no trace"):
        animate_outcome(no_trace, tmp_path / "x.gif")


def test_sitcov_animate_on_a_stored_run(tmp_path, capsys):
    db = tmp_path / "a.db"
    store = open_store(db)
    try:
        run_campaign(CampaignConfig(runs=3, seed=2, executor="serial"), store)
    finally:
        store.close()
    main(["animate", "default:1", "--db", str(db), "--out", str(tmp_path / "r.gif")])
    assert (tmp_path / "r.gif").stat().st_size > 1000
    assert "animation written" in capsys.readouterr().out
    with pytest.raises(SystemExit):
        main(["animate", "default:9", "--db", str(db), "--out", str(tmp_path / "r.gif")])
    assert "error" in capsys.readouterr().err


def _animated(tmp_path, capsys, perception: str):
    """``sitcov animate`` of run 0 of a 1-run campaign with ``perception``: the GIF's first
    and last frames (RGB arrays) and its frame count."""
    from PIL import Image

    db = tmp_path / f"{perception}.db"
    store = open_store(db)
    try:
        config = CampaignConfig(
            runs=1, seed=3, executor="serial", backend_options={"perception": perception}
        )
        run_campaign(config, store)
    finally:
        store.close()
    out = tmp_path / f"{perception}.gif"
    main(["animate", "default:0", "--db", str(db), "--out", str(out), "--fps", "2"])
    assert "animation written" in capsys.readouterr().out
    with Image.open(out) as im:
        n = im.n_frames
        first = np.asarray(im.convert("RGB")).copy()
        im.seek(n - 1)
        last = np.asarray(im.convert("RGB")).copy()
    return first, last, n


def test_a_camera_mode_run_has_a_dash_cam_strip_and_a_pem_run_none(tmp_path, capsys, ssd_model_dir):
    """Camera mode: a strip under the top-down view that shows the camera's view (sky over
    ground: varied pixels) and changes from frame to frame; PEM mode: the plain layout."""
    from sitcov.report._dashcam import camera_mode

    assert camera_mode({"backend_options": {"perception": "camera"}})
    assert not camera_mode({"backend_options": {"perception": "pem"}}) and not camera_mode({})
    pem_first, _, _ = _animated(tmp_path, capsys, "pem")
    cam_first, cam_last, n = _animated(tmp_path, capsys, "camera")
    assert pem_first.shape[1] == cam_first.shape[1]  # same width
    assert cam_first.shape[0] > 1.5 * pem_first.shape[0]  # the strip below
    strip = cam_first[pem_first.shape[0] + 30 :, :, :].astype(int)
    assert strip.std() > 20  # an image, not a blank panel
    assert n > 2 and (cam_last[pem_first.shape[0] :] != cam_first[pem_first.shape[0] :]).any()
    # the report's animations (its runs are RunFacts, without values): the same strip
    from sitcov.campaign._facts import iter_run_facts
    from sitcov.report._pictures import _dashcam
    from sitcov.report._traces import close_builders, traced_outcome

    for perception in ("camera", "pem"):
        builders: dict = {}
        with open_store(tmp_path / f"{perception}.db") as store:
            facts = next(iter_run_facts(store, "default"))
            outcome = traced_outcome(store, facts, builders)
            strip = _dashcam(store, facts, outcome)
        close_builders(builders)
        assert (strip is not None) == (perception == "camera")
        if strip is not None:
            assert strip.frame(0).shape == (*strip.shape, 3) and strip.detector is None
