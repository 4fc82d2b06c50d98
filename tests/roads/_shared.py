"""Test data from ``../shared`` (esmini's odrplot, CARLA's Town03): found there when present
(CI), otherwise the test is skipped locally and fails in CI (``tests/needs.py``)."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

from needs import missing

REPO = Path(__file__).resolve().parents[2]
SHARED = REPO.parent / "shared"
DATA = Path(__file__).parent / "data"


def town03() -> Path:
    """CARLA's Town03.xodr (the paper's map)."""
    path = SHARED / "maps" / "Town03.xodr"
    if not path.is_file():
        missing(f"CARLA's Town03 is not at {path}")
    return path


def odrplot() -> str:
    """esmini's ``odrplot``: beside ``SITCOV_ESMINI``, on PATH, or in ../shared."""
    candidates = []
    if os.environ.get("SITCOV_ESMINI"):
        candidates.append(Path(os.environ["SITCOV_ESMINI"]).parent / "odrplot")
    if shutil.which("odrplot"):
        candidates.append(Path(shutil.which("odrplot") or ""))
    candidates.append(SHARED / "tools" / "esmini" / "bin" / "odrplot")
    for path in candidates:
        if path.is_file() and os.access(path, os.X_OK):
            return str(path)
    missing("esmini's odrplot is not found (SITCOV_ESMINI, PATH or ../shared/tools/esmini)")
