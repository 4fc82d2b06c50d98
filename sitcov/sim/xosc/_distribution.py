"""A campaign as one OpenSCENARIO ``ParameterValueDistribution`` over its runs.

OpenSCENARIO's way to say "these N concrete scenarios of one logical scenario": a template
scenario whose parameters pick what differs, and a distribution file listing the parameter
values of each concrete one. Here the distribution is deterministic: one
``ParameterValueSet`` per exported run, carrying its situation's bins (``bin_*``), its
verdict (``sitcov_*``) and what the template needs to play it. An engine expands it
(``esmini --osc TEMPLATE --param_dist DIST --param_permutation I`` plays run I;
``--return_nr_permutations`` counts them).

What the template takes from the parameters, all through catalogs (the one place where
OpenSCENARIO lets a parameter choose a whole element):

- one ``ScenarioObject`` per road-user slot seen in the campaign (``hero``, ``ov``,
  ``actor2`` ...), each a ``CatalogReference`` whose entry (``$<slot>_entity``) is that
  run's car, bicycle or pedestrian; a slot the run does not use gets the tiny ``absent``
  car far off the map, deleted at once;
- its start pose (``$<slot>_x``, ``_y``, ``_h``) and its stored trajectory
  (``$<slot>_trajectory``, a trajectory catalog entry), the time it leaves the world
  (``$<slot>_leave``), the weather (``$environment``) and the end time (``$end_time``).

Built from the per-run files that :func:`sitcov.sim.xosc.run_scenario` wrote (one road file
for all of them), so both say exactly the same.
"""

from __future__ import annotations

import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path

from sitcov.errors import ConfigError

#: Folder of the catalogs, beside the template.
CATALOG_DIR = "catalogs"
#: Where an unused slot waits [m] (x and y), before it is deleted.
FAR = -10000.0
#: A time no run reaches [s] (a slot that never leaves).
NEVER = 1.0e9

_HEADER = {"revMajor": "1", "revMinor": "2", "date": "2024-01-01T00:00:00", "author": "sitcov"}


def _el(tag: str, attrib: dict[str, str] | None = None, *children: ET.Element) -> ET.Element:
    element = ET.Element(tag, attrib or {})
    element.extend(children)
    return element


def _doc(description: str, body: ET.Element) -> ET.ElementTree:
    root = _el("OpenSCENARIO", {}, _el("FileHeader", {**_HEADER, "description": description}))
    root.append(body)
    ET.indent(root)
    return ET.ElementTree(root)


def _condition(name: str, inner: ET.Element, edge: str = "rising") -> ET.Element:
    return _el("Condition", {"name": name, "delay": "0", "conditionEdge": edge}, inner)


def _time_after(name: str, value: str, edge: str = "rising") -> ET.Element:
    return _condition(
        name,
        _el(
            "ByValueCondition",
            {},
            _el("SimulationTimeCondition", {"value": value, "rule": "greaterThan"}),
        ),
        edge,
    )


def _trigger(tag: str, *conditions: ET.Element) -> ET.Element:
    return _el(tag, {}, *(_el("ConditionGroup", {}, c) for c in conditions))


class _Run:
    """What the template needs of one exported run file."""

    def __init__(self, path: Path) -> None:
        root = ET.parse(path).getroot()
        self.path = path
        self.params = {
            d.get("name", ""): (d.get("parameterType", "string"), d.get("value", ""))
            for d in root.iterfind("ParameterDeclarations/ParameterDeclaration")
        }
        self.road = root.find("RoadNetwork/LogicFile").get("filepath", "")  # type: ignore[union-attr]
        self.entities = {o.get("name", ""): o[0] for o in root.iterfind("Entities/ScenarioObject")}
        self.start: dict[str, ET.Element] = {}
        for private in root.iterfind("Storyboard/Init/Actions/Private"):
            pos = private.find("PrivateAction/TeleportAction/Position/WorldPosition")
            if pos is not None:
                self.start[private.get("entityRef", "")] = pos
        self.environment = root.find(
            "Storyboard/Init/Actions/GlobalAction/EnvironmentAction/Environment"
        )
        self.trajectories: dict[str, ET.Element] = {}
        self.leave: dict[str, str] = {}
        for group in root.iter("ManeuverGroup"):
            name = group.find("Actors/EntityRef").get("entityRef", "")  # type: ignore[union-attr]
            traj = group.find(".//FollowTrajectoryAction/TrajectoryRef/Trajectory")
            if traj is not None:
                self.trajectories[name] = traj
            for event in group.iter("Event"):
                if event.find(".//DeleteEntityAction") is not None:
                    cond = event.find(".//SimulationTimeCondition")
                    self.leave[name] = cond.get("value", "0")  # type: ignore[union-attr]
        end = root.find(
            ".//StopTrigger//Condition[@name='stored_run_ended']//SimulationTimeCondition"
        )
        self.end = end.get("value", "60") if end is not None else "60"


def write_distribution(
    runs: Sequence[str | Path], out: str | Path, name: str = "campaign"
) -> tuple[Path, Path]:
    """Write ``<name>_template.xosc``, ``<name>_distribution.xosc`` and the catalogs into
    ``out`` (the folder of the run files); the template's and the distribution's paths.

    Raises:
        ConfigError: no runs, or runs on different road files.
    """
    out = Path(out)
    items = [_Run(Path(p)) for p in runs]
    if not items:
        raise ConfigError(field="runs", value=0, expected="at least one exported run")
    roads = {r.road for r in items}
    if len(roads) != 1:
        raise ConfigError(
            field="road",
            value=sorted(roads),
            expected="one road file for every run of a distribution",
        )
    slots: list[str] = []
    for r in items:
        slots += [s for s in r.entities if s not in slots]
    keys = [f"r{k}" for k in range(len(items))]
    catalog_name = f"sitcov_{name}"
    _write_catalog(out, catalog_name, items, keys)
    template = out / f"{name}_template.xosc"
    sets = [_assignments(r, key, slots, catalog_name) for r, key in zip(items, keys, strict=True)]
    # every set assigns every parameter the template declares (runs may differ in bins)
    declared: dict[str, tuple[str, str]] = {}
    for s in sets:
        for k, (kind, value) in s.items():
            declared.setdefault(k, (kind, value))
    blank = {k: (kind, "" if kind == "string" else value) for k, (kind, value) in declared.items()}
    sets = [{k: s.get(k, blank[k]) for k in declared} for s in sets]
    _template(sets[0], slots, roads.pop(), catalog_name).write(
        template, encoding="utf-8", xml_declaration=True
    )
    dist = out / f"{name}_distribution.xosc"
    value_sets = [
        _el(
            "ParameterValueSet",
            {},
            *(
                _el("ParameterAssignment", {"parameterRef": k, "value": v})
                for k, (_, v) in s.items()
            ),
        )
        for s in sets
    ]
    body = _el(
        "ParameterValueDistribution",
        {},
        _el("ScenarioFile", {"filepath": template.name}),
        _el(
            "Deterministic",
            {},
            _el(
                "DeterministicMultiParameterDistribution",
                {},
                _el("ValueSetDistribution", {}, *value_sets),
            ),
        ),
    )
    _doc(f"sitcov {name}: {len(items)} runs", body).write(
        dist, encoding="utf-8", xml_declaration=True
    )
    return template, dist


def _write_catalog(out: Path, catalog_name: str, items: list[_Run], keys: list[str]) -> None:
    vehicles, pedestrians, trajectories, environments = [], [], [], []
    absent = _el(
        "Vehicle",
        {"name": "absent", "vehicleCategory": "car"},
        _el(
            "BoundingBox",
            {},
            _el("Center", {"x": "0", "y": "0", "z": "0.05"}),
            _el("Dimensions", {"width": "0.1", "length": "0.1", "height": "0.1"}),
        ),
        _el("Performance", {"maxSpeed": "1", "maxAcceleration": "1", "maxDeceleration": "1"}),
        _el(
            "Axles",
            {},
            _el(
                "FrontAxle",
                {
                    "maxSteering": "0.5",
                    "wheelDiameter": "0.05",
                    "trackWidth": "0.05",
                    "positionX": "0.05",
                    "positionZ": "0.025",
                },
            ),
            _el(
                "RearAxle",
                {
                    "maxSteering": "0",
                    "wheelDiameter": "0.05",
                    "trackWidth": "0.05",
                    "positionX": "0",
                    "positionZ": "0.025",
                },
            ),
        ),
        _el("Properties"),
    )
    vehicles.append(absent)
    far = {"x": str(FAR), "y": str(FAR), "z": "0", "h": "0"}
    trajectories.append(
        _el(
            "Trajectory",
            {"name": "absent", "closed": "false"},
            _el(
                "Shape",
                {},
                _el(
                    "Polyline",
                    {},
                    *(
                        _el("Vertex", {"time": t}, _el("Position", {}, _el("WorldPosition", far)))
                        for t in ("0", "1")
                    ),
                ),
            ),
        ),
    )
    for run, key in zip(items, keys, strict=True):
        for slot, entity in run.entities.items():
            copy = ET.fromstring(ET.tostring(entity))
            copy.set("name", f"{key}_{slot}")
            (pedestrians if copy.tag == "Pedestrian" else vehicles).append(copy)
        for slot, traj in run.trajectories.items():
            copy = ET.fromstring(ET.tostring(traj))
            copy.set("name", f"{key}_{slot}")
            trajectories.append(copy)
        if run.environment is not None:
            copy = ET.fromstring(ET.tostring(run.environment))
            copy.set("name", key)
            environments.append(copy)
    folder = out / CATALOG_DIR
    folder.mkdir(parents=True, exist_ok=True)
    # one catalog per element type: esmini types a catalog by its entries
    for kind, entries in (
        ("vehicles", vehicles),
        ("pedestrians", pedestrians),
        ("environments", environments),
        ("trajectories", trajectories),
    ):
        if entries:
            catalog = _el("Catalog", {"name": f"{catalog_name}_{kind}"}, *entries)
            path = folder / f"{catalog_name}_{kind}.xosc"
            _doc(f"sitcov {catalog_name} {kind}", catalog).write(
                path, encoding="utf-8", xml_declaration=True
            )


def _assignments(run: _Run, key: str, slots: list[str], catalog: str) -> dict[str, tuple[str, str]]:
    """Parameter -> (type, value) of one run in the template."""
    values: dict[str, tuple[str, str]] = dict(run.params)
    values["environment"] = ("string", key if run.environment is not None else "")
    values["end_time"] = ("double", run.end)
    for slot in slots:
        used = slot in run.entities and slot in run.trajectories
        pos = run.start.get(slot)
        values[f"{slot}_entity"] = ("string", f"{key}_{slot}" if used else "absent")
        pedestrian = used and run.entities[slot].tag == "Pedestrian"
        values[f"{slot}_catalog"] = (
            "string",
            f"{catalog}_{'pedestrians' if pedestrian else 'vehicles'}",
        )
        values[f"{slot}_trajectory"] = ("string", f"{key}_{slot}" if used else "absent")
        for axis in ("x", "y", "h"):
            default = {"x": str(FAR), "y": str(FAR), "h": "0"}[axis]
            values[f"{slot}_{axis}"] = (
                "double",
                pos.get(axis, "0") if used and pos is not None else default,
            )
        values[f"{slot}_leave"] = ("double", run.leave.get(slot, str(NEVER)) if used else "0")
    return values


def _template(
    values: dict[str, tuple[str, str]], slots: list[str], road: str, catalog: str
) -> ET.ElementTree:
    root = _el(
        "OpenSCENARIO",
        {},
        _el("FileHeader", {**_HEADER, "description": f"sitcov template ({catalog})"}),
    )
    root.append(
        _el(
            "ParameterDeclarations",
            {},
            *(
                _el("ParameterDeclaration", {"name": k, "parameterType": t, "value": v})
                for k, (t, v) in values.items()
            ),
        )
    )
    loc = {"Directory": {"path": CATALOG_DIR}}
    root.append(
        _el(
            "CatalogLocations",
            {},
            *(
                _el(tag, {}, _el("Directory", loc["Directory"]))
                for tag in (
                    "VehicleCatalog",
                    "PedestrianCatalog",
                    "EnvironmentCatalog",
                    "TrajectoryCatalog",
                )
            ),
        )
    )
    root.append(_el("RoadNetwork", {}, _el("LogicFile", {"filepath": road})))

    def ref(kind: str, entry: str) -> ET.Element:
        return _el("CatalogReference", {"catalogName": kind, "entryName": entry})

    root.append(
        _el(
            "Entities",
            {},
            *(
                _el("ScenarioObject", {"name": s}, ref(f"${s}_catalog", f"${s}_entity"))
                for s in slots
            ),
        )
    )
    actions = _el("Actions")
    if values["environment"][1]:
        actions.append(
            _el(
                "GlobalAction",
                {},
                _el("EnvironmentAction", {}, ref(f"{catalog}_environments", "$environment")),
            )
        )
    for s in slots:
        pos = {"x": f"${s}_x", "y": f"${s}_y", "z": "0", "h": f"${s}_h"}
        actions.append(
            _el(
                "Private",
                {"entityRef": s},
                _el(
                    "PrivateAction",
                    {},
                    _el("TeleportAction", {}, _el("Position", {}, _el("WorldPosition", pos))),
                ),
            )
        )
    stories = []
    start = _trigger("StartTrigger", _time_after("start", "-1", "none"))
    for s in slots:
        follow = _el(
            "FollowTrajectoryAction",
            {},
            _el("TrajectoryRef", {}, ref(f"{catalog}_trajectories", f"${s}_trajectory")),
            _el(
                "TimeReference",
                {},
                _el("Timing", {"domainAbsoluteRelative": "absolute", "scale": "1", "offset": "0"}),
            ),
            _el("TrajectoryFollowingMode", {"followingMode": "position"}),
        )
        drive = _el(
            "Event",
            {"name": f"{s}_as_stored", "priority": "override"},
            _el(
                "Action",
                {"name": f"{s}_trajectory"},
                _el("PrivateAction", {}, _el("RoutingAction", {}, follow)),
            ),
            _trigger("StartTrigger", _time_after("start", "-1", "none")),
        )
        leave = _el(
            "Event",
            {"name": f"{s}_leaves", "priority": "parallel"},
            _el(
                "Action",
                {"name": f"{s}_delete"},
                _el(
                    "GlobalAction",
                    {},
                    _el("EntityAction", {"entityRef": s}, _el("DeleteEntityAction")),
                ),
            ),
            _trigger("StartTrigger", _time_after(f"{s}_route_end", f"${s}_leave")),
        )
        events = [drive] if s == "hero" else [drive, leave]
        group = _el(
            "ManeuverGroup",
            {"name": f"{s}_group", "maximumExecutionCount": "1"},
            _el(
                "Actors", {"selectTriggeringEntities": "false"}, _el("EntityRef", {"entityRef": s})
            ),
            _el("Maneuver", {"name": f"{s}_maneuver"}, *events),
        )
        act = _el("Act", {"name": f"act_{s}"}, group, ET.fromstring(ET.tostring(start)))
        stories.append(_el("Story", {"name": f"story_{s}"}, act))
    collisions = [
        _condition(
            f"hero_hits_{s}",
            _el(
                "ByEntityCondition",
                {},
                _el(
                    "TriggeringEntities",
                    {"triggeringEntitiesRule": "any"},
                    _el("EntityRef", {"entityRef": "hero"}),
                ),
                _el(
                    "EntityCondition",
                    {},
                    _el("CollisionCondition", {}, _el("EntityRef", {"entityRef": s})),
                ),
            ),
        )
        for s in slots
        if s != "hero"
    ]
    stop = _trigger("StopTrigger", *collisions, _time_after("stored_run_ended", "$end_time"))
    root.append(_el("Storyboard", {}, _el("Init", {}, actions), *stories, stop))
    ET.indent(root)
    return ET.ElementTree(root)
