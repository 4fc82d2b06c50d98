"""The CARLA backend refuses an extra road user it could never place, before any run (issue
26): an actor key typo or a route its embedded map lacks is one ConfigError naming the bin."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml
from carla_testkit import fake_backend, small_map

from sitcov.errors import ConfigError
from sitcov.hyperspace import Hyperspace

DERIVED = Path(__file__).parents[3] / "sitcov/hyperspace/data/derived/t-junction.yaml"


def _derived(edit) -> Hyperspace:
    doc = yaml.safe_load(DERIVED.read_text())
    (actor2,) = [e for a in doc["axes"] for e in a["elements"] if e["name"] == "actor2"]
    edit(actor2["bins"][1]["value"])
    return Hyperspace.from_dict(doc)


def test_actor_typos_and_unknown_routes_are_refused(tmp_path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    backend.check_hyperspace(_derived(lambda v: None))  # the shipped values pass
    with pytest.raises(ConfigError, match=r"actor2\.bins\[1\] \(.*\)\.value\.behavior"):
        backend.check_hyperspace(_derived(lambda v: v.update(behavior="cruise")))
    with pytest.raises(ConfigError, match=r"actor2\.bins\[1\] \(.*\)\.value\.route: expected one"):
        backend.check_hyperspace(_derived(lambda v: v.update(route="B-Q")))
