"""Reading hyperspace files: the built-in ``t-junction`` or a user's YAML."""

from __future__ import annotations

from collections.abc import Mapping
from importlib import resources
from pathlib import Path
from typing import Any

import yaml

from sitcov.errors import ConfigError
from sitcov.hyperspace._space import Hyperspace

#: Name of the built-in default hyperspace (the paper's).
DEFAULT_HYPERSPACE = "t-junction"
_BUILTIN = {"t-junction": "t-junction.yaml"}


class _UniqueKeyLoader(yaml.SafeLoader):
    """A SafeLoader that rejects a key given twice in one mapping (PyYAML keeps the last)."""


def _construct_mapping(loader: _UniqueKeyLoader, node: yaml.MappingNode, deep: bool = False) -> Any:
    seen: set[Any] = set()
    for key_node, _ in node.value:
        key = loader.construct_object(key_node, deep=deep)
        if key in seen:
            raise yaml.constructor.ConstructorError(
                None, None, f"duplicate key {key!r}", key_node.start_mark
            )
        seen.add(key)
    return loader.construct_mapping(node, deep=deep)


_UniqueKeyLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)


def read_yaml(text: str, file: str) -> Any:
    """Parse YAML text; a syntax error becomes ``FILE: line N: expected valid YAML, got ...``."""
    try:
        return yaml.load(text, Loader=_UniqueKeyLoader)  # noqa: S506 (SafeLoader subclass)
    except yaml.MarkedYAMLError as exc:
        mark = exc.problem_mark or exc.context_mark
        line = f"line {mark.line + 1}" if mark is not None else "(unknown line)"
        problem = exc.problem or exc.context or "a syntax error"
        raise ConfigError(f"{file}: {line}: expected valid YAML, got {problem}") from None
    except (yaml.YAMLError, ValueError, RecursionError) as exc:  # 4300+ digits, deep nesting
        problem = " ".join(str(exc).split())
        raise ConfigError(f"{file}: expected valid YAML, got {problem}") from None


def load_hyperspace(
    source: str | Path | Mapping[str, Any] | Hyperspace | None = None,
) -> Hyperspace:
    """Load a hyperspace.

    Args:
        source: None or ``"t-junction"`` for the built-in default; a path to a YAML file;
            a mapping in the file form; or a Hyperspace (returned as is).

    Raises:
        ConfigError: the file is missing, is not valid YAML, or breaks the schema; the
            message names the file, the field path and what was expected.
    """
    if isinstance(source, Hyperspace):
        return source
    if isinstance(source, Mapping):
        return Hyperspace.from_dict(source)
    if source is None or (isinstance(source, str) and source in _BUILTIN):
        name = DEFAULT_HYPERSPACE if source is None else str(source)
        res = resources.files("sitcov.hyperspace") / "data" / _BUILTIN[name]
        return Hyperspace.from_dict(read_yaml(res.read_text(encoding="utf-8"), name), file=name)
    path = Path(source)
    file = str(source)
    if not path.is_file():
        known = ", ".join(sorted(_BUILTIN))
        raise ConfigError(
            f"{file}: file not found (expected a hyperspace YAML file or a built-in name: {known})"
        )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{file}: cannot read: {exc}") from None
    data = read_yaml(text, file)
    try:
        return Hyperspace.from_dict(data, file=file)
    except ValueError as exc:  # situations are stored as JSON, which has no inf or nan
        if "JSON compliant" not in str(exc):
            raise
        raise ConfigError(
            f"{file}: expected finite numbers (.inf and .nan cannot be stored), got one"
        ) from None
