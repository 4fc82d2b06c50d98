"""Reading a module's imports from its source, for tests of which layer may import which.

Read from the source (every import statement, also inside functions and ``TYPE_CHECKING``)
because importing any sitcov module runs ``sitcov/__init__.py``, which imports everything.
Importable from every test folder, like ``needs``.
"""

from __future__ import annotations

import ast
from pathlib import Path

#: The package's source folder.
SITCOV = Path(__file__).resolve().parent.parent / "sitcov"


def imported_names(path: Path) -> set[str]:
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


def from_the_face(name: str) -> bool:
    """Whether ``name`` is the package face ``sitcov/__init__.py`` (which imports every
    layer): ``import sitcov`` or a name taken from it rather than from a submodule."""
    parts = name.split(".")
    if parts[0] != "sitcov" or len(parts) > 2:
        return False
    if len(parts) == 1:
        return True
    return not ((SITCOV / f"{parts[1]}.py").is_file() or (SITCOV / parts[1]).is_dir())
