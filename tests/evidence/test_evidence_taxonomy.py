"""ODD attributes of hyperspace elements, and ODD files."""

from __future__ import annotations

from importlib import resources

import pytest

from sitcov.errors import ConfigError
from sitcov.evidence import Taxonomy, load_odd
from sitcov.hyperspace import Hyperspace, load_hyperspace

DERIVED = sorted(
    p.name
    for p in resources.files("sitcov.hyperspace").joinpath("data/derived").iterdir()
    if p.name.endswith(".yaml")
)


def _hyperspaces():
    yield load_hyperspace()
    for name in DERIVED:
        path = resources.files("sitcov.hyperspace").joinpath("data/derived", name)
        yield load_hyperspace(str(path))


@pytest.mark.parametrize("hs", list(_hyperspaces()), ids=lambda h: h.name)
def test_every_shipped_element_has_an_attribute_and_a_junction(hs):
    tax = Taxonomy(hs)
    assert tax.unmapped == []
    assert tax.junction is not None
    situation = hs.situation_from_bins({e.name: e.labels[-1] for e in hs.elements})
    attrs = tax.attributes(situation)
    paths = {a.attribute for a in attrs}
    assert "scenery.junction.type" in paths
    assert "dynamic_elements.traffic.agent_type" in paths
    assert all(a.openlabel for a in attrs if a.element in tax.specs)


def test_quantities_follow_the_physics():
    tax = Taxonomy(load_hyperspace())
    # denser fog, less visibility; more rain, more mm/h; classes in physical order
    vis = [tax.quantity("fog_density", v) for v in (0, 20, 60, 100)]
    assert vis[0] == float("inf") or vis[0] > 1000
    assert vis == sorted(vis, reverse=True)
    assert tax.category("fog_density", 100) == "dense_fog"
    assert tax.category("fog_density", 0) == "clear"
    assert [tax.category("precipitation", v) for v in (0, 4, 14, 100)] == [
        "none",
        "light",
        "moderate",
        "heavy",
    ]
    assert tax.quantity("precipitation", 100) == pytest.approx(50.0)
    assert [tax.category("friction", v) for v in (0.1, 0.2, 0.6, 1.0)] == [
        "icy",
        "snow",
        "wet",
        "dry",
    ]
    assert (
        tax.category("cloudiness", 100) == "overcast" and tax.category("cloudiness", 0) == "clear"
    )
    winds = [tax.quantity("wind_intensity", v) for v in (0, 50, 100)]
    assert winds == sorted(winds) and winds[0] == 0.0


def _with_odd_metadata(odd):
    data = load_hyperspace().to_dict()
    for axis in data["axes"]:
        for el in axis["elements"]:
            if el["name"] == "friction":
                el.setdefault("metadata", {})["odd"] = odd
    return Hyperspace.from_dict(data)


def test_a_hyperspace_overrides_the_shipped_attribute():
    hs = _with_odd_metadata(
        {
            "attribute": "scenery.drivable_area.surface.mu",
            "openlabel": "DrivableAreaSurface",
            "quantity": {"unit": "-", "scale": 1.0},
            "categories": {"classes": [{"label": "low", "max": 0.5}, {"label": "high"}]},
        }
    )
    tax = Taxonomy(hs)
    assert tax.specs["friction"].attribute == "scenery.drivable_area.surface.mu"
    assert tax.category("friction", 0.4) == "low" and tax.category("friction", 0.8) == "high"


def test_a_bad_override_names_the_element_and_field():
    hs = _with_odd_metadata({"attribute": "x", "openlabel": "Y", "quantity": {"from": "nope"}})
    with pytest.raises(ConfigError, match=r"friction\.metadata\.odd\.quantity\.from"):
        Taxonomy(hs)


def test_odd_permissive_and_restrictive(tmp_path):
    tax = Taxonomy(load_hyperspace())
    wet_fog = load_hyperspace().situation_from_bins(
        {
            "friction": "0.4",
            "fog_density": "100",
            "precipitation": "0",
            "cloudiness": "0",
            "precipitation_deposits": "0",
            "wind_intensity": "0",
            "fog_distance": "0",
            "wetness": "0",
            "intsit": "IntSit-1",
        }
    )
    attrs = tax.attributes(wet_fog)
    path = tmp_path / "odd.yaml"
    path.write_text("name: t\nattributes:\n  environment.particulates.visibility: {min: 200}\n")
    inside, reasons = load_odd(path).contains(attrs)
    assert not inside and "visibility" in reasons[0] and "dense_fog" in reasons[0]
    path.write_text(
        "name: t\napproach: restrictive\nattributes:\n  scenery.junction.type: {in: [t_junction]}\n"
    )
    inside, reasons = load_odd(path).contains(attrs)
    assert not inside and len(reasons) == len(attrs) - 1  # every attribute but the junction
    path.write_text(
        "name: t\nattributes:\n  scenery.drivable_area.surface_condition.friction:"
        " {in: [wet, dry]}\n  environment.weather.rainfall: {max: 7.6}\n"
    )
    assert load_odd(path).contains(attrs) == (True, [])


@pytest.mark.parametrize(
    "text,field",
    [
        ("name: t\nattributes:\n  a.b: {}\n", "attributes.a.b"),
        ("name: t\nattributes:\n  a.b: {min: 3, max: 1}\n", "attributes.a.b"),
        ("name: t\napproach: sometimes\n", "approach"),
        ("name: t\nattribute: {}\n", "attribute"),
        ("- a\n- b\n", "(top level)"),
    ],
)
def test_odd_file_errors_name_file_and_field(tmp_path, text, field):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as err:
        load_odd(path)
    assert str(path) in str(err.value) and field in str(err.value)


def test_missing_odd_file_is_one_clear_error(tmp_path):
    with pytest.raises(ConfigError, match="an existing ODD file"):
        load_odd(tmp_path / "none.yaml")
