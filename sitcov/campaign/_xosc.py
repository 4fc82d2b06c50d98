"""``sitcov export-xosc``: stored runs as OpenSCENARIO files that play in a real engine.

Each chosen run is re-simulated exactly as stored (same config, situation and seed: the
embedded world is deterministic, ``sitcov replay`` checks it) with recording on, and its
trajectories are written by :func:`sitcov.sim.xosc.run_scenario` beside the road file:

- by default the map's own OpenDRIVE export (``<map>.xodr``, written once per folder), so
  the scenario plays on exactly sitcov's geometry;
- with ``road`` an OpenDRIVE file such as CARLA's Town03: only for the map the CARLA map
  file places there (the paper's ``t-junction``), the trajectories moved onto its junction
  by the map file's frame. Another map is refused (its labels mean other legs).

A situation given without a stored run (``--situation-json``) is run once with the default
campaign config on ``map`` (seed ``seed``) and exported the same way.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from sitcov.campaign._build import build_backend, build_stack
from sitcov.campaign._config import CampaignConfig
from sitcov.campaign._executors import execute
from sitcov.campaign._open import open_store
from sitcov.campaign._runner import judge_of
from sitcov.errors import ConfigError
from sitcov.sim import Judge


@dataclass(frozen=True)
class _Road:
    """Where the scenarios' road comes from: the map's export or a given file."""

    file: Path | None  # None: the map's own export

    def setup(self, jmap: Any, out: Path) -> tuple[str, Any, Any]:
        """(LogicFile path relative to ``out``, placement, OdrIds or None)."""
        from sitcov.roads import write_xodr
        from sitcov.sim.embedded._odr import road_network
        from sitcov.sim.xosc import identity

        if self.file is None:
            network, ids = road_network(jmap)
            path = out / f"{jmap.name}.xodr"
            if not path.exists():
                write_xodr(network, path)
            return path.name, identity, ids
        from sitcov.sim.carla._actors import Frame
        from sitcov.sim.carla._mapfile import load_carla_map

        frame = getattr(jmap, "frame", None)
        imported = isinstance(frame, dict) and "origin" in frame
        spec = load_carla_map("Town03")
        if not imported and jmap.name != spec.embedded_map:
            raise ConfigError(
                field="--road",
                value=str(self.file),
                expected=f"a campaign on map {spec.embedded_map!r} (the junction Town03's map "
                f"file places on the road file) or on a map imported from the file; this one "
                f"ran on {jmap.name!r}: drop --road to export it with its own OpenDRIVE file",
            )
        if not self.file.is_file():
            raise ConfigError(field="--road", value=str(self.file), expected="an .xodr file")
        rel = os.path.relpath(self.file.resolve(), out.resolve())
        if imported:
            return rel, imported_placement(frame), None
        return rel, Frame.of(spec).to_sitcov, None


def imported_placement(frame: Mapping[str, Any]) -> Any:
    """Map frame -> the OpenDRIVE file's frame of a map imported from that file: its
    ``lanes.frame`` says the map's origin in the file (``origin`` [m]) and how far the file
    was turned to put leg B south (``rotation_deg``), map = R(rotation) (file - origin)."""
    import math

    x0, y0 = (float(v) for v in frame["origin"])
    rot = math.radians(float(frame.get("rotation_deg", 0.0)))
    c, s = math.cos(rot), math.sin(rot)

    def place(x: float, y: float, h: float) -> tuple[float, float, float]:
        return x0 + c * x + s * y, y0 - s * x + c * y, h - rot

    return place


def _embedded_map(sim: Any, where: str) -> Any:
    from sitcov.sim.embedded import JunctionMap

    jmap = getattr(sim, "map", None)
    if not isinstance(jmap, JunctionMap):
        raise ConfigError(
            field="backend", value=where, expected="runs of the embedded backend (its map)"
        )
    return jmap


def _write(
    sim: Any,
    stack: Any,
    judge: Any,
    run: Any,
    out: Path,
    road: _Road,
) -> Path:
    """Re-simulate ``run`` with recording and write its scenario; the path written."""
    from sitcov.sim.embedded._odr import hero_route
    from sitcov.sim.xosc import HeroRoute, environment, facts_of, run_scenario

    jmap = _embedded_map(sim, run.config.get("backend", "embedded"))
    road_file, place, ids = road.setup(jmap, out)
    _, raw, _ = execute(sim, stack, (run.index, run.situation.to_dict(), run.seed), True)
    outcome = judge(raw)
    if outcome.trace is None:
        raise ConfigError(
            field="run", value=f"{run.campaign}:{run.index}",
            expected=f"a run that simulates (it ended as {outcome.status}: {outcome.message})",
        )  # fmt: skip
    stored = run.outcome if run.outcome is not None else outcome
    same = (stored.status, stored.collision_time) == (outcome.status, outcome.collision_time)
    route = None
    intsit = run.situation.values.get("intsit")
    if ids is not None and isinstance(intsit, Mapping) and intsit.get("ego") in ids.movements:
        x, y = outcome.trace.ego[0][1:3]
        route = HeroRoute(hero_route(jmap, ids, str(intsit["ego"]), (x, y)))
    scenario = run_scenario(
        run.situation,
        outcome.trace,
        replace(facts_of(run, stored), reproduced=same),
        road_file=road_file,
        map_name=jmap.name,
        place=place,
        route=route,
        environment=environment(run.situation.values),
    )
    path = out / f"{run.situation.id}.xosc"
    scenario.write_xml(str(path))
    return path


def export_runs(
    db: str | Path,
    out: str | Path,
    *,
    campaign: str | None = None,
    status: str | Sequence[str] | None = "fail",
    road: str | Path | None = None,
) -> list[Path]:
    """Write one ``<situation id>.xosc`` per stored run of ``status`` (a situation once;
    ``None``: every run that finished, passed or failed).

    Raises:
        ConfigError: no such database, a run of another backend, or ``road`` for a map
            it does not fit.
    """
    if not Path(db).exists():
        raise ConfigError(field="--db", value=str(db), expected="an existing campaign database")
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    store = open_store(db)
    try:
        if campaign is not None:
            store.campaign(campaign)  # a clear error naming the known campaigns
        # runs that errored or are pending have nothing to replay
        runs = store.runs(campaign=campaign, status=status or ("pass", "fail"))
    finally:
        store.close()
    return _export(runs, out, _Road(None if road is None else Path(road)))


def _export(runs: Iterable[Any], out: Path, road: _Road) -> list[Path]:
    written: list[Path] = []
    seen: set[str] = set()
    parts: dict[str, tuple[Any, Any, Any]] = {}
    try:
        for run in runs:
            if run.situation.id in seen:
                continue
            seen.add(run.situation.id)
            key = repr(sorted(run.config.items()))
            if key not in parts:
                config = CampaignConfig(**{k: v for k, v in run.config.items() if k != "workers"})
                judge = judge_of(config) if "judge" in run.config else Judge.from_spec("paper")
                parts[key] = (build_backend(config), build_stack(config), judge)
            written.append(_write(*parts[key], run, out, road))
    finally:
        for sim, stack, _ in parts.values():
            stack.close()
            sim.close()
    return written


def export_situations(
    situations: Iterable[Any],
    out: str | Path,
    *,
    map: str = "t-junction",  # noqa: A002 - the CLI's option name
    seed: int = 0,
    road: str | Path | None = None,
    av: str = "reference",
) -> list[Path]:
    """Run each situation once (default campaign config on ``map``, ``seed``, stack ``av``)
    and export it.

    Raises:
        ConfigError: a bad map or road (see :func:`export_runs`).
    """
    from sitcov.campaign._records import RunRecord

    config = CampaignConfig(name="export", backend_options={"map": map}, av=av, workers=1)
    stored = config.model_dump()
    runs = [
        RunRecord("export", i, s, seed, "pending", config=stored) for i, s in enumerate(situations)
    ]
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    return _export(runs, out, _Road(None if road is None else Path(road)))
