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
