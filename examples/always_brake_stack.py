#!/usr/bin/env python3
"""An external AV stack that never drives: full brake on every step (protocol v1).

It never collides and never leaves its lane, so a judge that counts collisions and
departures only passes it everywhere. Under the ``default`` judge it fails every run: it
stands with a clear path (``blocked``) and never reaches its goal (``route_incomplete``).
docs/campaigns.md ("Route completion and blame") gives the measured numbers::

    sitcov run --runs 200 --db brake.db --av-cmd "python examples/always_brake_stack.py"
"""

from __future__ import annotations

import json
import sys


def send(message: dict) -> None:
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


def main() -> None:
    for line in sys.stdin:
        kind = json.loads(line)["type"]
        if kind == "step":
            send({"type": "control", "throttle": 0.0, "brake": 1.0, "steer": 0.0})
        elif kind == "reset":
            send({"type": "ready"})
        elif kind == "hello":
            send({"type": "hello", "protocol": 1, "name": "always-brake", "wants": "detections"})
        elif kind == "close":
            break


if __name__ == "__main__":
    main()
