"""The held-out check split by a property of the frame or its run (``--check-by``): the
groups partition each band, and a miss confined to one group shows there."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from sitcov.calibration import _frame_check as fc
from sitcov.calibration._camera_runs import CameraRun, RunFrame
from sitcov.calibration._frames import KindFrames, write_frames
from sitcov.errors import SitcovError
from sitcov.perception._pem import PEMFeatures, PEMParams, pass_probability

#: The PEM the synthetic frames are drawn from (its own law: the check finds it right).
PARAMS = PEMParams(noise_up_ratio=1.0)
#: Where each synthetic run's road user comes from: the ego's and its routes.
ROUTES = {
    "from left": {"ego": "B-L", "ov": "L-R"},
    "from right": {"ego": "B-L", "ov": "R-L"},
    "ahead/other": {"ego": "L-B", "ov": "R-L"},
}


def _score(feats: PEMFeatures, u: float, shift: float) -> float:
    """The score whose PEM exceedance probability is ``u`` (0: not reported), its logit
    moved by ``shift``: a draw of the PEM's own law by inverting ``pass_probability``."""
    if u >= pass_probability(feats, PARAMS, PARAMS.floor):
        return 0.0
    lo, hi = PARAMS.floor, 1.0 - 1e-9
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if pass_probability(feats, PARAMS, mid) > u else (lo, mid)
    z = math.log(lo / (1.0 - lo)) + shift
    return 1.0 / (1.0 + math.exp(-z))


def _frames(seed: int, left_shift: float = 0.0, runs: int = 90) -> KindFrames:
    """Runs of a car closing from 40 to 4 m, a third from each side, each seen from the
    front, side or rear, in dry, light or heavy rain, calm or windy, some cut by the image
    edge; scores drawn from :data:`PARAMS`' law, those of runs from the left moved by
    ``left_shift`` logit."""
    rng = np.random.default_rng(seed)
    out = KindFrames()
    for r in range(runs):
        side = list(ROUTES)[r % 3]
        facing = float(rng.choice([-0.95, 0.0, 0.95]))
        rain = float(rng.choice([0.0, 30.0, 80.0]))
        cut = float(rng.choice([0.0, 0.3]))
        shift = left_shift if side == "from left" else 0.0
        frames = []
        for k, d in enumerate(np.linspace(40.0, 4.0, 30)):
            h = 1.45 * 336.0 / d
            feats = PEMFeatures(h, math.acos(abs(facing)), cut, rain_noise=rain / 200.0,
                                width_px=2.0 * h, facing=facing)  # fmt: skip
            score = _score(feats, float(rng.uniform()), shift)
            frames.append(RunFrame(feats, score, None, 2.0 * h, k, 0, float(d)))
        wind = 80.0 if (r // 3) % 2 else 0.0  # not drawn: the other draws stay as they were
        values = {"precipitation": rain, "wind_intensity": wind, "intsit": ROUTES[side]}
        out.runs.append(CameraRun(r, r, {"values": values}, False, None, tuple(frames)))
    return out


@pytest.mark.parametrize("split", sorted(fc.SPLITS))
def test_a_splits_groups_partition_each_band(split: str) -> None:
    """Per band and θ the groups' frames add up to the band's, and their frame-weighted
    rates (detector's and PEM's) to the band's rates."""
    data = {"car": _frames(1, runs=30)}
    whole = fc.check_frames(data, {"car": PARAMS})
    parts = fc.check_frames(data, {"car": PARAMS}, split=split)
    assert {r["group"] for r in parts} <= set(fc.SPLITS[split][1])
    assert all("group" not in r for r in whole)
    for row in whole:
        mine = [p for p in parts if (p["band"], p["theta"]) == (row["band"], row["theta"])]
        assert sum(p["n"] for p in mine) == row["n"]
        if "detector" in row and all("detector" in p for p in mine):
            for key in ("detector", "pem"):
                mixed = sum(p[key] * p["n"] for p in mine) / row["n"]
                assert mixed == pytest.approx(row[key], abs=2e-4)


def test_a_miss_confined_to_one_group_shows_in_that_group() -> None:
    """Runs from the left scored 1.5 logit lower than the PEM says: split by approach,
    the left's close cells are off significantly, the other sides' are within the
    tolerance; split by view (which the miss does not follow) no group is as far off."""
    data = {"car": _frames(2, left_shift=-1.5)}
    rng = np.random.default_rng(0)
    rows = fc.check_frames(data, {"car": PARAMS}, rng=rng, split="approach")
    judged = [r for r in rows if "ok" in r]
    left = [r for r in judged if r["group"] == "from left"]
    assert any(r["significant"] and r["difference"] > 0 for r in left), fc.table_lines(rows)
    assert all(r["ok"] for r in judged if r["group"] != "from left"), fc.table_lines(rows)
    worst_left = max(r["difference"] for r in left)
    by_view = fc.check_frames(data, {"car": PARAMS}, split="view")
    assert max(r.get("difference", 0.0) for r in by_view) < 0.8 * worst_left


@pytest.mark.parametrize(
    ("values", "group"),
    [
        ({"precipitation": 0.0, "wind_intensity": 100.0}, "dry"),
        ({"precipitation": 30.0, "wind_intensity": 40.0}, "calm rain"),
        ({"precipitation": 100.0, "wind_intensity": 50.0}, "windy rain"),
        ({"precipitation": 100.0}, "unknown"),
    ],
)
def test_the_wind_split_puts_a_rainy_run_by_its_wind(values: dict, group: str) -> None:
    """The wind slants only the rain (camera mode): a dry run is dry at any wind; a rainy
    one is windy from :data:`fc.WINDY`; a run without both elements is unknown."""
    split, groups = fc.SPLITS["wind"]
    assert split(None, {"values": values}) == group and group in groups


@pytest.mark.parametrize(
    ("view_deg", "facing", "group"),
    [
        (10.0, -0.98, "head-on front"),
        (30.0, -0.87, "oblique front"),
        (80.0, -0.17, "side"),
        (80.0, 0.17, "side"),
        (50.0, 0.64, "oblique rear"),
        (0.0, 1.0, "head-on rear"),
    ],
)
def test_the_angle_split_puts_a_frame_by_its_view(view_deg: float, facing: float, group: str):
    """Within 22.5 degrees of the front or rear: head-on; within 22.5 of side-on: side;
    between: oblique, front or rear by the facing's sign."""
    feats = PEMFeatures(100.0, math.radians(view_deg), 0.0, facing=facing)
    split, groups = fc.SPLITS["angle"]
    assert split(feats, {}) == group and group in groups


@pytest.mark.parametrize(
    ("height", "group"),
    [(12.0, "0-60 px"), (60.0, "60-80 px"), (79.9, "60-80 px"), (80.0, "80-100 px"),
     (149.0, "100-150 px"), (150.0, "150-300 px"), (300.0, ">= 300 px"), (4000.0, ">= 300 px")],
)  # fmt: skip
def test_the_size_split_puts_a_frame_by_its_box_height(height: float, group: str) -> None:
    """Each bin holds its lower edge; the last is open above."""
    split, groups = fc.SPLITS["size"]
    assert split(PEMFeatures(height, 0.5, 0.0), {}) == group and group in groups


def test_check_by_prints_a_group_column_and_names_a_wrong_split(tmp_path: Path, capsys) -> None:
    """``sitcov calibrate --check FILE --check-by rain``: a row per group (dry, light and
    heavy rain); an unknown split is one error line, exit 2."""
    from sitcov.cli import main

    frames = tmp_path / "frames.jsonl"
    write_frames(frames, {"car": _frames(3, runs=12)})
    args = ["calibrate", "--check", str(frames), "--kinds", "car"]
    try:
        main([*args, "--check-by", "rain"])
    except SystemExit as exc:  # 1 when a cell is off: the table is printed either way
        assert exc.code == 1
    out = capsys.readouterr().out
    assert " group " in out.splitlines()[0]
    for group in ("dry", "light rain", "heavy rain"):
        assert f" {group} " in out
    with pytest.raises(SystemExit) as exc:
        main([*args, "--check-by", "colour"])
    err = capsys.readouterr().err.strip()
    assert exc.value.code == 2 and err.count("\n") == 0 and "approach | view" in err


def test_an_unknown_split_names_the_ones_there_are() -> None:
    with pytest.raises(SitcovError, match="approach, view, angle, rain, wind, cut"):
        fc.check_frames({"car": _frames(4, runs=3)}, {"car": PARAMS}, split="colour")
