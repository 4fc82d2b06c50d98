"""The road layer sits below ``sim/``: it imports nothing of sitcov but itself, the errors
and the plane geometry helpers (so ``sim`` and an OpenDRIVE writer beside the reader can
build on it)."""

from __future__ import annotations

from layering import SITCOV, imported_names


def test_roads_imports_only_itself_the_errors_and_geometry() -> None:
    files = sorted((SITCOV / "roads").glob("*.py"))
    assert files
    for path in files:
        for name in imported_names(path):
            if name.split(".")[0] != "sitcov":
                continue
            assert name.startswith(("sitcov.roads", "sitcov.errors", "sitcov._geometry")), (
                path.name,
                name,
            )
