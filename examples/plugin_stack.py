"""A Python plug-in AV stack: a class sitcov imports and drives in-process.

The quickest way to test a stack written in Python: subclass ``sitcov.av.AVStack`` and
implement ``reset(info)`` and ``step(observation) -> Control``. sitcov finds the class by
its ``package.module:Class`` path (the module must be importable, e.g. from the current
directory with ``PYTHONPATH=.``) or by an entry point in the group ``sitcov.av``::

    PYTHONPATH=. sitcov run --runs 50 --db plugin.db --av examples.plugin_stack:PluginStack

    # or, in your package's pyproject.toml, then ``sitcov run --av my-stack``:
    [project.entry-points."sitcov.av"]
    my-stack = "examples.plugin_stack:PluginStack"

This stack follows the route at a constant speed and brakes (and keeps braking) once a
confident car detection is close, i.e. its box is wide; it reads detections, so run it
with the embedded backend's default PEM perception.
"""

from __future__ import annotations

import math
from typing import Any, ClassVar

from sitcov.av import AVStack, Control, Observation, RunInfo

TARGET_SPEED = 25.0 / 3.6  # cruise speed [m/s]
LOOKAHEAD = 3.0  # steer towards the route point at least this far ahead [m]
BRAKE_WIDTH = 0.12  # brake when a car's box covers this share of the image width [-]


class PluginStack(AVStack):
    """Route following with a latched brake on close detections.

    Args:
        brake_width: share of the image width a car's box must cover to trigger the brake.
    """

    name: ClassVar[str] = "plugin-example"

    def __init__(self, brake_width: float = BRAKE_WIDTH) -> None:
        self.brake_width = brake_width
        self._route: tuple[tuple[float, float], ...] = ()
        self._index = 0
        self._braking = False

    def reset(self, info: RunInfo) -> None:
        """Keep the route and camera; forget the previous run."""
        self._route = tuple(info.route) or (info.goal,)
        self.camera = info.camera
        self._index = 0
        self._braking = False

    def step(self, observation: Observation) -> Control:
        """Brake if a close car was seen, else steer to the route and hold the speed."""
        ego = observation.ego
        width = self.camera.width
        for det in observation.detections or ():
            x0, _, x1, _ = det.box
            if det.label == "car" and det.score >= 0.5 and (x1 - x0) / width >= self.brake_width:
                self._braking = True
        last = len(self._route) - 1
        while (
            self._index < last and math.dist(self._route[self._index], (ego.x, ego.y)) < LOOKAHEAD
        ):
            self._index += 1
        tx, ty = self._route[self._index]
        error = math.atan2(ty - ego.y, tx - ego.x) - ego.yaw
        steer = max(-0.8, min(0.8, 0.9 * math.atan2(math.sin(error), math.cos(error))))
        if self._braking:
            return Control(0.0, 1.0, steer, {"aeb": True})
        u = 0.3 * (TARGET_SPEED - ego.speed)
        return Control(max(0.0, min(u, 0.75)), max(0.0, min(-u, 0.3)), steer)

    def config(self) -> dict[str, Any]:
        """Stored with every run, so results say which settings produced them."""
        return {"name": self.name, "brake_width": self.brake_width}
