"""Shared helpers of the CARLA tests: a small synthetic map, situations, recording stacks."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from sitcov.av import AVStack, Control, Observation, RunInfo
from sitcov.hyperspace import Situation
from sitcov.perception import Detection
from sitcov.sim.carla import CarlaBackend, load_carla_map
from sitcov.sim.carla._fake import FakeCarla, FakeServer

#: A clean T-junction in CARLA coordinates with short legs (fast fake runs). Right-hand
#: traffic as on CARLA's roads and the embedded t-junction: CARLA is left-handed (y points
#: south), so a vehicle heading east (yaw 0) keeps to +y, one heading west (yaw 180) to -y.
SMALL_MAP = """
name: small-t
town: Town03
junction: {x: 0.0, y: 0.0, radius: 12.0}
conflict_points: {c1: [0.0, 0.0], c2: [0.0, -2.0], c4: [-2.0, 0.0]}
ego_spawns:
  B: {x: 1.75, y: 40.0, yaw: 270.0}
  L: {x: -40.0, y: 1.75, yaw: 0.0}
  R: {x: 40.0, y: -1.75, yaw: 180.0}
ov_spawns:
  B: {x: 1.75, y: 25.0, yaw: 270.0}
  L: {x: -25.0, y: 1.75, yaw: 0.0}
  R: {x: 25.0, y: -1.75, yaw: 180.0}
goals:
  B: [-1.75, 30.0]
  L: [-30.0, -1.75]
  R: [30.0, 1.75]
"""

WEATHER = {
    "cloudiness": 20.0,
    "precipitation": 0.0,
    "precipitation_deposits": 0.0,
    "wind_intensity": 80.0,
    "fog_density": 100.0,
    "fog_distance": 10.0,
    "wetness": 0.0,
}


def small_map(tmp_path: Path) -> Path:
    path = tmp_path / "small.yaml"
    path.write_text(SMALL_MAP, encoding="utf-8")
    return path


def situation(ego: str = "L-B", ov: str = "R-B", conflict: str = "c4", **env: Any) -> Situation:
    values: dict[str, Any] = {**WEATHER, "friction": 1.0, **env}
    values["intsit"] = {"ego": ego, "ov": ov, "conflict": conflict}
    bins = {k: str(v) for k, v in values.items() if k != "intsit"}
    bins["intsit"] = f"{ego}/{ov}/{conflict}"
    return Situation(bins, values)


def fake_backend(map_source: Any = "Town03", **options: Any) -> tuple[CarlaBackend, FakeServer]:
    server = FakeServer(load_carla_map(map_source))
    backend = CarlaBackend(map=str(map_source), carla_module=FakeCarla(server), **options)
    return backend, server


class DrivingStack(AVStack):
    """The reference stack's route following, recording what it observes.

    ``brake_on_image``: after this many images, report AEB and brake fully.
    ``raise_at``: raise at this step.
    """

    name = "test-driving"

    def __init__(self, brake_on_image: int | None = None, raise_at: int | None = None) -> None:
        from sitcov.av import ReferenceStack

        self.inner = ReferenceStack(aeb=False)
        self.brake_on_image, self.raise_at = brake_on_image, raise_at
        self.observations: list[Observation] = []
        self.info: RunInfo | None = None

    def reset(self, info: RunInfo) -> None:
        self.info = info
        self.observations = []
        self.inner.reset(info)

    def step(self, observation: Observation) -> Control:
        self.observations.append(observation)
        if self.raise_at is not None and len(self.observations) > self.raise_at:
            raise ZeroDivisionError("stack bug")
        images = sum(o.image is not None for o in self.observations)
        if self.brake_on_image is not None and images >= self.brake_on_image:
            return Control(0.0, 1.0, 0.0, {"aeb": True})
        return self.inner.step(observation)


def centred_car(image: Any) -> list[Detection]:
    """A detector that always sees a close car in the middle of the image."""
    return [Detection((200.0, 100.0, 600.0, 400.0), 0.99, "car")]


#: Fake servers of FakeCarlaBackend instances, by the ``server_key`` option (tests kill them).
SERVERS: dict[str, FakeServer] = {}


class FakeCarlaBackend(CarlaBackend):
    """The CARLA backend on an in-memory fake server, loadable by ``module:Class`` path
    (``carla_testkit:FakeCarlaBackend``) so a campaign builds it like any backend.

    ``server_key`` names the fake server in :data:`SERVERS`; ``revive_file`` is the file
    whose appearance brings a killed fake server back (what a launch command creates).
    """

    def __init__(
        self, server_key: str = "default", revive_file: str | None = None, **options: Any
    ) -> None:
        server = FakeServer(load_carla_map(options.get("map", "Town03")))
        server.revive_file = Path(revive_file) if revive_file else None
        SERVERS[server_key] = server
        super().__init__(carla_module=FakeCarla(server), **options)
