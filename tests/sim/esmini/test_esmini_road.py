"""The cropped road of the esmini backend: the roads a run comes near, the rest dropped.

No esmini needed: these read and write OpenDRIVE text only (the outcomes on a cropped
Town03 are compared with the whole road's in test_esmini_backend.py).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

from sitcov.roads._writer import xodr_text
from sitcov.sim.embedded import load_map
from sitcov.sim.embedded._odr import road_network
from sitcov.sim.esmini._road import _samples, crop


def _roads(text: str) -> dict[str, ET.Element]:
    return {r.get("id", ""): r for r in ET.fromstring(text).iter("road")}


def test_samples_follow_lines_and_arcs() -> None:
    """A quarter circle of radius 10 m from the origin heading east ends at (10, 10)."""
    g = ET.fromstring(
        '<geometry s="0" x="0" y="0" hdg="0" length="15.707963"><arc curvature="0.1"/></geometry>'
    )
    end = list(_samples(g))[-1]
    assert math.dist(end, (10.0, 10.0)) < 1e-5
    line = ET.fromstring(
        '<geometry s="0" x="1" y="2" hdg="1.5707963" length="20"><line/></geometry>'
    )
    pts = list(_samples(line))
    assert len(pts) == 5 and math.dist(pts[-1], (1.0, 22.0)) < 1e-5


def test_crop_keeps_the_roads_near_the_points_unchanged_and_drops_the_rest() -> None:
    network, ids = road_network(load_map("t-junction"))
    text = xodr_text(network)
    full = _roads(text)
    # a point at the outer end of leg B's road, far from the junction and the other legs
    road = full[str(ids.legs["B"])]
    x, y = list(_samples(road.findall("planView/geometry")[-1]))[-1]
    out = crop(text, [(x, y)], margin=5.0)
    kept = _roads(out)
    assert road.get("id") in kept and len(kept) < len(full)
    for rid, r in kept.items():  # byte for byte the original's geometry and lanes
        assert ET.tostring(r.find("planView")) == ET.tostring(full[rid].find("planView"))
        assert ET.tostring(r.find("lanes")) == ET.tostring(full[rid].find("lanes"))
        for end in r.iterfind("link/*"):  # no link to a road that is gone
            if end.get("elementType") == "road":
                assert end.get("elementId") in kept
    for junction in ET.fromstring(out).iter("junction"):
        for conn in junction.iter("connection"):
            assert conn.get("incomingRoad") in kept and conn.get("connectingRoad") in kept


def test_a_wide_margin_keeps_everything() -> None:
    network, _ = road_network(load_map("t-junction"))
    text = xodr_text(network)
    assert set(_roads(crop(text, [(0.0, 0.0)], margin=1000.0))) == set(_roads(text))
