"""The published protocol (docs/protocol.md) matches what sitcov sends and accepts."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from sitcov.av import EgoState, Observation, RunInfo
from sitcov.av import _protocol as proto
from sitcov.perception import CameraSpec, Detection

DOC = Path(__file__).resolve().parents[2] / "docs" / "protocol.md"


def documented_messages() -> dict[str, list[dict]]:
    """Every JSON message in the page's code blocks, by type."""
    found: dict[str, list[dict]] = {}
    for block in re.findall(r"```json\n(.*?)```", DOC.read_text(), flags=re.S):
        message = json.loads(block)
        found.setdefault(message["type"], []).append(message)
    return found


def test_every_message_type_is_documented_with_an_example() -> None:
    assert set(documented_messages()) == {"hello", "reset", "step", "control"}
    text = DOC.read_text()
    for kind in ("ready", "close", "error"):
        assert f'{{"type": "{kind}"' in text


def test_documented_sitcov_messages_have_the_fields_sitcov_sends() -> None:
    docs = documented_messages()
    sent_hello = proto.hello(step_timeout=1.0, grey_box=False, version="0.1.0")
    ours = [m for m in docs["hello"] if "sitcov" in m][0]
    assert set(ours) == set(sent_hello) and ours["protocol"] == proto.PROTOCOL_VERSION
    info = RunInfo(0.05, ((0.0, 0.0), (1.0, 0.0)), (1.0, 0.0), "t-junction", CameraSpec(), 5)
    sent_reset = proto.reset(info, grey_box=False)
    assert set(docs["reset"][0]) == set(sent_reset)
    assert set(docs["reset"][0]["camera"]) == set(sent_reset["camera"])
    assert docs["reset"][0]["camera"]["focal_px"] == round(CameraSpec().focal_px, 1)
    obs = Observation(1.25, EgoState(1.0, 2.0, 0.0, 3.0, 1.25), (Detection((1, 2, 3, 4), 0.5),))
    sent_step = proto.step(obs, None)
    assert set(docs["step"][0]) == set(sent_step)
    assert set(docs["step"][0]["ego"]) == set(sent_step["ego"])
    assert set(docs["step"][0]["detections"][0]) == set(sent_step["detections"][0])


def test_documented_stack_messages_are_accepted() -> None:
    docs = documented_messages()
    theirs = [m for m in docs["hello"] if "sitcov" not in m][0]
    assert proto.parse_hello(theirs, who="doc") == {
        "name": "my-stack",
        "wants": "detections",
        "image_transport": "file",
    }
    control = proto.parse_control(docs["control"][0], who="doc")
    assert (control.throttle, control.brake, control.steer) == (0.4, 0.0, -0.05)


def test_hello_may_declare_the_narrowest_box_the_stack_acts_on() -> None:
    from sitcov.errors import StackError

    hello = {"type": "hello", "protocol": 1, "wants": "image", "min_box_width": 0.1}
    assert proto.parse_hello(hello, who="s")["min_box_width"] == 0.1
    for bad in (1.5, -0.1, "wide", True):
        with pytest.raises(StackError, match="min_box_width"):
            proto.parse_hello({**hello, "min_box_width": bad}, who="s")
