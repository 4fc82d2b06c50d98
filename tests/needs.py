"""What a test needs from the machine: skipped locally when missing, a FAILURE in CI.

CI (``CI`` set to ``true``/``1``/``yes``, as GitHub Actions and .ci/run do) installs every
extra, chromium, node and fetches the detector model, so a missing one there means the
set-up broke and the tests that need it would silently vanish; they fail instead.
Never use these for sitcov's own modules: an import error in sitcov is a bug, not a skip.
"""

from __future__ import annotations

import importlib
import os
import shutil
from types import ModuleType
from typing import NoReturn

import pytest


def in_ci() -> bool:
    """True when the ``CI`` environment variable is set to true/1/yes."""
    return os.environ.get("CI", "").strip().lower() in ("1", "true", "yes")


def missing(reason: str) -> NoReturn:
    """Skip with ``reason`` locally; fail with it when running in CI."""
    if in_ci():
        pytest.fail(f"{reason} (CI is set: everything the tests need must be installed)")
    pytest.skip(reason, allow_module_level=True)


def need_module(name: str, extra: str) -> ModuleType:
    """Import an optional third-party module (from the ``extra`` of pyproject.toml)."""
    if name.split(".")[0] == "sitcov":
        raise ValueError("sitcov's own modules are imported, never skipped")
    try:
        return importlib.import_module(name)
    except ImportError as exc:
        missing(f"{name} is not installed (pip install 'sitcov[{extra}]'): {exc}")


def need_program(*names: str) -> str:
    """The path of the first of ``names`` on PATH (e.g. ``node``, ``chromium``)."""
    for name in names:
        path = shutil.which(name)
        if path:
            return path
    missing(f"{' or '.join(names)} is not on PATH")


def need_esmini_library() -> str:
    """The path of esmini's C library, found as the esmini backend finds it
    (``SITCOV_ESMINI_LIB``, ``SITCOV_ESMINI`` or an ``esmini`` on PATH; CI sets
    ``SITCOV_ESMINI`` to the shared build)."""
    from sitcov.errors import SetupError
    from sitcov.sim.esmini import find_library

    try:
        return str(find_library())
    except SetupError as exc:
        missing(str(exc))


def not_on_this_machine(reason: str) -> NoReturn:
    """Skip, in CI too: the test needs a capability of the machine itself that no install
    step can provide (root, a cgroup-v1 memory controller, /proc start times). Each such test
    has a sibling that runs everywhere (docs/reliability.md names it)."""
    pytest.skip(reason, allow_module_level=True)


def need_esmini(tool: str = "esmini"):
    """The esmini player (``SITCOV_ESMINI`` or PATH; CI points it at ../shared's build) or
    another program of its build beside it (``odrplot``), as a ``pathlib.Path``."""
    from sitcov.sim.xosc import esmini_tool, find_esmini

    esmini = find_esmini()
    if esmini is None:
        missing("esmini not found (set SITCOV_ESMINI to the esmini program, or put it on PATH)")
    if tool == "esmini":
        return esmini
    path = esmini_tool(tool, esmini)
    if path is None:
        missing(f"{tool} not found beside {esmini}")
    return path


def need_schema(name: str):
    """An ASAM schema (``OpenSCENARIOv1.2.xsd``, ``OpenDRIVE_1.4H.xsd``) of the esmini build."""
    from sitcov.sim.xosc import schema_dir

    folder = schema_dir(need_esmini())
    path = None if folder is None else folder / name
    if path is None or not path.is_file():
        missing(f"schema {name} not found in esmini's schema folder ({folder})")
    return path
