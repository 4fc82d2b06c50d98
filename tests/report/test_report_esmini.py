"""The report of an esmini campaign draws its OpenDRIVE road: the pictured failing runs,
their animations, the collision map and ``sitcov animate`` (examples/esmini/crossing.xosc
on examples/esmini/straight.xodr: driving lanes and sidewalks).

Needs esmini (``SITCOV_ESMINI`` or ``SITCOV_ESMINI_LIB``; CI sets it to the shared build):
skipped locally without it, a failure in CI (tests/needs.py).
"""

from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from needs import need_esmini_library

from sitcov.report._road import GRASS, ROAD, SIDEWALK

need_esmini_library()

ROOT = Path(__file__).resolve().parents[2]
EXAMPLES = ROOT / "examples" / "esmini"

#: The crossing car starts when the ego is 17 m from the crossing at 8 m/s: it hits the
#: reference stack's ego (tests/sim/esmini: test_trigger_distance_decides_a_collision).
HYPERSPACE = """name: crossing-hits
axes:
  - name: scenario
    elements:
      - name: TriggerDistance
        bins: [{value: 17}]
      - name: CrossingSpeed
        bins: [{value: 8}]
      - name: OncomingSpeed
        bins: [{label: slow, value: 5}, {label: fast, value: 14}]
constraints: []
"""


def _share(png: bytes | Path, colour: str) -> float:
    """Share of the image's pixels that are exactly ``colour``."""
    from PIL import Image

    data = png.read_bytes() if isinstance(png, Path) else png
    rgb = np.asarray(Image.open(io.BytesIO(data)).convert("RGB")).reshape(-1, 3)
    want = [int(colour[i : i + 2], 16) for i in (1, 3, 5)]
    return float(np.mean(np.all(rgb == want, axis=1)))


@pytest.fixture(scope="module")
def campaign(tmp_path_factory) -> Path:
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    root = tmp_path_factory.mktemp("esmini-report")
    (root / "hits.yaml").write_text(HYPERSPACE)
    config = CampaignConfig(
        name="crossing",
        hyperspace=str(root / "hits.yaml"),
        backend="esmini",
        backend_options={"scenario": str(EXAMPLES / "crossing.xosc")},
        runs=3,
        seed=3,
        workers=1,
        executor="processes",
    )
    db = root / "c.db"
    with open_store(db) as store:
        run_campaign(config, store)
        failed = [r for r in store.iter_runs("crossing") if r.status == "fail"]
    assert failed, "the crossing car should hit the ego"
    return db


def test_the_report_pictures_the_failing_runs_on_the_road(campaign: Path, tmp_path: Path) -> None:
    from sitcov.report import build_report

    html = build_report(campaign, tmp_path / "out", pictures=2).read_text()
    pictures = sorted((tmp_path / "out" / "figures").glob("failure_*.png"))
    assert pictures and "Not drawn" not in html
    for png in pictures:
        # the straight road's lanes and sidewalks under the actors, grass around
        assert _share(png, ROAD) > 0.01 and _share(png, SIDEWALK) > 0.002
        assert _share(png, GRASS) > 0.2
    assert "data:image/gif;base64," in html  # the failing runs' animations
    collisions = tmp_path / "out" / "figures" / "collision_map.png"
    assert collisions.is_file()
    assert _share(collisions, ROAD) > 0.05 and _share(collisions, SIDEWALK) > 0.02


def test_sitcov_animate_draws_the_road(campaign: Path, tmp_path: Path) -> None:
    from PIL import Image

    from sitcov.campaign import open_store
    from sitcov.report._animate import animate_run

    with open_store(campaign) as store:
        run = next(r for r in store.iter_runs("crossing") if r.status == "fail")
    out = animate_run(campaign, f"crossing:{run.index}", tmp_path / "run.gif")
    gif = Image.open(out)
    assert gif.n_frames > 10
    gif.seek(gif.n_frames - 1)
    frame = io.BytesIO()
    gif.convert("RGB").save(frame, format="PNG")
    # the GIF's palette shifts colours a little: count pixels near the road's grey
    rgb = np.asarray(Image.open(frame).convert("RGB")).reshape(-1, 3).astype(int)
    near = np.abs(rgb - [int(ROAD[i : i + 2], 16) for i in (1, 3, 5)]).max(axis=1) <= 6
    assert near.mean() > 0.005
