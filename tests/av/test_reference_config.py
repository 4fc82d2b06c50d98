"""Faults and parameters as configuration; make_stack's name resolution and errors."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from sitcov.av import (
    DEFAULT_PARAMS,
    FAULT_DESCRIPTIONS,
    FAULTS,
    AVStack,
    NoPerceptionStack,
    ReferenceStack,
    make_stack,
)
from sitcov.av._fault_map import f1_threshold
from sitcov.av._faults import fault_overrides
from sitcov.errors import ConfigError, UnknownPluginError


def test_geometric_faults_and_f1_raw_are_the_papers_values():
    assert fault_overrides("f1-raw") == {"threshold": 0.95}
    assert fault_overrides("f2") == {"centering": (0.3, 0.6)}
    assert fault_overrides("f3") == {"distance": 0.35}
    assert set(FAULT_DESCRIPTIONS) == set(FAULTS) == {"f1", "f1-raw", "f2", "f3", "f4"}
    assert fault_overrides("f4") == {"classes": ("car", "bicycle")}
    assert "0.95" in FAULT_DESCRIPTIONS["f1-raw"] and "PEM" in FAULT_DESCRIPTIONS["f1"]


def test_f1_is_computed_from_the_detector_model():
    # stricter than nominal, below what our detector never reaches; see test_fault_map.py
    assert 0.5 < fault_overrides("f1")["threshold"] == f1_threshold() < 0.95
    assert ReferenceStack(fault="f1").params["threshold"] == f1_threshold()
    assert ReferenceStack(fault="f1-raw").params["threshold"] == 0.95


@pytest.mark.parametrize("fault", sorted(FAULTS))
def test_config_reports_fault_and_effective_params(fault):
    cfg = ReferenceStack(fault=fault).config()
    assert cfg["name"] == "reference" and cfg["fault"] == fault
    ((name, value),) = fault_overrides(fault).items()
    assert cfg["params"][name] == (list(value) if isinstance(value, tuple) else value)
    json.dumps(cfg)  # stored with every run


def test_params_override_defaults_and_faults():
    stack = ReferenceStack(fault="f1", params={"threshold": 0.7, "target_speed_kmh": 30})
    assert stack.params["threshold"] == 0.7
    assert stack.params["target_speed_kmh"] == 30.0
    assert stack.params["distance"] == DEFAULT_PARAMS["distance"]
    assert ReferenceStack(params={"centering": [0.1, 0.9]}).params["centering"] == (0.1, 0.9)


def test_unknown_fault_lists_the_allowed_ones():
    with pytest.raises(ConfigError, match=r"'f9'.*f1, f1-raw, f2, f3") as info:
        ReferenceStack(fault="f9")
    assert "\n" not in str(info.value) and info.value.field == "fault"


def test_unknown_param_lists_the_allowed_ones():
    with pytest.raises(ConfigError, match=r"'treshold'.*centering.*threshold") as info:
        ReferenceStack(params={"treshold": 0.4})
    assert info.value.field == "params.treshold"


@pytest.mark.parametrize(
    "params",
    [
        {"threshold": 1.5},
        {"threshold": "high"},
        {"centering": (0.6, 0.3)},
        {"centering": 0.5},
        {"distance": -1},
        {"pid_window": 0},
        {"max_brake": True},
    ],
)
def test_invalid_values_are_config_errors(params):
    with pytest.raises(ConfigError, match=next(iter(params))):
        ReferenceStack(params=params)


def test_make_stack_names_and_paths():
    assert type(make_stack()) is ReferenceStack
    assert make_stack("reference", fault="f2").params["centering"] == (0.3, 0.6)
    blind = make_stack("no-perception")
    assert isinstance(blind, NoPerceptionStack) and not blind.aeb
    by_path = make_stack("sitcov.av:ReferenceStack", params={"distance": 0.5})
    assert by_path.params["distance"] == 0.5


class _Plain(AVStack):
    def reset(self, info):
        pass

    def step(self, observation):
        raise NotImplementedError


def test_make_stack_errors():
    with pytest.raises(UnknownPluginError, match="reference"):
        make_stack("nonexistent")
    with pytest.raises(ConfigError, match="does not implement"):
        make_stack("sitcov.av:Control")
    with pytest.raises(ConfigError, match="does not take 'fault'"):
        make_stack(f"{__name__}:_Plain", fault="f1")
    assert isinstance(make_stack(f"{__name__}:_Plain"), _Plain)


def _sitcov(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", "from sitcov.cli import main; main()", *args],
        capture_output=True,
        text=True,
        timeout=120,
        env={**os.environ, "COLUMNS": "200"},
    )


def test_cli_unknown_fault_is_one_line_and_help_says_which_f1_is_which():
    result = _sitcov("bench", "--fault", "f9", "-n", "1")
    assert result.returncode == 2
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert lines == ["error: unknown fault 'f9'; expected one of: f1, f1-raw, f2, f3, f4 (or none)"]
    help_text = " ".join(_sitcov("run", "--help").stdout.replace("│", " ").split())
    assert "f1-raw = the paper's raw 0.95" in help_text
    assert "relative to our detector" in help_text
