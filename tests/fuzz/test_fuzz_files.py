"""Fuzzing the files users write: hyperspace YAML, campaign config YAML, map YAML.

Every damaged file either loads or raises one single-line SitcovError (ConfigError) that
names the file - never another exception, never a hang.
"""

from __future__ import annotations

import itertools
import tempfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
import yaml
from fuzz_helpers import fuzz_settings, ok_or_one_line
from hypothesis import given
from mutations import ALIAS_BOMB, dump, mutated_bytes, mutated_data

import sitcov.hyperspace
from sitcov.campaign import CampaignConfig, load_config
from sitcov.hyperspace import load_hyperspace
from sitcov.sim.embedded._map import MAPS_DIR, load_map

WORK = Path(tempfile.mkdtemp(prefix="sitcov-fuzz-"))
_COUNT = itertools.count()
HYPERSPACE = Path(sitcov.hyperspace.__file__).parent / "data" / "t-junction.yaml"


def _config_text() -> str:
    return dump(CampaignConfig(runs=20, seed=3).model_dump(mode="json"))


SOURCES: dict[str, tuple[str, Callable[[Path], Any]]] = {
    "hyperspace": (HYPERSPACE.read_text(), lambda p: load_hyperspace(p)),
    "config": (_config_text(), lambda p: load_config(p, {})),
    "map": ((MAPS_DIR / "t-junction.yaml").read_text(), lambda p: load_map(str(p))),
}


def check(kind: str, content: bytes) -> str:
    path = WORK / f"{kind}-{next(_COUNT)}.yaml"  # a new name: loaders may cache by path
    path.write_bytes(content)
    _, load = SOURCES[kind]
    try:
        return ok_or_one_line(lambda: load(path), str(path), path.name)
    finally:
        path.unlink()


@pytest.mark.parametrize("kind", list(SOURCES))
def test_pristine_files_load(kind):
    text, _ = SOURCES[kind]
    assert check(kind, text.encode()) == "ok"


@pytest.mark.parametrize("kind", list(SOURCES))
def test_an_alias_bomb_is_one_line_or_loads_quickly(kind):
    assert check(kind, ALIAS_BOMB.encode()) in ("ok", "error")


@pytest.mark.parametrize("kind", list(SOURCES))
@pytest.mark.parametrize(
    "text",
    [
        "[" * 500 + "]" * 500,
        "runs: " + "1" * 5000,
        "a: " + "{a: " * 2000 + "1" + "}" * 2000,
        "axes: [{elements: [{bins: [{value: .inf}]}]}]",
    ],
    ids=["deep-list", "5000-digit-int", "deep-mapping", "infinity"],
)
def test_nesting_and_number_limits_are_one_line(kind, text):
    assert check(kind, text.encode()) == "error"


@pytest.mark.parametrize("kind", list(SOURCES))
def test_structurally_damaged_files(kind):
    text, _ = SOURCES[kind]

    @fuzz_settings()
    @given(mutated_data(yaml.safe_load(text)))
    def damaged(data):
        check(kind, dump(data).encode())

    damaged()


@pytest.mark.parametrize("kind", list(SOURCES))
def test_byte_damaged_files(kind):
    text, _ = SOURCES[kind]

    @fuzz_settings()
    @given(mutated_bytes(text))
    def damaged(content):
        check(kind, content)

    damaged()
