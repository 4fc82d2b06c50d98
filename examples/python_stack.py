#!/usr/bin/env python3
"""A minimal external AV stack in plain Python, speaking sitcov's protocol v1.

It shows everything a stack in any language has to do (see docs/protocol.md):

1. read JSON lines on stdin, write one JSON line per answer on stdout (and flush);
2. answer ``hello`` with the protocol version and what it wants to see (detections);
3. on ``reset`` keep the route and camera, answer ``ready``;
4. on ``step`` answer ``control``: follow the route (steer towards a point a few metres
   ahead, hold 25 km/h) and brake fully, for the rest of the run, once a confident car
   detection is near the image centre and large enough to be close;
5. exit on ``close`` or when stdin ends. Logs go to stderr, never to stdout.

It uses only the standard library and imports nothing from sitcov: it is a black box.
Run a campaign with it::

    sitcov run --runs 50 --db py.db --av-cmd "python examples/python_stack.py"
"""

from __future__ import annotations

import json
import math
import sys

TARGET_SPEED = 25.0 / 3.6  # cruise speed [m/s]
LOOKAHEAD = 3.0  # steer towards the route point at least this far ahead [m] ...
LOOKAHEAD_TIME = 0.5  # ... plus this many seconds of travel [s]
STEER_GAIN = 0.9  # steer command per radian of heading error [1/rad]
SPEED_GAIN = 0.3  # throttle (or brake) per m/s of speed error [s/m]
MIN_SCORE = 0.5  # detections below this score are ignored [-]
CENTRE = (0.05, 0.98)  # a detection must have its box centre in this share of the width [-]
MIN_WIDTH = 0.12  # ... and cover at least this share of the image width (close) [-]


class Stack:
    """Route following with a latched emergency brake."""

    def __init__(self) -> None:
        self.route: list[list[float]] = []
        self.width = 800.0
        self.index = 0
        self.braking = False

    def reset(self, msg: dict) -> None:
        self.route = msg["route"] or [msg["goal"]]
        self.width = float(msg["camera"]["width"])
        self.index = 0
        self.braking = False

    def step(self, msg: dict) -> dict:
        ego = msg["ego"]
        if not self.braking and msg["detections"]:
            self.braking = any(self.threat(d) for d in msg["detections"])
        steer = self.steer(ego["x"], ego["y"], ego["yaw"], ego["speed"])
        if self.braking:
            return {
                "type": "control",
                "throttle": 0.0,
                "brake": 1.0,
                "steer": steer,
                "info": {"aeb": True},
            }
        u = SPEED_GAIN * (TARGET_SPEED - ego["speed"])
        return {
            "type": "control",
            "throttle": max(0.0, min(u, 0.75)),
            "brake": max(0.0, min(-u, 0.3)),
            "steer": steer,
        }

    def threat(self, det: dict) -> bool:
        x0, _, x1, _ = det["box"]
        centre = 0.5 * (x0 + x1) / self.width
        return (
            det["label"] == "car"
            and det["score"] >= MIN_SCORE
            and CENTRE[0] < centre < CENTRE[1]
            and (x1 - x0) / self.width >= MIN_WIDTH
        )

    def steer(self, x: float, y: float, yaw: float, speed: float) -> float:
        reach = LOOKAHEAD + LOOKAHEAD_TIME * speed
        last = len(self.route) - 1
        while self.index < last and math.dist(self.route[self.index], (x, y)) < reach:
            self.index += 1
        tx, ty = self.route[self.index]
        error = math.atan2(ty - y, tx - x) - yaw
        error = math.atan2(math.sin(error), math.cos(error))  # wrap to (-pi, pi]
        return max(-0.8, min(0.8, STEER_GAIN * error))


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
            if msg["protocol"] != 1:
                print(f"unsupported protocol {msg['protocol']}", file=sys.stderr)
                sys.exit(1)
            send({"type": "hello", "protocol": 1, "name": "python-example", "wants": "detections"})
        elif kind == "close":
            break


if __name__ == "__main__":
    main()
