"""The OpenDRIVE reader against esmini's ``odrplot`` on the same files: every lane's outer
border (odrplot samples each lane half its width outwards from its centre line) within
0.05 m, on CARLA's Town03 (lines and arcs) and on ``geometries.xodr`` (every plan-view
record type, lane offsets, cubic widths, several lane sections and lane types).

odrplot samples each lane section every ~1 m from its start to its end; the sample at the
very end of a section is evaluated by esmini in the following section (or, for a road
shorter than a step, elsewhere), so those end samples are not compared.
"""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

from sitcov.roads import read_opendrive
from tests.roads._shared import DATA, odrplot, town03

TOLERANCE = 0.05  # [m]


def _odrplot_lanes(xodr: Path, tmp_path: Path) -> dict[tuple[str, int, int], np.ndarray]:
    """odrplot's CSV: ``lane, ROAD_ID, SECTION_INDEX, LANE_ID, driving|no-driving`` headers,
    each followed by ``x, y, z, h`` rows."""
    out = tmp_path / "odrplot.csv"
    subprocess.run([odrplot(), str(xodr), str(out)], check=True, capture_output=True, timeout=120)
    lanes: dict[tuple[str, int, int], list[list[float]]] = {}
    current: list[list[float]] = []
    for line in out.read_text().splitlines():
        if line.startswith("lane"):
            _, road, section, lane, _kind = (v.strip() for v in line.split(","))
            current = lanes.setdefault((road, int(section), int(lane)), [])
        elif line.strip():
            current.append([float(v) for v in line.split(",")])
    return {k: np.array(v) for k, v in lanes.items()}


def _deviations(xodr: Path, tmp_path: Path) -> np.ndarray:
    net = read_opendrive(xodr)
    worst = []
    for (road_id, index, lane_id), pts in _odrplot_lanes(xodr, tmp_path).items():
        if lane_id == 0:
            continue
        road = net.roads[road_id]
        s0, s1 = road.sections[index].s, road.section_end(index)
        steps = int((s1 - s0) / 1.0)
        step = (s1 - s0) / steps if steps > 0 else s1 - s0
        s = np.minimum(s1, s0 + np.arange(steps + 1) * step)[:-1]
        x, y, _ = road.points(index, lane_id, s, where=1.0)
        worst.append(np.hypot(x - pts[: len(s), 0], y - pts[: len(s), 1]))
    return np.concatenate(worst)


@pytest.mark.parametrize("name", ["geometries.xodr", "t-junction.xodr"])
def test_test_files_match_odrplot(name: str, tmp_path: Path) -> None:
    dev = _deviations(DATA / name, tmp_path)
    assert len(dev) > 500
    assert dev.max() < TOLERANCE


@pytest.mark.slow
def test_town03_matches_odrplot(tmp_path: Path) -> None:
    dev = _deviations(town03(), tmp_path)
    assert len(dev) > 50_000
    assert dev.max() < TOLERANCE


def test_every_geometry_type_is_in_the_test_file() -> None:
    net = read_opendrive(DATA / "geometries.xodr")
    kinds = {type(g).__name__ for g in net.roads["1"].plan_view.records}
    assert kinds == {"Line", "Arc", "Spiral", "ParamPoly3"}  # poly3 is a ParamPoly3
    assert len(net.roads["1"].plan_view.records) == 7
