"""The hyperspace file format: pydantic models for structure, plus the checks between fields.

Pydantic checks types and unknown keys; :func:`validate_document` then checks what pydantic
cannot see in one field (unique names and labels, one of ``value``/``range``, constraints that
name existing elements and labels). Every problem becomes one :class:`ConfigError` line of the
form ``FILE: axes[0].elements[2].bins: expected ..., got ...``.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any, Union, get_args, get_origin

from pydantic import (
    BaseModel,
    ConfigDict,
    Field,
    StrictFloat,
    StrictInt,
    StrictStr,
    ValidationError,
)

from sitcov.errors import ConfigError

Number = Union[StrictInt, StrictFloat]  # noqa: UP007 (pydantic-friendly on 3.10)


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class BinSpec(_Strict):
    """One bin: a point (numeric ``value``), a category (other ``value``) or a ``range``."""

    label: str | None = None
    value: Any = None
    range: tuple[Number, Number] | None = None
    description: str = ""


class ElementSpec(_Strict):
    """One element of an axis, with its bins in order."""

    name: str = Field(min_length=1)
    description: str = ""
    unit: str = ""
    carla_field: str | None = None
    metadata: dict[str, Any] = Field(default_factory=dict)
    bins: list[BinSpec]


class AxisSpec(_Strict):
    """A group of elements (e.g. ``environment``, ``intersection``)."""

    name: str = Field(min_length=1)
    description: str = ""
    metadata: dict[str, Any] = Field(default_factory=dict)
    elements: list[ElementSpec]


class ConstraintSpec(_Strict):
    """A forbidden combination: situations whose bins are all in ``forbid`` are not allowed."""

    forbid: dict[str, list[Union[StrictStr, StrictInt, StrictFloat]]]  # noqa: UP007
    description: str = ""

    def labels(self, element: str) -> list[str]:
        """The forbidden labels of ``element``; numbers are read as point labels (0.1 -> "0.1")."""
        return [x if isinstance(x, str) else str(default_label(x)) for x in self.forbid[element]]


class HyperspaceSpec(_Strict):
    """The whole file."""

    name: str = Field(min_length=1)
    description: str = ""
    metadata: dict[str, Any] = Field(default_factory=dict)
    axes: list[AxisSpec]
    constraints: list[ConstraintSpec] = Field(default_factory=list)


def _path(loc: tuple[Any, ...]) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def _model_at(loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The model class that owns the key at ``loc`` (to list the allowed keys)."""
    model: Any = HyperspaceSpec
    for part in loc[:-1]:
        if isinstance(part, int):
            continue
        if not (isinstance(model, type) and issubclass(model, BaseModel)):
            return None
        info = model.model_fields.get(str(part))
        if info is None:
            return None
        annotation = info.annotation
        while get_origin(annotation) in (list, Union) or str(get_origin(annotation)).endswith(
            "UnionType"
        ):
            args = [a for a in get_args(annotation) if a is not type(None)]
            annotation = args[0] if args else None
        model = annotation
    return model if isinstance(model, type) and issubclass(model, BaseModel) else None


_EXPECT = {
    "missing": "a required field",
    "string_type": "a string",
    "list_type": "a list",
    "tuple_type": "a list [lo, hi]",
    "dict_type": "a mapping",
    "model_type": "a mapping",
    "int_type": "an integer",
    "float_type": "a number",
    "too_short": "a longer value",
    "too_long": "a shorter value",
}


def translate(exc: ValidationError, file: str) -> ConfigError:
    """The first pydantic error as one ConfigError line naming file, field path and rule."""
    err = exc.errors(include_url=False)[0]
    loc = tuple(err["loc"])
    kind = err["type"]
    if kind == "extra_forbidden":
        model = _model_at(loc)
        allowed = ", ".join(model.model_fields) if model else "the documented keys"
        return ConfigError(
            file=file,
            field=_path(loc),
            expected=f"no such key (allowed: {allowed})",
            value=err["input"],
        )
    if kind == "missing":
        return ConfigError(f"{file}: {_path(loc)}: expected a required field, got nothing")
    # Unions report one error per branch: drop the branch names from the path.
    loc = tuple(p for p in loc if not (isinstance(p, str) and p in ("int", "float")))
    expected = _EXPECT.get(kind) or err["msg"].removeprefix("Input should be ")
    value = err.get("input")
    if kind == "too_short" and isinstance(value, str):
        expected = "a non-empty string"
    return ConfigError(file=file, field=_path(loc), expected=expected, value=value)


def is_number(value: Any) -> bool:
    """True for int/float values (not bool): these make a bin a point."""
    return isinstance(value, int | float) and not isinstance(value, bool)


def default_label(value: Any) -> str | None:
    """The label a point or string category gets when none is given: ``0``, ``20``, ``0.1``."""
    if is_number(value):
        return str(value) if isinstance(value, int) else repr(float(value))
    if isinstance(value, str):
        return value
    return None


def validate_document(spec: HyperspaceSpec, file: str) -> None:
    """Checks across fields; raises the first problem as a ConfigError."""
    seen_elements: dict[str, str] = {}
    labels: dict[str, list[str]] = {}
    if not spec.axes:
        raise ConfigError(file=file, field="axes", expected="at least one axis", value=[])
    for a, axis in enumerate(spec.axes):
        if not axis.elements:
            raise ConfigError(
                file=file, field=f"axes[{a}].elements", expected="at least one element", value=[]
            )
        for e, element in enumerate(axis.elements):
            where = f"axes[{a}].elements[{e}]"
            if element.name in seen_elements:
                raise ConfigError(
                    file=file,
                    field=f"{where}.name",
                    expected=f"a unique element name ({element.name!r} is also "
                    f"{seen_elements[element.name]})",
                    value=element.name,
                )
            seen_elements[element.name] = where
            if not element.bins:
                raise ConfigError(
                    file=file, field=f"{where}.bins", expected="at least one bin", value=[]
                )
            names: list[str] = []
            for b, bin_ in enumerate(element.bins):
                names.append(_check_bin(bin_, file, f"{where}.bins[{b}]"))
                if names[-1] in names[:-1]:
                    raise ConfigError(
                        file=file,
                        field=f"{where}.bins[{b}].label",
                        expected=f"labels unique within element {element.name!r}",
                        value=names[-1],
                    )
            labels[element.name] = names
    for c, constraint in enumerate(spec.constraints):
        where = f"constraints[{c}].forbid"
        if not constraint.forbid:
            raise ConfigError(file=file, field=where, expected="at least one element", value={})
        for el, chosen in constraint.forbid.items():
            if el not in labels:
                raise ConfigError(
                    file=file,
                    field=f"{where}.{el}",
                    expected=f"an element name ({', '.join(labels)})",
                    value=el,
                )
            if not chosen:
                raise ConfigError(
                    file=file, field=f"{where}.{el}", expected="at least one bin label", value=[]
                )
            for i, label in enumerate(constraint.labels(el)):
                if label not in labels[el]:
                    raise ConfigError(
                        file=file,
                        field=f"{where}.{el}[{i}]",
                        expected=f"a bin label of {el!r} ({', '.join(labels[el])})",
                        value=label,
                    )


def _check_bin(bin_: BinSpec, file: str, where: str) -> str:
    has_value = "value" in bin_.model_fields_set
    has_range = bin_.range is not None
    if has_value == has_range:
        raise ConfigError(
            file=file,
            field=where,
            expected="exactly one of 'value' (point or category) or 'range' [lo, hi]",
            value=bin_.model_dump(exclude_defaults=True),
        )
    if has_range:
        lo, hi = bin_.range  # type: ignore[misc]
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ConfigError(
                file=file, field=f"{where}.range", expected="finite lo < hi", value=[lo, hi]
            )
        label = bin_.label if bin_.label is not None else f"[{lo:g},{hi:g})"
    else:
        if bin_.value is None:
            raise ConfigError(
                file=file,
                field=f"{where}.value",
                expected="a number, string or mapping",
                value=None,
            )
        if is_number(bin_.value) and not math.isfinite(bin_.value):
            raise ConfigError(
                file=file, field=f"{where}.value", expected="a finite number", value=bin_.value
            )
        label = bin_.label if bin_.label is not None else default_label(bin_.value)
        if label is None:
            raise ConfigError(
                file=file,
                field=f"{where}.label",
                expected="a label (required when the value is not a number or string)",
                value=None,
            )
    if not label:
        raise ConfigError(file=file, field=f"{where}.label", expected="a non-empty label", value="")
    return label


def parse(data: Any, file: str) -> HyperspaceSpec:
    """Validate a loaded YAML/JSON document into a :class:`HyperspaceSpec`."""
    if not isinstance(data, Mapping):
        raise ConfigError(
            file=file, field="(top level)", expected="a mapping with name and axes", value=data
        )
    try:
        spec = HyperspaceSpec.model_validate(dict(data))
    except ValidationError as exc:
        raise translate(exc, file) from None
    validate_document(spec, file)
    return spec
