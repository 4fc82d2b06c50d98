#!/usr/bin/env python3
"""An external test stack: the example detection stack (examples/python_stack.py) that also
appends every step message it receives with a new frame (``detections`` not null) to the
JSON-lines file named by ``SITCOV_TEST_LOG`` (ego position and detections), so a test can
check what crossed the protocol. ``SITCOV_TEST_WANTS`` overrides what it asks for."""

from __future__ import annotations

import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3] / "examples"))
import python_stack  # noqa: E402

LOG = os.environ.get("SITCOV_TEST_LOG")
WANTS = os.environ.get("SITCOV_TEST_WANTS", "detections")


def main() -> None:
    stack = python_stack.Stack()
    log = open(LOG, "a", encoding="utf-8") if LOG else None  # noqa: SIM115
    for line in sys.stdin:
        msg = json.loads(line)
        kind = msg["type"]
        if kind == "step":
            if log is not None and (msg["detections"] is not None or msg.get("objects")):
                keep = {k: msg.get(k) for k in ("t", "ego", "detections", "objects", "image")}
                log.write(json.dumps(keep) + "\n")
                log.flush()
            python_stack.send(stack.step(msg))
        elif kind == "reset":
            stack.reset(msg)
            python_stack.send({"type": "ready"})
        elif kind == "hello":
            python_stack.send({"type": "hello", "protocol": 1, "name": "recorder", "wants": WANTS})
        elif kind == "close":
            break


if __name__ == "__main__":
    main()
