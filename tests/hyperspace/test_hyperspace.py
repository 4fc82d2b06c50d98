from __future__ import annotations

import itertools
import json

import numpy as np
import pytest

from sitcov.errors import ConfigError
from sitcov.hyperspace import Hyperspace, Situation, load_hyperspace

ENV = [
    "cloudiness",
    "precipitation",
    "precipitation_deposits",
    "wind_intensity",
    "fog_density",
    "fog_distance",
    "wetness",
]
# The paper's Table 1, typed in again here: label -> (ego, ov, conflict)
INTSITS = {
    1: ("L-B", "R-B", "c4"),
    2: ("L-R", "R-B", "c4"),
    3: ("L-R", "B-R", "c1"),
    4: ("L-R", "B-L", "c1"),
    5: ("B-L", "L-R", "c1"),
    6: ("B-L", "R-L", "c2"),
    7: ("B-L", "R-B", "c2"),
    8: ("B-R", "L-R", "c1"),
    9: ("R-L", "B-L", "c2"),
    10: ("R-B", "B-L", "c2"),
    11: ("R-B", "L-R", "c4"),
    12: ("R-B", "L-B", "c4"),
}


def test_default_is_the_papers_hyperspace():
    hs = load_hyperspace()
    assert hs.name == "t-junction"
    assert hs.element_names == (*ENV, "friction", "intsit")
    assert [a.name for a in hs.axes] == ["environment", "intersection"]
    for name in ENV:
        el = hs.element(name)
        assert el.labels == ("0", "20", "40", "60", "80", "100")
        assert [b.value for b in el.bins] == [0.0, 20.0, 40.0, 60.0, 80.0, 100.0]
        assert el.carla_field == name and el.unit and el.axis == "environment"
    friction = hs.element("friction")
    assert friction.labels == ("0.1", "0.2", "0.4", "0.6", "0.8", "1.0")
    assert [b.value for b in friction.bins] == [0.1, 0.2, 0.4, 0.6, 0.8, 1.0]
    assert "FrictionTrigger" in friction.carla_field
    intsit = hs.element("intsit")
    assert intsit.labels == tuple(f"IntSit-{i}" for i in range(1, 13))
    for i, (ego, ov, conflict) in INTSITS.items():
        assert dict(intsit.bins[i - 1].value) == {"ego": ego, "ov": ov, "conflict": conflict}
    assert hs.n_situations == 6**8 * 12
    assert load_hyperspace("t-junction") == hs


def test_to_dict_round_trip_through_json():
    hs = load_hyperspace()
    again = Hyperspace.from_dict(json.loads(json.dumps(hs.to_dict())))
    assert again == hs
    assert again.to_dict() == hs.to_dict()


def _write(tmp_path, text: str, name: str = "hs.yaml"):
    path = tmp_path / name
    path.write_text(text)
    return path


TINY = """
name: tiny
axes:
  - name: a
    elements:
      - name: speed
        unit: m/s
        bins: [{value: 1}, {value: 2.5}, {label: fast, range: [10, 20]}]
      - name: weather
        bins: [{value: dry}, {value: wet}]
      - name: route
        metadata: {anything: [1, 2]}
        bins:
          - {label: r1, value: {ego: L-B}}
          - {label: r2, value: {ego: "L-R"}}
constraints:
  - forbid: {weather: [wet], route: [r2]}
  - forbid: {speed: [fast], weather: [wet]}
"""


def test_yaml_file_points_categories_ranges(tmp_path):
    hs = load_hyperspace(_write(tmp_path, TINY))
    assert hs.labels("speed") == ("1", "2.5", "fast")
    assert hs.labels("weather") == ("dry", "wet")
    assert hs.element("route").metadata == {"anything": [1, 2]}
    s1 = hs.situation_from_bins(
        {"speed": "fast", "weather": "dry", "route": "r1"}, np.random.default_rng(3)
    )
    s2 = hs.situation_from_bins(
        {"speed": "fast", "weather": "dry", "route": "r1"}, np.random.default_rng(3)
    )
    assert s1 == s2 and 10.0 <= s1.values["speed"] < 20.0
    s3 = hs.situation_from_bins(
        {"speed": "fast", "weather": "dry", "route": "r1"}, np.random.default_rng(4)
    )
    assert s3.values["speed"] != s1.values["speed"]
    point = hs.situation_from_bins({"speed": "2.5", "weather": "wet", "route": "r1"})
    assert point.values["speed"] == 2.5 and point.values["weather"] == "wet"
    with pytest.raises(ConfigError, match="rng"):
        hs.situation_from_bins({"speed": "fast", "weather": "dry", "route": "r1"})
    with pytest.raises(ConfigError, match="bins.route"):
        hs.situation_from_bins({"speed": "1", "weather": "dry", "route": "r9"})


def test_constraints_counting_matches_brute_force(tmp_path):
    hs = load_hyperspace(_write(tmp_path, TINY))
    combos = list(itertools.product(*(hs.labels(n) for n in hs.element_names)))
    allowed = [c for c in combos if hs.is_allowed(dict(zip(hs.element_names, c, strict=False)))]
    # by hand: 3*2*2 = 12; wet&r2 forbids 3; fast&wet forbids 2, one of them shared -> 8
    assert len(allowed) == 8 == hs.n_situations
    assert not hs.is_allowed({"weather": "wet", "route": "r2"})  # partial mapping
    assert hs.is_allowed({"weather": "wet"})
    assert hs.count({"weather": ["wet"]}) == sum(1 for c in allowed if c[1] == "wet")
    # allowed pairs: pairs appearing in at least one allowed situation
    brute = set()
    for c in allowed:
        idx = [hs.labels(n).index(x) for n, x in zip(hs.element_names, c, strict=False)]
        for e1, e2 in itertools.combinations(range(3), 2):
            brute.add((e1, idx[e1], e2, idx[e2]))
    assert hs.allowed_pairs == brute
    assert len(brute) == 6 + 6 + 4 - 2  # (fast,wet) and (wet,r2) are impossible


def test_n_situations_with_overlapping_constraints_on_default():
    d = load_hyperspace().to_dict()
    d["constraints"] = [
        {"forbid": {"friction": ["0.1"], "intsit": ["IntSit-3"]}},
        {"forbid": {"friction": ["0.1", "0.2"], "intsit": ["IntSit-3", "IntSit-4"]}},
        {"forbid": {"fog_density": ["100"], "intsit": ["IntSit-3"]}},
    ]
    hs = Hyperspace.from_dict(d)
    # independent: count forbidden (friction, fog_density, intsit) triples by enumeration
    rest = 6**6
    forbidden = 0
    for f, fog, i in itertools.product(
        hs.labels("friction"), hs.labels("fog_density"), hs.labels("intsit")
    ):
        if not hs.is_allowed({"friction": f, "fog_density": fog, "intsit": i}):
            forbidden += 1
    assert hs.n_situations == 6**8 * 12 - forbidden * rest


def test_fast_situation_id_equals_situation_id(tmp_path):
    hs = load_hyperspace(_write(tmp_path, TINY.replace("dry", '"dr\\u00ff"')))
    rng = np.random.default_rng(0)
    for idx in itertools.product(range(3), range(2), range(2)):
        fast = hs._situation(list(idx), rng)
        slow = Situation(dict(fast.bins), json.loads(json.dumps(fast.to_dict()["values"])))
        assert fast.id == slow.id
        assert Situation.from_dict(fast.to_dict()) == fast
    default = load_hyperspace()
    s = default._situation([0, 1, 2, 3, 4, 5, 0, 1, 11])
    assert s.id == Situation(dict(s.bins), s.to_dict()["values"]).id


def test_element_lookup_errors_name_the_choices():
    hs = load_hyperspace()
    with pytest.raises(ConfigError, match="friction"):
        hs.element("frction")


def test_hyperspace_and_elements_pickle():
    import pickle

    hs = load_hyperspace()
    again = pickle.loads(pickle.dumps(hs))
    assert again == hs and again.n_situations == hs.n_situations
    intsit = pickle.loads(pickle.dumps(hs.element("intsit")))
    assert intsit == hs.element("intsit") and intsit.bins[0].value["conflict"] == "c4"
