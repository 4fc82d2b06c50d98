"""Finding esmini (the open OpenSCENARIO player) and its tools on this machine.

esmini is not in any package registry: users get it from its release page or build it.
sitcov finds the player from ``SITCOV_ESMINI`` (the path of the ``esmini`` program) or
``PATH``; ``odrplot`` and the ASAM schemas (``schema/*.xsd``) are looked for beside it, as
a release unpacks them (``bin/esmini``, ``bin/odrplot``, ``schema/``).
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

#: Environment variable naming the esmini program.
ENV = "SITCOV_ESMINI"


def find_esmini() -> Path | None:
    """The esmini program: ``SITCOV_ESMINI`` if it names a file, else ``esmini`` on PATH."""
    named = os.environ.get(ENV, "").strip()
    if named:
        path = Path(named).expanduser()
        return path if path.is_file() else None
    found = shutil.which("esmini")
    return Path(found) if found else None


def esmini_tool(name: str, esmini: Path | None = None) -> Path | None:
    """Another program of the esmini build (``odrplot``, ``dat2csv``) beside the player."""
    esmini = esmini or find_esmini()
    if esmini is None:
        return None
    path = esmini.resolve().parent / name
    return path if path.is_file() else None


def schema_dir(esmini: Path | None = None) -> Path | None:
    """The ASAM schema folder of the esmini build (``bin/../schema``), if present."""
    esmini = esmini or find_esmini()
    if esmini is None:
        return None
    path = esmini.resolve().parent.parent / "schema"
    return path if path.is_dir() else None
