from __future__ import annotations

import pytest

from sitcov.campaign._config import load_config, run_overrides
from sitcov.errors import ConfigError


def test_plain_flags_pass_through_and_unset_ones_stay_unset():
    overrides = run_overrides(runs=10, seed=None, backend=None, av=None)
    cfg = load_config(None, overrides)
    assert cfg.runs == 10
    assert cfg.backend_options == {}
    assert overrides["av_params"] is None


def test_av_cmd_builds_an_external_stack_spec_with_its_timeout():
    overrides = run_overrides(av_cmd="node stack.js", av_step_timeout=2.5, grey_box=True, av=None)
    assert overrides["av"] == "cmd:node stack.js"
    assert overrides["av_params"] == {"step_timeout": 2.5, "grey_box": True}
    assert overrides["backend_options"] == {"grey_box": True}


def test_grey_box_for_an_in_process_stack_only_tells_the_backend():
    overrides = run_overrides(grey_box=True, av="reference")
    assert overrides["backend_options"] == {"grey_box": True}
    assert overrides["av_params"] is None


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"av_cmd": "x", "av": "reference"}, "--av and --av-cmd"),
        ({"av_step_timeout": 1.0, "av": None}, "--av-step-timeout"),
        (
            {"carla": {"port": 2001}, "backend": None},
            "--carla-port: these flags need --backend carla",
        ),
        ({"carla": {"map": "Town03"}, "backend": "embedded"}, "--map"),
    ],
)
def test_flags_that_do_not_go_together_are_refused(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        run_overrides(**kwargs)


def test_carla_flags_become_backend_options():
    overrides = run_overrides(carla={"port": 2001, "servers": "a:1,b:2"}, backend="carla")
    options = overrides["backend_options"]
    assert options["port"] == 2001
    assert options["servers"]


class OptionsBackend:
    """Stands in for a backend class; remembers the options it was built with."""

    def __init__(self, **options):
        self.options = options


def test_each_worker_is_told_its_index_when_a_server_list_is_configured(monkeypatch):
    from sitcov.campaign import _build
    from sitcov.campaign._config import CampaignConfig

    monkeypatch.setattr(_build, "load", lambda kind, name, base: OptionsBackend)
    listed = CampaignConfig(backend="x:Y", backend_options={"servers": "a:1,b:2"})
    assert _build.build_backend(listed, worker_index=3).options["worker_index"] == 3
    plain = CampaignConfig(backend="x:Y", backend_options={"perception": "pem"})
    assert "worker_index" not in _build.build_backend(plain, worker_index=3).options
