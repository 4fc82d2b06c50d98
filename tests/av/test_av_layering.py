"""The stacks stand below the simulator that drives them: sitcov.av imports no layer above it.

Read from the source (every import statement, also inside functions and ``TYPE_CHECKING``),
because importing ``sitcov.av`` runs ``sitcov/__init__.py``, which imports everything.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import sitcov.av

AV = Path(sitcov.av.__file__).parent
SITCOV = AV.parent
#: Packages above the stacks: the simulator and what is built on it.
ABOVE = ("sitcov.sim", "sitcov.gym", "sitcov.campaign", "sitcov.generation", "sitcov.analysis")


def imported_modules(path: Path) -> set[str]:
    """Every module or name an import statement of ``path`` names, in full.

    ``import a.b`` gives ``a.b``; ``from a import b`` gives ``a.b`` (a submodule or a name
    of ``a``); relative imports are not used in sitcov.
    """
    names: set[str] = set()
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def is_above(name: str) -> bool:
    """A layer above the stacks, or the package face ``sitcov/__init__.py`` (which imports
    all of them): ``import sitcov`` or a name taken from it rather than from a submodule."""
    if name.startswith(ABOVE):
        return True
    parts = name.split(".")
    if parts[0] != "sitcov":
        return False
    if len(parts) == 1:
        return True
    return len(parts) == 2 and not (
        (SITCOV / f"{parts[1]}.py").is_file() or (SITCOV / parts[1]).is_dir()
    )


@pytest.mark.parametrize("path", sorted(AV.glob("*.py")), ids=lambda p: p.name)
def test_no_stack_module_imports_a_layer_above(path: Path) -> None:
    above = sorted(n for n in imported_modules(path) if is_above(n))
    assert above == [], f"{path.name} imports {above}"


def test_the_check_sees_function_level_imports_and_the_package_face(tmp_path: Path) -> None:
    source = tmp_path / "probe.py"
    source.write_text(
        "def f():\n    from sitcov.sim.embedded import x\n    import sitcov\n"
        "    from sitcov import __version__, _plugins, perception\n"
    )
    names = imported_modules(source)
    assert sorted(n for n in names if is_above(n)) == [
        "sitcov",
        "sitcov.__version__",
        "sitcov.sim.embedded.x",
    ]
