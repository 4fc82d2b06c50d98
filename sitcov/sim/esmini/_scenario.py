"""A user's OpenSCENARIO file: its parameters, its ego, and the text esmini is given per run.

A hyperspace binds to a scenario file by element names: an element named like one of the
file's ``ParameterDeclaration``\\ s sets that parameter; the weather elements
(``sitcov.weather.WEATHER_ELEMENTS`` and ``friction``) set the file's ``Environment`` where
it has one (fog visual range, precipitation, cloud state, road friction) and the
perception and dynamics of the run in any case; any other name is an error naming the file
and the element. Per run, :meth:`ScenarioFile.render` writes the file's XML with the
parameters' values substituted in their declarations (esmini then resolves every
``$name`` and ``${expression}`` itself), relative paths made absolute, the road replaced
by ``--road`` when given, and the ego given to an ``ExternalController`` (its pose comes
from sitcov's vehicle dynamics every step, its storyboard actions no longer move it).
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from sitcov.errors import ConfigError
from sitcov.weather._conditions import WEATHER_ELEMENTS

#: Elements that set the weather and the road friction (never scenario parameters).
WEATHER_NAMES = frozenset(WEATHER_ELEMENTS) | {"friction"}
#: The element that picks a file when the scenario is a folder.
SCENARIO_ELEMENT = "scenario"
#: Entity names taken as the ego when no ``ego`` option names it (case-insensitive).
EGO_NAMES = ("ego", "hero", "egovehicle", "ego_vehicle")
#: The controller that hands the ego's pose to the API.
EXTERNAL_CONTROLLER = "ExternalController"


@dataclass(frozen=True)
class Declaration:
    """One ``ParameterDeclaration``: its name, OpenSCENARIO type and default value text."""

    name: str
    type: str
    default: str


def _parse(path: Path) -> ET.Element:
    try:
        root = ET.parse(path).getroot()  # noqa: S314 - the user's own scenario file
    except OSError as exc:
        raise ConfigError(f"{path}: cannot read the scenario: {exc.strerror or exc}") from None
    except ET.ParseError as exc:
        raise ConfigError(file=str(path), field="(xml)", expected=f"valid XML ({exc})") from None
    if root.tag != "OpenSCENARIO" or root.find("Storyboard") is None:
        raise ConfigError(
            file=str(path), field="(root)", expected="an OpenSCENARIO file with a Storyboard"
        )
    return root


class ScenarioFile:
    """An OpenSCENARIO file read once (see the module docstring).

    Args:
        path: the ``.xosc`` file.
        ego: the entity the stack under test drives (default: one named ego/hero, else
            the entity with property ``type=ego_vehicle``, else the first one).
    """

    def __init__(self, path: str | Path, ego: str | None = None) -> None:
        self.path = Path(path).resolve()
        self._root = _parse(self.path)
        self.declarations: dict[str, Declaration] = {}
        for decl in self._root.iterfind("ParameterDeclarations/ParameterDeclaration"):
            name = decl.get("name", "")
            self.declarations[name] = Declaration(
                name, decl.get("parameterType", "string"), decl.get("value", "")
            )
        self.entities = [
            obj.get("name", "") for obj in self._root.iterfind("Entities/ScenarioObject")
        ]
        if not self.entities:
            raise ConfigError(file=str(self.path), field="Entities", expected="a ScenarioObject")
        self.ego = self._ego(ego)
        self.has_environment = self._root.find(".//Init//Environment") is not None

    @property
    def name(self) -> str:
        """The file's name without ``.xosc``."""
        return self.path.stem

    def _ego(self, wanted: str | None) -> str:
        if wanted is not None:
            if wanted not in self.entities:
                raise ConfigError(
                    file=str(self.path),
                    field="ego",
                    value=wanted,
                    expected=f"one of the entities {self.entities}",
                )
            return wanted
        for name in self.entities:
            if name.lower() in EGO_NAMES:
                return name
        for obj in self._root.iterfind("Entities/ScenarioObject"):
            for prop in obj.iterfind(".//Property"):
                if prop.get("name") == "type" and prop.get("value") == "ego_vehicle":
                    return obj.get("name", "")
        return self.entities[0]

    # --- binding ----------------------------------------------------------------------------

    def check_names(self, names: list[str] | tuple[str, ...], *, folder: bool = False) -> None:
        """Refuse an element that is neither a declared parameter nor a weather element.

        Raises:
            ConfigError: ``FILE: element NAME: expected a ParameterDeclaration ...``.
        """
        for name in names:
            if name in WEATHER_NAMES or name in self.declarations:
                continue
            if folder and name == SCENARIO_ELEMENT:
                continue
            declared = ", ".join(sorted(self.declarations)) or "none"
            raise ConfigError(
                f"{self.path}: hyperspace element {name!r}: expected a ParameterDeclaration "
                f"of this scenario (declared: {declared}) or a weather element "
                f"({', '.join(sorted(WEATHER_NAMES))})"
            )

    def parameter_values(self, values: Mapping[str, Any]) -> dict[str, str]:
        """The declared parameters ``values`` sets, as OpenSCENARIO value text.

        Raises:
            ConfigError: a value that does not fit its parameter's type.
        """
        out: dict[str, str] = {}
        for name, value in values.items():
            decl = self.declarations.get(name)
            if decl is not None:
                out[name] = _value_text(self.path, decl, value)
        return out

    def render(
        self,
        values: Mapping[str, Any],
        *,
        road: Path | None = None,
        weather: Mapping[str, Any] | None = None,
        external: bool = True,
    ) -> str:
        """The XML esmini plays for one run (module docstring).

        Args:
            values: the situation's values (only declared parameters are used).
            road: an OpenDRIVE file replacing the file's ``RoadNetwork/LogicFile``.
            weather: the situation's weather values written into the file's Environment
                (None: the file's own environment stays).
            external: hand the ego to the ``ExternalController`` (False: its Init only,
                with no story and no stop trigger: a dry run that drives every entity
                along its route, ``_session.route_paths``).
        """
        root = _copy(self._root)
        params = self.parameter_values(values)
        for decl in root.iterfind("ParameterDeclarations/ParameterDeclaration"):
            name = decl.get("name", "")
            if name in params:
                decl.set("value", params[name])
        self._absolute_paths(root, road)
        if weather:
            for env in root.iterfind(".//Init//Environment"):
                write_environment(env, weather)
        if external:
            _external_ego(root, self.ego)
        else:
            board = root.find("Storyboard")
            for child in list(board if board is not None else ()):
                if child.tag in ("Story", "StopTrigger"):
                    board.remove(child)  # type: ignore[union-attr]
        return ET.tostring(root, encoding="unicode")

    def _absolute_paths(self, root: ET.Element, road: Path | None) -> None:
        base = self.path.parent
        logic = root.find("RoadNetwork/LogicFile")
        if road is not None:
            if logic is None:
                network = root.find("RoadNetwork")
                if network is None:
                    network = ET.SubElement(root, "RoadNetwork")
                logic = ET.SubElement(network, "LogicFile")
            logic.set("filepath", str(Path(road).resolve()))
        elif logic is not None:
            logic.set("filepath", _resolve(base, logic.get("filepath", "")))
        for directory in root.iterfind("CatalogLocations/*/Directory"):
            directory.set("path", _resolve(base, directory.get("path", "")))
        scene = root.find("RoadNetwork/SceneGraphFile")
        if scene is not None:  # headless: no 3D model
            root.find("RoadNetwork").remove(scene)  # type: ignore[union-attr]

    def road_file(self) -> Path | None:
        """The file's OpenDRIVE road (absolute), or None if it names none."""
        logic = self._root.find("RoadNetwork/LogicFile")
        if logic is None or not logic.get("filepath"):
            return None
        return Path(_resolve(self.path.parent, logic.get("filepath", "")))

    def hyperspace_skeleton(self) -> dict[str, Any]:
        """A hyperspace (file form) with one element per declared parameter, to edit: a
        positive ``double`` gets two ranges around its default (0.5x-1x, 1x-1.5x), a
        ``boolean`` both values, anything else its default as the only bin."""
        elements = []
        for decl in self.declarations.values():
            kind = decl.type.lower()
            bins: list[dict[str, Any]] = [{"value": decl.default}]
            if kind == "double":
                try:
                    d = float(decl.default)
                except ValueError:
                    d = math.nan
                if math.isfinite(d) and d > 0:
                    bins = [
                        {"label": "low", "range": [round(0.5 * d, 6), d]},
                        {"label": "high", "range": [d, round(1.5 * d, 6)]},
                    ]
                elif math.isfinite(d):
                    bins = [{"value": d}]
            elif kind in ("integer", "int", "unsignedint", "unsignedshort"):
                bins = [{"value": float(decl.default)}] if _is_number(decl.default) else bins
            elif kind == "boolean":
                bins = [{"value": "false"}, {"value": "true"}]
            elements.append(
                {"name": decl.name, "description": f"{kind} parameter of {self.path.name}",
                 "bins": bins}
            )  # fmt: skip
        return {
            "name": self.name,
            "description": f"The ParameterDeclarations of {self.path.name} (edit the bins).",
            "metadata": {"scenario": str(self.path)},
            "axes": [{"name": "scenario", "elements": elements}],
            "constraints": [],
        }

    def environment_friction(self) -> float | None:
        """The file's ``RoadCondition frictionScaleFactor`` (the run's mu when no ``friction``
        element sets it), or None."""
        cond = self._root.find(".//Init//Environment/RoadCondition")
        if cond is None:
            return None
        text = cond.get("frictionScaleFactor", "")
        if text.startswith("$"):
            name = text.strip("${}")
            text = self.declarations[name].default if name in self.declarations else ""
        try:
            return float(text)
        except ValueError:
            return None


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _copy(root: ET.Element) -> ET.Element:
    return ET.fromstring(ET.tostring(root))  # noqa: S314 - our own serialisation


def _resolve(base: Path, path: str) -> str:
    if not path or path.startswith("$") or Path(path).is_absolute():
        return path
    return str((base / path).resolve())


def _value_text(path: Path, decl: Declaration, value: Any) -> str:
    kind = decl.type.lower()
    try:
        if kind == "double":
            number = float(value)
            if not math.isfinite(number):
                raise ValueError
            return repr(number)
        if kind in ("integer", "int", "unsignedint", "unsignedshort"):
            number = float(value)
            if number != int(number):
                raise ValueError
            return str(int(number))
        if kind == "boolean":
            if isinstance(value, str) and value.lower() in ("true", "false"):
                return value.lower()
            if isinstance(value, bool | int | float) and value in (0, 1):
                return "true" if value else "false"
            raise ValueError
    except (TypeError, ValueError):
        raise ConfigError(
            f"{path}: parameter {decl.name!r}: expected a {kind} value, got {value!r}"
        ) from None
    if isinstance(value, Mapping | list | tuple):
        raise ConfigError(
            f"{path}: parameter {decl.name!r}: expected a {kind} value, got {value!r}"
        )
    return str(value)


def write_environment(env: ET.Element, values: Mapping[str, Any]) -> None:
    """Write sitcov's weather values (CARLA units) into an OpenSCENARIO ``Environment``:
    fog visual range (Koschmieder, as the perception model), precipitation type and
    intensity (share of 100), cloud state, and ``frictionScaleFactor`` = ``friction``."""
    from sitcov.weather._conditions import conditions_from_values

    weather = env.find("Weather")
    if weather is None:
        weather = ET.SubElement(env, "Weather")
    keys = set(values)
    if keys & {"fog_density", "fog_distance"}:
        fog = weather.find("Fog")
        if fog is None:
            fog = ET.SubElement(weather, "Fog")
        visibility = conditions_from_values(values).visibility
        fog.set("visualRange", repr(float(min(100000.0, visibility))))
    if "precipitation" in keys:
        rain = float(values["precipitation"])
        prec = weather.find("Precipitation")
        if prec is None:
            prec = ET.SubElement(weather, "Precipitation")
        prec.set("precipitationType", "rain" if rain > 0 else "dry")
        attr = "precipitationIntensity" if "precipitationIntensity" in prec.attrib else "intensity"
        prec.set(attr, repr(rain / 100.0))
    if "cloudiness" in keys:
        cloud = float(values["cloudiness"])
        state = "free" if cloud < 20 else ("cloudy" if cloud < 60 else "overcast")
        weather.set("cloudState", state)
    if "friction" in keys:
        road = env.find("RoadCondition")
        if road is None:
            road = ET.SubElement(env, "RoadCondition")
        road.set("frictionScaleFactor", repr(float(values["friction"])))


def _external_ego(root: ET.Element, ego: str) -> None:
    """Append an ExternalController assignment to the ego's Init actions (after its
    teleport and route, so both still apply)."""
    actions = root.find("Storyboard/Init/Actions")
    if actions is None:
        init = root.find("Storyboard/Init")
        if init is None:
            init = ET.SubElement(root.find("Storyboard"), "Init")  # type: ignore[arg-type]
        actions = ET.SubElement(init, "Actions")
    private = next((p for p in actions.iterfind("Private") if p.get("entityRef") == ego), None)
    if private is None:
        private = ET.SubElement(actions, "Private", entityRef=ego)
    action = ET.SubElement(private, "PrivateAction")
    ctrl = ET.SubElement(action, "ControllerAction")
    assign = ET.SubElement(
        ctrl, "AssignControllerAction", activateLateral="true", activateLongitudinal="true"
    )
    controller = ET.SubElement(assign, "Controller", name="sitcov_stack")
    props = ET.SubElement(controller, "Properties")
    ET.SubElement(props, "Property", name="esminiController", value=EXTERNAL_CONTROLLER)


def scenario_files(folder: Path) -> dict[str, Path]:
    """The ``.xosc`` files of a folder by name (no suffix), sorted.

    Raises:
        ConfigError: the folder has none.
    """
    files = {p.stem: p for p in sorted(Path(folder).glob("*.xosc"))}
    if not files:
        raise ConfigError(file=str(folder), field="scenario", expected="a folder of .xosc files")
    return files
