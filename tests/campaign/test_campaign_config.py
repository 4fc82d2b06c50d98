"""Campaign config: YAML + flag overrides, errors that name file and field, resume diffs."""

from __future__ import annotations

import pytest

from sitcov.campaign import CampaignConfig, load_config
from sitcov.campaign._config import config_differences
from sitcov.errors import ConfigError


def test_defaults_match_the_cli_contract():
    c = CampaignConfig()
    assert (c.name, c.generator, c.backend, c.av, c.runs, c.seed) == (
        "default",
        "sitcov",
        "embedded",
        "reference",
        1000,
        0,
    )
    assert c.executor == "processes" and c.batch_size == 32 and c.workers >= 1


def test_yaml_with_flag_overrides(tmp_path):
    f = tmp_path / "c.yaml"
    f.write_text("name: fog\nruns: 20\nbackend_options: {perception: pem, x: 1}\nseed: 4\n")
    c = load_config(f, {"runs": 50, "seed": None, "backend_options": {"perception": "camera"}})
    assert c.name == "fog" and c.runs == 50 and c.seed == 4
    assert c.backend_options == {"perception": "camera", "x": 1}


@pytest.mark.parametrize(
    ("text", "pattern"),
    [
        ("runs: many\n", r"c\.yaml: runs: expected .*integer.*got 'many'"),
        ("runz: 3\n", r"c\.yaml: runz: unknown field; expected one of: .*runs"),
        ("executor: gpu\n", r"c\.yaml: executor: expected .*'serial'.*got 'gpu'"),
        ("batch_size: 0\n", r"c\.yaml: batch_size: expected .*greater than or equal to 1"),
        ("- a\n- b\n", r"c\.yaml: \(top level\): expected a mapping"),
        ("a: [\n", r"c\.yaml: not valid YAML"),
    ],
)
def test_bad_files_name_file_and_field(tmp_path, text, pattern):
    f = tmp_path / "c.yaml"
    f.write_text(text)
    with pytest.raises(ConfigError, match=pattern):
        load_config(f)


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="nope.yaml: cannot read"):
        load_config(tmp_path / "nope.yaml")


def test_bad_flag_names_field_without_file():
    with pytest.raises(ConfigError, match=r"^workers: expected .*greater than or equal to 1"):
        load_config(None, {"workers": 0})


def test_differences_ignore_execution_only_settings():
    stored = CampaignConfig(runs=10, workers=1, executor="serial").model_dump(mode="json")
    same = CampaignConfig(runs=99, workers=7, executor="ray", ray_address="x:1")
    assert config_differences(stored, same) == []
    other = CampaignConfig(seed=5, fault="f1")
    diffs = config_differences(stored, other)
    assert diffs == ["fault: None -> 'f1'", "seed: 0 -> 5"]
