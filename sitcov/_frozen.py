"""A faster ``__init__`` for the small frozen dataclasses built every simulation step.

A frozen dataclass's generated ``__init__`` sets each field through
``object.__setattr__`` (it must bypass its own ``__setattr__``, which raises); the run
loop builds several such objects per step (``Observation``, ``EgoState``, ``Control``,
``Pose``, ``ActorView``, ``Detection``), and that costs about twice what filling the
instance's ``__dict__`` does. :func:`fast_init` swaps in an ``__init__`` that fills the
``__dict__`` directly, generated from the dataclass's own fields (same names, order,
defaults and default factories), so the class's signature, equality, hash, repr,
immutability and pickling stay exactly those of the dataclass.
"""

from __future__ import annotations

import dataclasses
from typing import TypeVar

T = TypeVar("T")


class _Factory:
    """Default of a field with a default factory (shown as ``<factory>``, as dataclasses do)."""

    def __repr__(self) -> str:
        return "<factory>"


_FACTORY = _Factory()


def fast_init(cls: type[T]) -> type[T]:
    """Replace ``cls.__init__`` (a frozen dataclass without ``__post_init__`` or slots)."""
    if (
        not dataclasses.is_dataclass(cls)
        or not cls.__dataclass_params__.frozen  # type: ignore[attr-defined]
        or hasattr(cls, "__post_init__")
        or hasattr(cls, "__slots__")
    ):
        raise TypeError(f"fast_init: {cls.__name__} is not a plain frozen dataclass")
    namespace: dict[str, object] = {"_FACTORY": _FACTORY}
    params, body = [], ["    d = self.__dict__"]
    for f in dataclasses.fields(cls):
        if not f.init:
            raise TypeError(f"fast_init: {cls.__name__}.{f.name} is not an init field")
        if f.default is not dataclasses.MISSING:
            namespace[f"_d_{f.name}"] = f.default
            params.append(f"{f.name}=_d_{f.name}")
        elif f.default_factory is not dataclasses.MISSING:
            namespace[f"_f_{f.name}"] = f.default_factory
            params.append(f"{f.name}=_FACTORY")
            body.append(f"    if {f.name} is _FACTORY:\n        {f.name} = _f_{f.name}()")
        else:
            params.append(f.name)
        body.append(f"    d[{f.name!r}] = {f.name}")
    source = f"def __init__(self, {', '.join(params)}):\n" + "\n".join(body) + "\n"
    exec(source, namespace)  # noqa: S102 - generated from the dataclass's own fields
    init = namespace["__init__"]
    init.__qualname__ = f"{cls.__qualname__}.__init__"  # type: ignore[attr-defined]
    init.__doc__ = cls.__init__.__doc__  # type: ignore[misc]
    cls.__init__ = init  # type: ignore[assignment]
    return cls
