"""CARLA map files: which town and junction a campaign uses, and where everything starts.

A map file is YAML, in CARLA's own coordinates (x, y [m]; yaw [deg], left-handed as CARLA
reports them), so positions can be copied from the simulator. ``maps/town03.yaml`` holds the
paper's Town03 T-junction (from the authors' released code); another junction or town is
another file::

    name: town03-t-junction
    town: Town03
    junction: {x: -74.63, y: -136.34, radius: 25.0}
    conflict_points: {c1: [-74.63, -136.34], ...}
    ego_spawns: {B: {x: -74.32, y: -50.0, yaw: 270.0}, ...}
    ov_spawns: {B: {...}, B-L: {...}, ...}   # a movement key wins over its leg key
    goals: {B: [-85.2, -30.0], ...}

Errors name the file, the field, the value and what was expected.
"""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import Any

import yaml
from pydantic import BaseModel, ConfigDict, Field, ValidationError, model_validator

from sitcov.errors import ConfigError

MAPS_DIR = Path(__file__).parent / "maps"


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class SpawnPoint(_Strict):
    """A spawn pose in CARLA coordinates: x, y, z [m], yaw [deg]."""

    x: float
    y: float
    z: float = 0.5
    yaw: float


class Junction(_Strict):
    """The junction centre [m] and the radius [m] of the area a friction trigger covers."""

    x: float
    y: float
    radius: float = Field(default=25.0, gt=0)


class CarlaMap(_Strict):
    """A validated map file (see the module docstring)."""

    name: str = Field(min_length=1)
    town: str = Field(min_length=1)
    description: str = ""
    junction: Junction
    conflict_points: dict[str, tuple[float, float]] = Field(min_length=1)
    ego_spawns: dict[str, SpawnPoint] = Field(min_length=2)
    ov_spawns: dict[str, SpawnPoint] = Field(min_length=2)
    goals: dict[str, tuple[float, float]] = Field(min_length=2)
    ego_blueprint: str = "vehicle.tesla.model3"
    ov_blueprint: str = "vehicle.audi.tt"
    #: pedestrians (a ``walker.pedestrian.*`` blueprint) and cyclists (a two-wheeled
    #: ``vehicle.*`` blueprint)
    walker_blueprint: str = Field(
        default="walker.pedestrian.0001", pattern=r"^walker\.pedestrian\."
    )
    bicycle_blueprint: str = Field(default="vehicle.diamondback.century", pattern=r"^vehicle\.")
    #: the embedded map (``sitcov.sim.embedded``) whose junction this one matches: the routes
    #: of pedestrians, cyclists and extra cars come from it (``actor_route``), its centre
    #: placed on ``junction`` and turned by ``embedded_rotation_deg`` (counter-clockwise in
    #: sitcov's right-handed frame)
    embedded_map: str = Field(default="t-junction", min_length=1)
    embedded_rotation_deg: float = 0.0
    goal_tolerance: float = Field(default=3.0, gt=0)
    source: str = ""
    #: "EGO/OV" -> the ego's distance to the conflict point [m] at which the OV stops
    #: synchronising (sitcov.sim._adversary); situations without an entry use the fallback.
    switch_distances: dict[str, float] = Field(default_factory=dict)

    @model_validator(mode="after")
    def _legs_consistent(self) -> CarlaMap:
        legs = set(self.goals)
        for field in ("ego_spawns", "ov_spawns"):
            for key in getattr(self, field):
                leg = key.split("-", 1)[0]
                if leg not in legs:
                    raise ValueError(
                        f"{field}.{key}: leg {leg!r} has no goal; legs with goals: "
                        f"{', '.join(sorted(legs))}"
                    )
        return self

    @property
    def legs(self) -> tuple[str, ...]:
        """The leg names (keys of ``goals``)."""
        return tuple(self.goals)

    def ego_spawn(self, movement: str) -> SpawnPoint:
        """Ego spawn for a movement ``"X-Y"`` (from leg X to leg Y)."""
        return self._spawn(self.ego_spawns, movement, "ego_spawns")

    def ov_spawn(self, movement: str) -> SpawnPoint:
        """OV spawn for a movement; a ``"X-Y"`` entry wins over the leg entry ``"X"``."""
        return self._spawn(self.ov_spawns, movement, "ov_spawns")

    def goal(self, movement: str) -> tuple[float, float]:
        """Goal of a movement ``"X-Y"``: the goal of leg Y."""
        leg = _split(movement)[1]
        if leg not in self.goals:
            raise ConfigError(field="goals", value=leg, expected=f"one of {sorted(self.goals)}")
        return self.goals[leg]

    def conflict_point(self, label: str) -> tuple[float, float]:
        """Position [m] of a named conflict point (``c1``, ``c2``, ``c4`` in Town03)."""
        if label not in self.conflict_points:
            raise ConfigError(
                field="conflict_points",
                value=label,
                expected=f"one of {sorted(self.conflict_points)} (map {self.name!r})",
            )
        return self.conflict_points[label]

    def switch_distance(self, ego_move: str, ov_move: str) -> float | None:
        """The situation's ``switch_distances`` entry [m], or None if the file has none."""
        return self.switch_distances.get(f"{ego_move}/{ov_move}")

    def _spawn(self, table: dict[str, SpawnPoint], movement: str, field: str) -> SpawnPoint:
        start, _ = _split(movement)
        if movement in table:
            return table[movement]
        if start in table:
            return table[start]
        raise ConfigError(
            field=f"{self.name}: {field}", value=movement, expected=f"one of {sorted(table)}"
        )


def _split(movement: str) -> tuple[str, str]:
    parts = str(movement).split("-")
    if len(parts) != 2 or not all(parts):
        raise ConfigError(field="intsit", value=movement, expected="a movement 'X-Y' (legs)")
    return parts[0], parts[1]


def available_maps() -> list[str]:
    """Names of the map files shipped with sitcov (file stems)."""
    return sorted(p.stem for p in MAPS_DIR.glob("*.yaml"))


def load_carla_map(source: str | Path = "Town03") -> CarlaMap:
    """Load a map file by shipped name (``Town03``, case-insensitive) or YAML path.

    Raises:
        ConfigError: unknown name, unreadable file, or invalid content (file, field,
            value and expectation in the message).
    """
    path = Path(source)
    if not (path.suffix in (".yaml", ".yml") and path.exists()):
        shipped = MAPS_DIR / f"{str(source).lower()}.yaml"
        if not shipped.exists():
            raise ConfigError(
                field="map",
                value=str(source),
                expected=f"a map file path or one of {available_maps()}",
            )
        path = shipped
    return _load_path(str(path.resolve()))


@lru_cache(maxsize=16)
def _load_path(path: str) -> CarlaMap:
    try:
        data: Any = yaml.safe_load(Path(path).read_text(encoding="utf-8"))
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read map file: {exc}") from None
    if not isinstance(data, dict):
        raise ConfigError(file=path, field="(top level)", value=data, expected="a mapping")
    try:
        return CarlaMap.model_validate(data)
    except ValidationError as exc:
        err = exc.errors()[0]
        loc = ".".join(str(p) for p in err["loc"]) or "(top level)"
        value = err.get("input")
        raise ConfigError(
            file=path,
            field=loc,
            value=value if not isinstance(value, dict) else None,
            expected=err["msg"].removeprefix("Value error, "),
        ) from None
