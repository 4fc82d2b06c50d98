"""Hyperspace elements as ODD attributes (ISO 34503 / BSI PAS 1883 terms, OpenLABEL classes).

A situation's bins are CARLA settings ("precipitation 60"); a safety case speaks of the
operational design domain ("moderate rainfall, 30 mm/h"). The shipped table
``data/taxonomy.yaml`` maps every element of the shipped hyperspaces to one attribute with
a physical quantity and its classes; a hyperspace may override or add elements under
``metadata: {odd: {...}}``. Junction type and road users come from the hyperspace's map
and the intersection bins' values.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError

from sitcov.errors import ConfigError
from sitcov.hyperspace import Hyperspace, Situation

#: attribute paths of the attributes that do not come from one element
JUNCTION_ATTRIBUTE = "scenery.junction.type"
ROAD_USER_ATTRIBUTE = "dynamic_elements.traffic.agent_type"
BEHAVIOUR_ATTRIBUTE = "dynamic_elements.traffic.behaviour"


def _wind_speed(value: float) -> float:
    from sitcov.weather import conditions_from_values

    return conditions_from_values({"wind_intensity": value}).wind_speed


def _fog_visibility(value: float) -> float:
    from sitcov.weather import conditions_from_values

    return conditions_from_values({"fog_density": value}).visibility


#: named conversions a taxonomy entry may use (``quantity: {from: NAME}``); each takes the
#: bin's value in CARLA units and returns the physical quantity, through sitcov.weather so
#: that the ODD speaks of the same visibility and wind the simulation uses.
CONVERSIONS: dict[str, Callable[[float], float]] = {
    "wind_speed": _wind_speed,
    "fog_visibility": _fog_visibility,
}


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class QuantitySpec(_Strict):
    unit: str = ""
    scale: float | None = None
    from_: str | None = Field(None, alias="from")


class ClassSpec(_Strict):
    label: str = Field(min_length=1)
    max: float | None = None


class CategoriesSpec(_Strict):
    source: str = ""
    classes: list[ClassSpec] = Field(min_length=1)


class AttributeSpec(_Strict):
    """How one element's bins become one ODD attribute."""

    attribute: str = Field(min_length=1)
    openlabel: str = Field(min_length=1)
    pas1883: str = ""
    quantity: QuantitySpec = QuantitySpec()
    categories: CategoriesSpec | None = None


class _TableSpec(_Strict):
    elements: dict[str, AttributeSpec]
    junctions: dict[str, dict[str, str]] = Field(default_factory=dict)
    road_users: dict[str, dict[str, str]] = Field(default_factory=dict)
    behaviours: dict[str, str] = Field(default_factory=dict)


@dataclass(frozen=True)
class AttributeValue:
    """One ODD attribute of one situation.

    Attributes:
        attribute: dotted taxonomy path (``environment.weather.rainfall``).
        category: the class the situation falls in (``moderate``), or the value's name for
            enumerated attributes (``pedestrian``).
        quantity: the physical quantity (``30.0``), None for enumerated attributes.
        unit: the quantity's unit (``mm/h``).
        openlabel: the ASAM OpenLABEL 1.0.0 ontology class.
        pas1883: the BSI PAS 1883 clause.
        element: the hyperspace element it comes from (None for map-level attributes).
    """

    attribute: str
    category: str
    quantity: float | None = None
    unit: str = ""
    openlabel: str = ""
    pas1883: str = ""
    element: str | None = None

    def to_dict(self) -> dict[str, Any]:
        """JSON form; a non-finite quantity (clear air's visibility) becomes its string."""
        q = self.quantity
        quantity = q if q is None or math.isfinite(q) else str(q)
        return {
            "attribute": self.attribute,
            "category": self.category,
            "quantity": quantity,
            "unit": self.unit,
            "openlabel": self.openlabel,
            "pas1883": self.pas1883,
            "element": self.element,
        }


@cache
def _shipped_table() -> _TableSpec:
    text = resources.files("sitcov.evidence").joinpath("data/taxonomy.yaml").read_text()
    return _TableSpec.model_validate(yaml.safe_load(text))


def _category(spec: AttributeSpec, quantity: float) -> str:
    if spec.categories is None:
        return f"{quantity:g}"
    for cls in spec.categories.classes:
        if cls.max is None or quantity <= cls.max:
            return cls.label
    return spec.categories.classes[-1].label


class Taxonomy:
    """The ODD attributes of a hyperspace's situations.

    Args:
        hyperspace: the hyperspace; an element's ``metadata.odd`` (the keys of an entry of
            ``data/taxonomy.yaml``) overrides the shipped entry of the same name.

    Raises:
        ConfigError: an element's ``metadata.odd`` is malformed or names an unknown
            conversion.
    """

    def __init__(self, hyperspace: Hyperspace) -> None:
        table = _shipped_table()
        self.hyperspace = hyperspace
        self._junctions = table.junctions
        self._road_users = table.road_users
        self._behaviours = table.behaviours
        self.specs: dict[str, AttributeSpec] = {}
        for element in hyperspace.elements:
            override = element.metadata.get("odd")
            if override is not None:
                self.specs[element.name] = self._element_spec(element.name, override)
            elif element.name in table.elements:
                self.specs[element.name] = table.elements[element.name]
        map_name = str(hyperspace.metadata.get("map", "")) or None
        self.junction = self._junctions.get(map_name) if map_name else None

    def _element_spec(self, name: str, data: Any) -> AttributeSpec:
        where = f"hyperspace {self.hyperspace.name!r}"
        try:
            spec = AttributeSpec.model_validate(data)
        except ValidationError as exc:
            err = exc.errors()[0]
            loc = ".".join(str(p) for p in err["loc"])
            raise ConfigError(
                file=where, field=f"{name}.metadata.odd.{loc}", expected=err["msg"]
            ) from None
        conversion = spec.quantity.from_
        if conversion is not None and conversion not in CONVERSIONS:
            raise ConfigError(
                file=where,
                field=f"{name}.metadata.odd.quantity.from",
                value=conversion,
                expected=" | ".join(sorted(CONVERSIONS)),
            )
        return spec

    @property
    def unmapped(self) -> list[str]:
        """Elements with no attribute (neither shipped nor in their metadata), except the
        intersection and actor elements, whose bins carry road users instead."""
        out = []
        for element in self.hyperspace.elements:
            if element.name in self.specs:
                continue
            if not any(isinstance(b.value, Mapping) for b in element.bins):
                out.append(element.name)
        return out

    def quantity(self, element: str, value: Any) -> float | None:
        """The physical quantity of an element's value (None when it is not a number)."""
        spec = self.specs[element]
        try:
            number = float(value)
        except (TypeError, ValueError):
            return None
        if spec.quantity.from_ is not None:
            return float(CONVERSIONS[spec.quantity.from_](number))
        return number * (1.0 if spec.quantity.scale is None else spec.quantity.scale)

    def category(self, element: str, value: Any) -> str:
        """The class of an element's value (the value itself when it is not a number)."""
        q = self.quantity(element, value)
        return _category(self.specs[element], q) if q is not None else str(value)

    def attributes(self, situation: Situation) -> list[AttributeValue]:
        """Every ODD attribute of ``situation``: one per mapped element, the junction type,
        and one ``agent_type`` (and behaviour, where OpenLABEL names it) per road user."""
        out: list[AttributeValue] = []
        if self.junction is not None:
            out.append(
                AttributeValue(
                    JUNCTION_ATTRIBUTE,
                    self.junction["label"],
                    None,
                    "",
                    self.junction.get("openlabel", ""),
                    self.junction.get("pas1883", ""),
                )
            )
        for name, value in situation.values.items():
            spec = self.specs.get(name)
            if spec is not None:
                q = self.quantity(name, value)
                category = self.category(name, value)
                out.append(
                    AttributeValue(
                        spec.attribute,
                        category,
                        q,
                        spec.quantity.unit,
                        spec.openlabel,
                        spec.pas1883,
                        name,
                    )
                )
            elif isinstance(value, Mapping):
                out += self._road_user(name, value)
        return out

    def _road_user(self, element: str, value: Mapping[str, Any]) -> list[AttributeValue]:
        kind = value.get("kind") or ("car" if "ov" in value else None)
        if kind is None:
            return []
        user = self._road_users.get(str(kind), {})
        out = [
            AttributeValue(
                ROAD_USER_ATTRIBUTE,
                str(kind),
                None,
                "",
                user.get("openlabel", ""),
                "5.4.a.4",
                element,
            )
        ]
        conflict = value.get("type")
        if conflict is not None:
            out.append(
                AttributeValue(
                    BEHAVIOUR_ATTRIBUTE,
                    str(conflict),
                    None,
                    "",
                    self._behaviours.get(str(conflict), ""),
                    "",
                    element,
                )
            )
        return out


def attribute_map(values: list[AttributeValue]) -> dict[str, list[AttributeValue]]:
    """Attribute path -> its values in a situation (road users may appear several times)."""
    out: dict[str, list[AttributeValue]] = {}
    for v in values:
        out.setdefault(v.attribute, []).append(v)
    return out
