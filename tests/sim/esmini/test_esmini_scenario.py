"""The scenario file layer of the esmini backend: parameters, ego, the XML given to esmini.

No esmini needed: these read and write OpenSCENARIO text only.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from pathlib import Path

import pytest

from sitcov.campaign._config import run_overrides
from sitcov.errors import ConfigError, SetupError
from sitcov.sim.esmini import ScenarioFile, find_library, scenario_files
from sitcov.sim.esmini._scenario import write_environment

EXAMPLES = Path(__file__).resolve().parents[3] / "examples" / "esmini"
CROSSING = EXAMPLES / "crossing.xosc"


def test_declarations_and_ego_are_read_from_the_file() -> None:
    file = ScenarioFile(CROSSING)
    assert set(file.declarations) == {"TriggerDistance", "CrossingSpeed", "OncomingSpeed"}
    assert file.declarations["TriggerDistance"].type == "double"
    assert file.ego == "Ego"
    assert file.has_environment
    assert file.environment_friction() == 1.0
    assert file.road_file() == EXAMPLES / "straight.xodr"


def test_unknown_element_is_one_error_naming_file_and_element() -> None:
    file = ScenarioFile(CROSSING)
    file.check_names(["TriggerDistance", "fog_density", "friction"])
    with pytest.raises(ConfigError) as err:
        file.check_names(["TriggerDistance", "TrigerDistance"])
    text = str(err.value)
    assert str(CROSSING) in text and "'TrigerDistance'" in text and "TriggerDistance" in text
    assert "\n" not in text


def test_render_sets_parameters_paths_and_the_external_ego() -> None:
    file = ScenarioFile(CROSSING)
    xml = file.render({"TriggerDistance": 17.25, "CrossingSpeed": 8, "fog_density": 50})
    root = ET.fromstring(xml)
    decl = {d.get("name"): d.get("value") for d in root.iter("ParameterDeclaration")}
    assert float(decl["TriggerDistance"]) == 17.25 and float(decl["CrossingSpeed"]) == 8.0
    assert decl["OncomingSpeed"] == "10.0"  # not set: the file's default stays
    assert root.find("RoadNetwork/LogicFile").get("filepath") == str(EXAMPLES / "straight.xodr")
    ego = [p for p in root.iter("Private") if p.get("entityRef") == "Ego"]
    props = [p.get("value") for p in ego[0].iter("Property") if p.get("name") == "esminiController"]
    assert props == ["ExternalController"]
    # the teleport still comes first, so the ego starts where the file puts it
    kinds = [child[0].tag for child in ego[0]]
    assert kinds.index("TeleportAction") < kinds.index("ControllerAction")
    # the source file is untouched
    assert "ExternalController" not in CROSSING.read_text()


def test_render_with_a_road_replaces_the_file_s_road(tmp_path: Path) -> None:
    road = tmp_path / "other.xodr"
    road.write_text("<OpenDRIVE/>")
    xml = ScenarioFile(CROSSING).render({}, road=road)
    assert ET.fromstring(xml).find("RoadNetwork/LogicFile").get("filepath") == str(road)


def test_a_value_of_the_wrong_type_names_the_parameter() -> None:
    file = ScenarioFile(CROSSING)
    with pytest.raises(ConfigError, match="parameter 'TriggerDistance': expected a double"):
        file.render({"TriggerDistance": "near"})


def test_string_integer_and_boolean_parameters(tmp_path: Path) -> None:
    text = CROSSING.read_text().replace(
        "<ParameterDeclarations>",
        "<ParameterDeclarations>"
        '<ParameterDeclaration name="Model" parameterType="string" value="a"/>'
        '<ParameterDeclaration name="Lanes" parameterType="integer" value="1"/>'
        '<ParameterDeclaration name="Night" parameterType="boolean" value="false"/>',
        1,
    )
    path = tmp_path / "typed.xosc"
    path.write_text(text)
    file = ScenarioFile(path)
    assert file.parameter_values({"Model": "truck", "Lanes": 2.0, "Night": True}) == {
        "Model": "truck",
        "Lanes": "2",
        "Night": "true",
    }
    with pytest.raises(ConfigError, match="'Lanes': expected a integer"):
        file.parameter_values({"Lanes": 2.5})


def test_weather_is_written_into_the_environment() -> None:
    env = ET.fromstring(
        '<Environment><Weather><Fog visualRange="100000"/>'
        '<Precipitation precipitationType="dry" intensity="0"/></Weather>'
        '<RoadCondition frictionScaleFactor="1.0"/></Environment>'
    )
    write_environment(env, {"fog_density": 0, "precipitation": 60, "friction": 0.4})
    clear = float(env.find("Weather/Fog").get("visualRange"))
    write_environment(env, {"fog_density": 80})
    foggy = float(env.find("Weather/Fog").get("visualRange"))
    assert foggy < 200 < clear  # denser fog, shorter visual range (Koschmieder)
    prec = env.find("Weather/Precipitation")
    assert prec.get("precipitationType") == "rain" and float(prec.get("intensity")) == 0.6
    assert float(env.find("RoadCondition").get("frictionScaleFactor")) == 0.4


def test_bad_files_are_one_error(tmp_path: Path) -> None:
    broken = tmp_path / "broken.xosc"
    broken.write_text("<OpenSCENARIO><Storyboard>")
    with pytest.raises(ConfigError, match="broken.xosc"):
        ScenarioFile(broken)
    with pytest.raises(ConfigError, match="ego"):
        ScenarioFile(CROSSING, ego="Nobody")
    with pytest.raises(ConfigError, match="a folder of .xosc files"):
        scenario_files(tmp_path / "none")


def test_scenario_flags_need_the_esmini_backend() -> None:
    with pytest.raises(ConfigError, match="--scenario: these flags need --backend esmini"):
        run_overrides(esmini={"scenario": CROSSING})
    options = run_overrides(backend="esmini", esmini={"scenario": CROSSING, "road": "x.xodr"})
    assert options["backend_options"]["scenario"] == str(CROSSING)
    assert Path(options["backend_options"]["road"]).is_absolute()
    # --map goes with esmini too (where situations are placed); other CARLA flags do not
    options = run_overrides(backend="esmini", carla={"map": "crossroads"})
    assert options["backend_options"] == {"map": "crossroads"}
    with pytest.raises(ConfigError, match="--carla-host"):
        run_overrides(backend="esmini", carla={"map": "Town03", "host": "h"})


def test_a_missing_library_is_one_line(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    monkeypatch.setenv("SITCOV_ESMINI_LIB", str(tmp_path / "libesminiLib.so"))
    monkeypatch.setenv("SITCOV_ESMINI", str(tmp_path / "bin" / "esmini"))
    monkeypatch.setenv("PATH", str(tmp_path))
    with pytest.raises(SetupError) as err:
        find_library()
    text = str(err.value)
    assert "SITCOV_ESMINI" in text and "\n" not in text


def test_the_skeleton_hyperspace_binds_to_its_scenario(tmp_path: Path) -> None:
    """`sitcov hyperspace scenario FILE`'s document loads and passes the binding check."""
    from sitcov.hyperspace import load_hyperspace

    file = ScenarioFile(CROSSING)
    hs = load_hyperspace(file.hyperspace_skeleton())
    assert set(hs.element_names) == set(file.declarations)
    file.check_names(hs.element_names)
    assert list(hs.labels("TriggerDistance")) == ["low", "high"]  # ranges around the default 30
