from __future__ import annotations

import subprocess
import sys

import pytest

from sitcov.hyperspace import Situation


def test_id_is_stable_across_processes():
    code = (
        "from sitcov.hyperspace import Situation;"
        "print(Situation({'f':'0.4','i':'IntSit-3'},{'f':0.4,'i':{'ego':'L-R'}}).id)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    here = Situation({"f": "0.4", "i": "IntSit-3"}, {"f": 0.4, "i": {"ego": "L-R"}})
    assert out.stdout.strip() == here.id


def test_id_depends_on_values_and_bins():
    a = Situation({"f": "lo"}, {"f": 0.1})
    assert a.id != Situation({"f": "lo"}, {"f": 0.2}).id
    assert a.id != Situation({"f": "hi"}, {"f": 0.1}).id
    assert a == Situation({"f": "lo"}, {"f": 0.1})


def test_situation_is_immutable_and_roundtrips():
    s = Situation({"i": "IntSit-1"}, {"i": {"ego": ["L", "B"]}})
    with pytest.raises(TypeError):
        s.values["i"]["ego"] = "x"  # type: ignore[index]
    assert Situation.from_dict(s.to_dict()) == s
    assert s.to_dict()["values"]["i"]["ego"] == ["L", "B"]


def test_mismatched_elements_rejected():
    with pytest.raises(ValueError):
        Situation({"a": "x"}, {"b": 1})
