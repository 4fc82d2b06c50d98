"""The public API: the names ``sitcov`` and its packages promise, and that they all exist."""

from __future__ import annotations

import importlib
import re
from pathlib import Path

import pytest
from layering import SITCOV, from_the_face, imported_names

import sitcov

ROOT = Path(__file__).resolve().parent.parent

#: The top-level API is deliberately small (one entry per concern); adding a name is a
#: decision, so this list changes with it.
TOP_LEVEL = {
    "AVStack",
    "Backend",
    "CampaignConfig",
    "ConfigError",
    "Control",
    "Generator",
    "Hyperspace",
    "Observation",
    "Outcome",
    "ReferenceStack",
    "RunInfo",
    "SitcovError",
    "Situation",
    "__version__",
    "ask_rng",
    "load_hyperspace",
    "make_backend",
    "make_generator",
    "make_stack",
    "open_store",
    "run_campaign",
    "run_seed",
    "summarize",
}
#: Packages whose ``__all__`` is public (``sitcov.gym`` needs the extra ``gym``).
PACKAGES = (
    "analysis",
    "av",
    "campaign",
    "generation",
    "hyperspace",
    "perception",
    "sim",
    "sim.embedded",
    "sim.carla",
    "sim.esmini",
    "weather",
    "roads",
    "report",
    "evidence",
)


def test_top_level_names_are_the_small_api() -> None:
    assert set(sitcov.__all__) == TOP_LEVEL
    assert len(sitcov.__all__) == len(TOP_LEVEL)  # no name twice
    for name in sitcov.__all__:
        assert getattr(sitcov, name) is not None


def test_star_import_gives_exactly_the_api() -> None:
    namespace: dict = {}
    exec("from sitcov import *", namespace)  # noqa: S102
    assert set(namespace) - {"__builtins__"} == TOP_LEVEL


@pytest.mark.parametrize("package", PACKAGES)
def test_every_listed_name_of_a_package_exists(package: str) -> None:
    module = importlib.import_module(f"sitcov.{package}")
    missing = [name for name in module.__all__ if not hasattr(module, name)]
    assert missing == [] and len(set(module.__all__)) == len(module.__all__)


def test_the_gym_package_lists_what_it_has() -> None:
    from needs import need_module

    need_module("gymnasium", "gym")
    gym = importlib.import_module("sitcov.gym")
    assert [name for name in gym.__all__ if not hasattr(gym, name)] == []
    assert {"ENV_ID", "PolicyStack", "TJunctionEnv"} <= set(gym.__all__)


def test_version_is_pyproject_s() -> None:
    found = re.search(r'^version = "([^"]+)"$', (ROOT / "pyproject.toml").read_text(), re.M)
    assert found and sitcov.__version__ == found[1]
    from sitcov._version import __version__

    assert __version__ is sitcov.__version__


def test_no_module_takes_names_from_the_package_face() -> None:
    """``sitcov/__init__.py`` imports every layer: a module below it takes what it needs from
    the submodule that defines it (``sitcov._version``, not ``sitcov``), or layers run back up.
    """
    offenders = {
        str(path.relative_to(SITCOV)): sorted(n for n in imported_names(path) if from_the_face(n))
        for path in SITCOV.rglob("*.py")
        if path != SITCOV / "__init__.py"
    }
    assert {path: names for path, names in offenders.items() if names} == {}
