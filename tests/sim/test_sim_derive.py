"""`sitcov hyperspace derive`: situations derived from a map's conflicting route pairs."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from sitcov.errors import ConfigError
from sitcov.hyperspace import Hyperspace, load_hyperspace
from sitcov.sim.embedded import load_map
from sitcov.sim.embedded._conflicts import conflict_type
from sitcov.sim.embedded._derive import derive_command, derive_hyperspace, dump_derived
from sitcov.sim.embedded._routes import actor_route

ROOT = Path(__file__).resolve().parents[2]
DERIVED = ROOT / "sitcov" / "hyperspace" / "data" / "derived"
SHIPPED = ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge")


def _intsit(doc: dict) -> list[dict]:
    return doc["axes"][1]["elements"][0]["bins"]


def test_t_junction_cars_crossing_and_merging_are_the_paper_s_twelve() -> None:
    doc = derive_hyperspace("t-junction", ["car"], 1, ["crossing", "merging"])
    paper = load_hyperspace().element("intsit").bins
    derived = _intsit(doc)
    assert [b["label"] for b in derived] == [b.label for b in paper]
    for mine, theirs in zip(derived, paper, strict=True):
        value = mine["value"]
        assert {k: value[k] for k in ("ego", "ov", "conflict")} == dict(theirs.value)
        assert value["kind"] == "car" and value["type"] in ("crossing", "merging")
    # the environment is the default hyperspace's, element for element
    default = load_hyperspace()
    hs = Hyperspace.from_dict(doc)
    for name in ("cloudiness", "fog_density", "friction"):
        assert hs.element(name).bins == default.element(name).bins


@pytest.mark.parametrize("name", SHIPPED)
def test_every_derived_situation_really_conflicts_with_its_type(name: str) -> None:
    doc = yaml.safe_load((DERIVED / f"{name}.yaml").read_text())
    jmap = load_map(name)
    bins = _intsit(doc)
    assert len({b["label"] for b in bins}) == len(bins)
    for b in bins[:: max(1, len(bins) // 40)]:  # a spread sample: the re-derivation checks all
        v = b["value"]
        actor = (
            jmap.ov_path(v["ov"]) if v["kind"] == "car" else actor_route(jmap, v["kind"], v["ov"])
        )
        assert conflict_type(jmap.ego_path(v["ego"]), actor, v["kind"]) == v["type"], b["label"]


@pytest.mark.parametrize(
    "name", [pytest.param(n, marks=pytest.mark.slow) if n != "t-junction" else n for n in SHIPPED]
)
def test_shipped_derived_hyperspace_is_reproduced(name: str) -> None:
    path = DERIVED / f"{name}.yaml"
    text = path.read_text()
    header = text.splitlines()[1].strip("# ").strip()
    assert header == derive_command(
        name,
        ["car", "cyclist", "pedestrian"],
        2,
        None,
        f"sitcov/hyperspace/data/derived/{name}.yaml",
    )
    doc = derive_hyperspace(name, ["car", "cyclist", "pedestrian"], 2)
    assert yaml.safe_load(text) == doc
    assert dump_derived(doc, header) == text


def test_actor_slot_constraints_forbid_impossible_combinations() -> None:
    hs = Hyperspace.from_dict(derive_hyperspace("t-junction", ["car", "pedestrian"], 3))
    base = {e.name: e.labels[0] for e in hs.elements}
    ok = {**base, "intsit": "IntSit-1", "actor2": "pedestrian:XLL", "actor3": "none"}
    assert hs.is_allowed(ok)  # L-B passes the crossing on its own approach
    assert not hs.is_allowed({**ok, "actor2": "pedestrian:XRL"})  # never meets L-B
    # IntSit-1's OV starts on leg R: another car from R would spawn on it
    assert "car:R-L" in hs.labels("actor2")
    assert not hs.is_allowed({**ok, "actor2": "car:R-L"})
    assert hs.is_allowed({**ok, "actor2": "car:B-L"}) is False  # B-L never meets L-B
    assert hs.is_allowed({**ok, "actor2": "car:L-R"})  # queued ahead on the ego's lane
    # two slots never start at the same place, and fill in order
    assert not hs.is_allowed({**ok, "actor3": "pedestrian:XLL"})
    assert hs.is_allowed({**ok, "actor3": "pedestrian:XBL"})
    assert not hs.is_allowed({**ok, "actor2": "none", "actor3": "pedestrian:XBL"})
    assert hs.n_situations > 0


def test_merge_has_no_pedestrians_and_bad_options_fail() -> None:
    doc = derive_hyperspace("merge", ["car", "pedestrian"], 1)
    assert {b["value"]["kind"] for b in _intsit(doc)} == {"car"}
    assert {b["value"]["type"] for b in _intsit(doc)} == {"merging", "following"}
    with pytest.raises(ConfigError, match="actors"):
        derive_hyperspace("t-junction", ["bus"])
    with pytest.raises(ConfigError, match="conflicts"):
        derive_hyperspace("t-junction", ["car"], 1, ["sideswipe"])
    with pytest.raises(ConfigError, match="max_actors"):
        derive_hyperspace("t-junction", ["car"], 0)
    with pytest.raises(ConfigError, match="actors"):
        derive_hyperspace("merge", ["pedestrian"])  # nothing conflicts


def _sitcov(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", "from sitcov.cli import main; main()", *args],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )


def test_cli_derive_writes_a_loadable_hyperspace(tmp_path) -> None:
    out = tmp_path / "t.yaml"
    result = _sitcov(
        "hyperspace",
        "derive",
        "--map",
        "t-junction",
        "--conflicts",
        "crossing,merging",
        "--out",
        str(out),
    )
    assert result.returncode == 0, result.stderr
    assert "12 intersection situations" in result.stderr
    assert out.read_text().startswith("# Derived")
    assert load_hyperspace(out).labels("intsit") == load_hyperspace().labels("intsit")
    bad = _sitcov("hyperspace", "derive", "--actors", "car,bus")
    assert bad.returncode == 2 and "actors" in bad.stderr and "Traceback" not in bad.stderr
