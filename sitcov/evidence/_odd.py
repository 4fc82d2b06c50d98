"""An ODD file: which attribute values are inside the operational design domain.

Format (YAML; docs/evidence.md)::

    name: urban-junctions-daylight
    approach: permissive        # attributes not listed are inside (restrictive: outside)
    attributes:
      environment.weather.rainfall: {max: 7.6}            # on the quantity (mm/h)
      environment.particulates.visibility: {min: 200}     # metres
      scenery.junction.type: {in: [t_junction, crossroads]}
      dynamic_elements.traffic.agent_type: {in: [car, cyclist]}

``min``/``max`` bound the physical quantity (inclusive), ``in`` lists the allowed classes
(or names, for enumerated attributes). A situation is in the ODD when every value of every
listed attribute is allowed; with ``approach: restrictive`` an attribute the file does not
list puts the situation outside. ISO 34503 calls these the permissive and restrictive
ways of writing an ODD.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from sitcov.errors import ConfigError
from sitcov.evidence._taxonomy import AttributeValue


class Limit(BaseModel):
    """What one attribute may take inside the ODD."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)

    min: float | None = None
    max: float | None = None
    in_: list[str] | None = Field(None, alias="in")

    @model_validator(mode="after")
    def _something(self) -> Limit:
        if self.min is None and self.max is None and self.in_ is None:
            raise ValueError("at least one of min, max, in")
        if self.min is not None and self.max is not None and self.min > self.max:
            raise ValueError(f"min {self.min} above max {self.max}")
        return self

    def allows(self, value: AttributeValue) -> bool:
        """True when ``value`` is inside this limit."""
        if self.in_ is not None and value.category not in self.in_:
            return False
        if self.min is None and self.max is None:
            return True
        q = value.quantity
        if q is None or math.isnan(q):
            return False
        return (self.min is None or q >= self.min) and (self.max is None or q <= self.max)

    def text(self) -> str:
        parts = []
        if self.min is not None:
            parts.append(f">= {self.min:g}")
        if self.max is not None:
            parts.append(f"<= {self.max:g}")
        if self.in_ is not None:
            parts.append("in {" + ", ".join(self.in_) + "}")
        return " and ".join(parts)


class OddSpec(BaseModel):
    """A whole ODD file."""

    model_config = ConfigDict(extra="forbid", frozen=True)

    name: str = Field("odd", min_length=1)
    description: str = ""
    approach: Literal["permissive", "restrictive"] = "permissive"
    attributes: dict[str, Limit] = Field(default_factory=dict)


@dataclass(frozen=True)
class Odd:
    """A loaded ODD and the file it came from (None for the everything-ODD)."""

    spec: OddSpec
    file: str | None = None

    @classmethod
    def everything(cls) -> Odd:
        """The ODD that contains every situation (no ODD file given)."""
        return cls(OddSpec(name="whole hyperspace (no ODD file given)"))

    def contains(self, values: list[AttributeValue]) -> tuple[bool, list[str]]:
        """(inside?, the reasons it is outside) for one situation's attribute values."""
        reasons = []
        seen = set()
        for v in values:
            seen.add(v.attribute)
            limit = self.spec.attributes.get(v.attribute)
            if limit is None:
                if self.spec.approach == "restrictive":
                    reasons.append(f"{v.attribute} = {v.category}: not in the ODD's list")
            elif not limit.allows(v):
                q = f" ({v.quantity:g} {v.unit})" if v.quantity is not None else ""
                reasons.append(f"{v.attribute} = {v.category}{q}: ODD needs {limit.text()}")
        return not reasons, reasons

    def unused(self, attributes: set[str]) -> list[str]:
        """Attributes the ODD file names that no situation has (probably a typo)."""
        return sorted(set(self.spec.attributes) - attributes)


def load_odd(path: str | Path | None) -> Odd:
    """Read an ODD YAML file (None: the ODD that contains everything).

    Raises:
        ConfigError: the file is missing, not YAML, or a field is wrong (named).
    """
    if path is None:
        return Odd.everything()
    file = str(path)
    try:
        data = yaml.safe_load(Path(path).read_text())
    except FileNotFoundError:
        raise ConfigError(file=file, expected="an existing ODD file") from None
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(file=file, expected=f"a readable YAML file ({exc})") from None
    if not isinstance(data, dict):
        raise ConfigError(
            file=file,
            field="(top level)",
            value=type(data).__name__,
            expected="a mapping with name, approach and attributes",
        )
    try:
        return Odd(OddSpec.model_validate(data), file)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"]) or "(top level)"
        raise ConfigError(
            file=file, field=loc, value=_given(data, err["loc"]), expected=err["msg"]
        ) from None


def _given(data: Any, loc: tuple[Any, ...]) -> Any:
    for key in loc:
        in_dict = isinstance(data, dict) and key in data
        in_list = isinstance(data, list) and isinstance(key, int) and key < len(data)
        if in_dict or in_list:
            data = data[key]
        else:
            return None
    return data
