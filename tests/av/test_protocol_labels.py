"""The external protocol's step message carries each detection's class label."""

from __future__ import annotations

import json

from sitcov.av import EgoState, Observation
from sitcov.av._protocol import step
from sitcov.perception import Detection


def test_step_message_carries_every_class_label() -> None:
    dets = (
        Detection((10.0, 20.0, 60.0, 50.0), 0.8, "car"),
        Detection((100.0, 80.0, 118.0, 150.0), 0.55, "person"),
        Detection((200.0, 90.0, 260.0, 150.0), 0.35, "bicycle"),
    )
    obs = Observation(1.0, EgoState(0.0, 0.0, 0.0, 5.0, 1.0), dets)
    message = json.loads(json.dumps(step(obs, None)))
    assert [d["label"] for d in message["detections"]] == ["car", "person", "bicycle"]
    assert message["detections"][1] == {"box": [100.0, 80.0, 118.0, 150.0], "score": 0.55,
                                        "label": "person"}  # fmt: skip
