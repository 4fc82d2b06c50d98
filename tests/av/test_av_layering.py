"""The stacks stand below the simulator that drives them: sitcov.av imports no layer above it."""

from __future__ import annotations

from pathlib import Path

import pytest
from layering import SITCOV, from_the_face, imported_names

#: Packages above the stacks: the simulator and what is built on it.
ABOVE = ("sitcov.sim", "sitcov.gym", "sitcov.campaign", "sitcov.generation", "sitcov.analysis")


def is_above(name: str) -> bool:
    """A layer above the stacks, or the package face (which imports all of them)."""
    return name.startswith(ABOVE) or from_the_face(name)


@pytest.mark.parametrize("path", sorted((SITCOV / "av").glob("*.py")), ids=lambda p: p.name)
def test_no_stack_module_imports_a_layer_above(path: Path) -> None:
    above = sorted(n for n in imported_names(path) if is_above(n))
    assert above == [], f"{path.name} imports {above}"


def test_the_check_sees_function_level_imports_and_the_package_face(tmp_path: Path) -> None:
    source = tmp_path / "probe.py"
    source.write_text(
        "def f():\n    from sitcov.sim.embedded import x\n    import sitcov\n"
        "    from sitcov import __version__, _plugins, perception\n"
    )
    assert sorted(n for n in imported_names(source) if is_above(n)) == [
        "sitcov",
        "sitcov.__version__",
        "sitcov.sim.embedded.x",
    ]
