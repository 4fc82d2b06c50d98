#!/usr/bin/env python3
"""An external AV stack that creeps 10 m along its route and stops for good (protocol v1).

It follows its route at walking pace (1 m/s) until it has covered ``CREEP_DISTANCE``, then
brakes fully to the end of the run: it moves, so it is not a stack that never starts, but
it never gets anywhere. Under the ``default`` judge it fails every run (``blocked``,
``route_incomplete``); docs/campaigns.md gives the measured numbers::

    sitcov run --runs 200 --db creep.db --av-cmd "python examples/creep_stack.py"
"""

from __future__ import annotations

import json
import math
import sys

CREEP_DISTANCE = 10.0  # how far it drives before stopping for good [m]
CREEP_SPEED = 1.0  # its speed meanwhile [m/s]
LOOKAHEAD = 3.0  # steer towards the route point at least this far ahead [m]


class Stack:
    """Creep, then stop."""

    def __init__(self) -> None:
        self.route: list[list[float]] = []
        self.index = 0
        self.start: tuple[float, float] | None = None
        self.driven = 0.0

    def reset(self, msg: dict) -> None:
        self.route = msg["route"] or [msg["goal"]]
        self.index = 0
        self.start = None
        self.driven = 0.0

    def step(self, msg: dict) -> dict:
        ego = msg["ego"]
        x, y = ego["x"], ego["y"]
        if self.start is not None:
            self.driven += math.dist(self.start, (x, y))
        self.start = (x, y)
        if self.driven >= CREEP_DISTANCE:
            return {"type": "control", "throttle": 0.0, "brake": 1.0, "steer": 0.0}
        last = len(self.route) - 1
        while self.index < last and math.dist(self.route[self.index], (x, y)) < LOOKAHEAD:
            self.index += 1
        tx, ty = self.route[self.index]
        error = math.atan2(ty - y, tx - x) - ego["yaw"]
        error = math.atan2(math.sin(error), math.cos(error))
        u = 0.5 * (CREEP_SPEED - ego["speed"])
        return {
            "type": "control",
            "throttle": max(0.0, min(u, 0.5)),
            "brake": max(0.0, min(-u, 0.5)),
            "steer": max(-0.8, min(0.8, 0.9 * error)),
        }


def send(message: dict) -> None:
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


def main() -> None:
    stack = Stack()
    for line in sys.stdin:
        msg = json.loads(line)
        kind = msg["type"]
        if kind == "step":
            send(stack.step(msg))
        elif kind == "reset":
            stack.reset(msg)
            send({"type": "ready"})
        elif kind == "hello":
            send({"type": "hello", "protocol": 1, "name": "creep", "wants": "detections"})
        elif kind == "close":
            break


if __name__ == "__main__":
    main()
