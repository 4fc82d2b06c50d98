"""Every shipped map as OpenDRIVE: valid against the ASAM schema, loaded by esmini, and its
lanes where sitcov's lanes are (sampled by esmini's own ``odrplot``)."""

from __future__ import annotations

import subprocess

import numpy as np
import pytest
from needs import need_esmini, need_module, need_schema

from sitcov.roads import write_xodr
from sitcov.sim.embedded import load_map
from sitcov.sim.embedded._map import MAPS_DIR
from sitcov.sim.embedded._odr import road_network

MAPS = sorted(p.stem for p in MAPS_DIR.glob("*.yaml"))


def _odrplot_centres(csv: str) -> dict[tuple[int, int], np.ndarray]:
    """odrplot's samples are lane borders (the outer one of each lane): centre lines are
    the mean of a lane's border and the next one inwards."""
    borders: dict[tuple[int, int], list[list[float]]] = {}
    key = None
    for line in csv.splitlines():
        if line.startswith("lane"):
            _, road, _, lane, _ = (f.strip() for f in line.split(","))
            key = (int(road), int(lane))
            borders[key] = []
        elif line.strip():
            borders[key].append([float(v) for v in line.split(",")[:2]])
    arr = {k: np.asarray(v) for k, v in borders.items()}
    return {
        (r, lane): 0.5 * (v + arr[(r, lane - (1 if lane > 0 else -1))])
        for (r, lane), v in arr.items()
        if lane != 0
    }


def _distance(points: np.ndarray, poly) -> np.ndarray:
    """Distance of each point to the polyline ``poly`` [m]."""
    poly = np.asarray(poly, dtype=float)
    poly = poly[np.r_[True, np.hypot(*np.diff(poly, axis=0).T) > 1e-9]]  # no empty segments
    a, ab = poly[:-1], np.diff(poly, axis=0)
    t = ((points[:, None, :] - a[None]) * ab[None]).sum(-1) / (ab * ab).sum(-1)[None]
    q = a[None] + np.clip(t, 0.0, 1.0)[..., None] * ab[None]
    return np.sqrt(((points[:, None, :] - q) ** 2).sum(-1)).min(axis=1)


@pytest.mark.parametrize("name", MAPS)
def test_map_network_covers_every_movement(name):
    jmap = load_map(name)
    network, ids = road_network(jmap)
    assert set(ids.movements) == set(jmap.movements)
    assert set(ids.legs) == set(jmap.legs)
    (junction,) = network.junctions
    assert {c.connecting for c in junction.connections} == set(ids.movements.values())
    sidewalk = [lane for r in network.roads for lane in r.lanes if lane.type == "sidewalk"]
    assert bool(sidewalk) == bool(jmap.render_geometry()["sidewalks"])


@pytest.mark.parametrize("name", MAPS)
def test_exported_map_is_valid_opendrive(name, tmp_path):
    xmlschema = need_module("xmlschema", "test")
    schema = xmlschema.XMLSchema(str(need_schema("OpenDRIVE_1.4H.xsd")))
    path = write_xodr(road_network(load_map(name))[0], tmp_path / f"{name}.xodr")
    assert list(schema.iter_errors(str(path))) == []


@pytest.mark.parametrize("name", MAPS)
def test_esmini_samples_the_lanes_where_sitcov_has_them(name, tmp_path):
    """Lane centre lines within 0.01 m of sitcov's (the polylines' chords sag < 5 mm)."""
    odrplot = need_esmini("odrplot")
    jmap = load_map(name)
    network, ids = road_network(jmap)
    path = write_xodr(network, tmp_path / f"{name}.xodr")
    csv = tmp_path / "lanes.csv"
    subprocess.run([str(odrplot), str(path), str(csv), "0.5"], check=True, capture_output=True)
    centres = _odrplot_centres(csv.read_text())
    worst = 0.0
    for move, road in ids.movements.items():
        a, _, b = move.partition("-")
        lanes = jmap.lane_sequence(a, b)[1:-1]
        points = [p for lane in lanes for p in jmap.lane(lane).points]
        worst = max(worst, float(_distance(centres[(road, -1)], points).max()))
    checked = 0
    for leg, road in ids.legs.items():
        for lane, suffix in ((1, ".in"), (-1, ".out")):
            if f"{leg}{suffix}" in jmap.graph:
                d = _distance(centres[(road, lane)], jmap.lane(f"{leg}{suffix}").points)
                worst = max(worst, float(d.max()))
                checked += 1
    assert checked >= len(jmap.legs)
    assert worst < 0.01, f"{name}: a lane centre is {worst:.4f} m from sitcov's"


@pytest.mark.parametrize("name", ["crossroads", "roundabout", "merge"])
def test_movement_chains_put_every_lane_where_sitcov_has_it(name, tmp_path):
    """The network for maps with lanes per movement (an imported junction), built here
    from a shipped map: each movement's inbound, connecting and outbound lane."""
    from sitcov.sim.embedded._odr import _movement_chains

    odrplot = need_esmini("odrplot")
    jmap = load_map(name)
    network, ids = _movement_chains(jmap)
    assert ids.legs == {} and set(ids.movements) == set(jmap.movements)
    path = write_xodr(network, tmp_path / f"{name}.xodr")
    csv = tmp_path / "lanes.csv"
    subprocess.run([str(odrplot), str(path), str(csv), "0.5"], check=True, capture_output=True)
    centres = _odrplot_centres(csv.read_text())
    worst = 0.0
    for move in jmap.movements:
        a, _, b = move.partition("-")
        seq = jmap.lane_sequence(a, b)
        inner = [p for lane in seq[1:-1] for p in jmap.lane(lane).points]
        pairs = [
            (ids.entry[move], jmap.lane(seq[0]).points),
            (ids.exit[move], jmap.lane(seq[-1]).points),
        ]
        pairs.append(((ids.movements[move], -1), inner))
        for key, points in pairs:
            worst = max(worst, float(_distance(centres[key], points).max()))
    assert worst < 0.01, f"{name}: a lane centre is {worst:.4f} m from sitcov's"


def test_cli_export_xodr_writes_what_export_xosc_plays_on(tmp_path, capsys):
    from sitcov.cli import main
    from sitcov.roads import xodr_text

    out = tmp_path / "m.xodr"
    main(["export-xodr", "--map", "merge", "--out", str(out)])
    assert out.read_text() == xodr_text(road_network(load_map("merge"))[0])
    assert "2 movements" in capsys.readouterr().out
