"""Finding generators, backends and AV stacks by name, entry point or ``module:Class`` path.

Built-in names are registered by their packages; third parties add entry points in the
groups ``sitcov.generators``, ``sitcov.backends`` and ``sitcov.av``. Every loaded object is
checked against the interface it must implement, and the error names the plugin, the
group and what was expected (as pluggy does).
"""

from __future__ import annotations

import importlib
from importlib.metadata import entry_points
from typing import Any

from sitcov.errors import ConfigError, UnknownPluginError

GROUPS = {"generator": "sitcov.generators", "backend": "sitcov.backends", "av": "sitcov.av"}

_BUILTINS: dict[str, dict[str, str]] = {kind: {} for kind in GROUPS}


def register_builtin(kind: str, name: str, path: str) -> None:
    """Register a built-in plugin as ``module:attribute`` (imported only when used)."""
    _BUILTINS[kind][name] = path


def import_path(path: str, *, kind: str = "plugin") -> Any:
    """Import ``package.module:Attribute``; a clear ConfigError if it fails."""
    module_name, sep, attr = path.partition(":")
    if not sep or not module_name or not attr:
        raise ConfigError(
            field=kind, value=path, expected="a name or a 'package.module:Class' path"
        )
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ConfigError(f"{kind} {path!r}: cannot import module {module_name!r}: {exc}") from exc
    try:
        return getattr(module, attr)
    except AttributeError:
        raise ConfigError(f"{kind} {path!r}: module {module_name!r} has no {attr!r}") from None


def available(kind: str) -> list[str]:
    """Names usable for ``kind``: built-ins plus installed entry points."""
    names = set(_BUILTINS[kind])
    names.update(ep.name for ep in entry_points(group=GROUPS[kind]))
    return sorted(names)


def load(kind: str, name: str, base: type) -> type:
    """Resolve ``name`` to a class implementing ``base``.

    Args:
        kind: ``generator``, ``backend`` or ``av``.
        name: a registered name, an entry-point name, or ``module:Class``.
        base: the abstract interface the class must subclass.
    """
    if name in _BUILTINS[kind]:
        obj = import_path(_BUILTINS[kind][name], kind=kind)
    elif ":" in name:
        obj = import_path(name, kind=kind)
    else:
        matches = [ep for ep in entry_points(group=GROUPS[kind]) if ep.name == name]
        if not matches:
            raise UnknownPluginError(kind, name, available(kind))
        try:
            obj = matches[0].load()
        except Exception as exc:  # a broken third-party package must not crash sitcov
            raise ConfigError(
                f"{kind} {name!r}: entry point {matches[0].value!r} in group "
                f"{GROUPS[kind]!r} cannot be loaded: {type(exc).__name__}: {exc}"
            ) from exc
    if not (isinstance(obj, type) and issubclass(obj, base)):
        raise ConfigError(
            f"{kind} {name!r} ({obj!r}) does not implement {base.__module__}.{base.__name__}"
            f" (plugins of group {GROUPS[kind]!r} must subclass it)"
        )
    missing = sorted(getattr(obj, "__abstractmethods__", ()))
    if missing:
        raise ConfigError(
            f"{kind} {name!r} does not implement {', '.join(missing)}"
            f" (abstract in {base.__module__}.{base.__name__}, group {GROUPS[kind]!r})"
        )
    return obj
