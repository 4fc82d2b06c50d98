#!/usr/bin/env python3
"""An external AV stack that plans on object lists (``"wants": "objects"``), protocol v1.

Where ``python_stack.py`` brakes on image boxes, this stack gets every road user as an
object (class, id, position, heading, velocity and size in the ego frame: ``x`` forward,
``y`` left; docs/protocol.md) and brakes for one that will be in its path:

- it follows its route at 25 km/h (steer towards a point a few metres ahead);
- every frame it predicts, at constant velocity, where each road user will be when the ego
  reaches each point of the next ``HORIZON`` metres of its route, and calls the point taken
  if the road user is then within ``CLEARANCE`` metres of it (both bodies' half widths plus
  a margin);
- if a taken point is closer than the ego's stopping distance plus ``MARGIN``, it brakes
  fully; it drives on once the path is clear (it does not latch).

Standard library only; it imports nothing from sitcov. Run a campaign with it::

    sitcov run --runs 50 --db obj.db --av-cmd "python examples/object_stack.py"
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
HORIZON = 30.0  # how much of the route ahead is checked [m]
STEP = 1.0  # spacing of the checked route points [m]
EGO_HALF_WIDTH = 1.0  # [m]
MARGIN_LATERAL = 0.6  # extra clearance around both bodies [m]
DECEL = 6.0  # braking deceleration the stopping distance assumes [m/s^2]
MARGIN = 4.0  # brake when the taken point is closer than stopping distance + this [m]
MIN_SPEED = 1.0  # the arrival time at a point assumes at least this speed [m/s]


class Stack:
    """Route following that yields to road users predicted in its path."""

    def __init__(self) -> None:
        self.route: list[list[float]] = []
        self.index = 0
        self.blocked = False

    def reset(self, msg: dict) -> None:
        self.route = msg["route"] or [msg["goal"]]
        self.index = 0
        self.blocked = False

    def step(self, msg: dict) -> dict:
        ego = msg["ego"]
        steer = self.steer(ego["x"], ego["y"], ego["yaw"], ego["speed"])
        objects = msg.get("objects")
        if objects is not None:  # a new frame (between frames the last decision holds)
            self.blocked = self.path_taken(ego, objects)
        if self.blocked:
            return {"type": "control", "throttle": 0.0, "brake": 1.0, "steer": steer}
        u = SPEED_GAIN * (TARGET_SPEED - ego["speed"])
        return {
            "type": "control",
            "throttle": max(0.0, min(u, 0.75)),
            "brake": max(0.0, min(-u, 0.3)),
            "steer": steer,
        }

    def path_ahead(self, ego: dict) -> list[tuple[float, float, float]]:
        """The next HORIZON metres of the route in the ego frame: (x, y, arc length)."""
        c, s = math.cos(ego["yaw"]), math.sin(ego["yaw"])
        out, travelled = [(0.0, 0.0, 0.0)], 0.0
        px, py = 0.0, 0.0
        for wx, wy in self.route[self.index :]:
            dx, dy = wx - ego["x"], wy - ego["y"]
            x, y = dx * c + dy * s, -dx * s + dy * c
            if x < 0.0 and not out[1:]:
                continue  # behind the ego
            seg = math.hypot(x - px, y - py)
            n = max(1, int(seg / STEP))
            for k in range(1, n + 1):
                out.append((px + (x - px) * k / n, py + (y - py) * k / n, travelled + seg * k / n))
            travelled += seg
            px, py = x, y
            if travelled >= HORIZON:
                break
        return out

    def path_taken(self, ego: dict, objects: list[dict]) -> bool:
        """Whether a road user will be on the path ahead closer than we can stop."""
        speed = max(ego["speed"], 0.0)
        stop = speed * speed / (2.0 * DECEL) + MARGIN
        arrival_speed = max(speed, MIN_SPEED)
        for x, y, s in self.path_ahead(ego):
            if s > stop:
                break
            t = s / arrival_speed
            for obj in objects:
                ox, oy = obj["position"]
                vx, vy = obj["velocity"]
                clearance = EGO_HALF_WIDTH + 0.5 * obj["size"][1] + MARGIN_LATERAL
                reach = 0.5 * obj["size"][0]  # its half length along its heading
                if math.hypot(ox + vx * t - x, oy + vy * t - y) < clearance + reach:
                    return True
        return False

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
            send({"type": "hello", "protocol": 1, "name": "object-planner", "wants": "objects"})
        elif kind == "close":
            break


if __name__ == "__main__":
    main()
