"""Protocol v1 between sitcov and an AV stack running as a separate process.

Messages are JSON objects, one per line (UTF-8, ``\\n``-terminated), on the child's stdin
(sitcov -> stack) and stdout (stack -> sitcov); the child's stderr is free text for logs.
Camera frames do not travel as JSON: they are raw bytes in a per-run shared file whose path
the step message names (or, if the stack asks for it, raw bytes on stdin right after the
step line). The full specification, with examples, is ``docs/protocol.md``; this module
only builds and checks the messages, so the process handling in ``_external.py`` stays
independent of the message format.
"""

from __future__ import annotations

import json
import math
from typing import TYPE_CHECKING, Any

from sitcov.av._base import Control, Observation, RunInfo
from sitcov.errors import StackError

if TYPE_CHECKING:
    from sitcov.perception import CameraSpec

#: The protocol version this sitcov speaks; a stack must answer the hello with it.
PROTOCOL_VERSION = 1
#: What a stack may ask to receive each step.
WANTS = ("detections", "image", "objects")
#: How a stack may ask to receive camera frames.
IMAGE_TRANSPORTS = ("file", "stdin")
#: Longest piece of a bad message quoted in an error [characters].
_QUOTE = 120


def encode(message: dict[str, Any]) -> bytes:
    """One message as a compact JSON line (NaN/inf are refused: they are not JSON)."""
    return json.dumps(message, separators=(",", ":"), allow_nan=False).encode() + b"\n"


def decode(line: bytes, *, who: str) -> dict[str, Any]:
    """Parse one line from the stack; anything but a JSON object is a protocol error."""
    try:
        message = json.loads(line)
    except (ValueError, RecursionError):  # bad UTF-8 or JSON, 4300+ digits, deep nesting
        message = None
    if not isinstance(message, dict) or not isinstance(message.get("type"), str):
        text = line[:_QUOTE].decode("utf-8", "replace").rstrip()
        raise StackError(
            f"{who}: expected a JSON object with a 'type' on stdout (protocol v{PROTOCOL_VERSION}),"
            f" got {text!r}; write logs to stderr, not stdout"
        )
    if message["type"] == "error":
        raise StackError(f"{who} reported an error: {message.get('message', '(no message)')}")
    return message


def expect(message: dict[str, Any], kind: str, *, who: str) -> dict[str, Any]:
    """Check that ``message`` is of type ``kind``."""
    if message["type"] != kind:
        raise StackError(f"{who}: expected a {kind!r} message, got {message['type']!r}")
    return message


def hello(*, step_timeout: float, grey_box: bool, version: str) -> dict[str, Any]:
    """sitcov's opening message."""
    return {
        "type": "hello",
        "protocol": PROTOCOL_VERSION,
        "sitcov": version,
        "step_timeout": step_timeout,
        "grey_box": grey_box,
    }


def parse_hello(message: dict[str, Any], *, who: str) -> dict[str, Any]:
    """Validate the stack's hello; returns ``{"name", "wants", "image_transport"}`` and,
    if the stack declared them, ``"min_box_width"``, ``"min_box_sizes"`` (per class) and
    ``"centre_window"``."""
    expect(message, "hello", who=who)
    version = message.get("protocol")
    if version != PROTOCOL_VERSION:
        raise StackError(
            f"{who} speaks protocol {version!r} but this sitcov speaks protocol "
            f"{PROTOCOL_VERSION}; see docs/protocol.md"
        )
    wants = message.get("wants", "detections")
    if wants not in WANTS:
        raise StackError(f"{who}: hello field 'wants' must be one of {WANTS}, got {wants!r}")
    transport = message.get("image_transport", "file")
    if transport not in IMAGE_TRANSPORTS:
        raise StackError(
            f"{who}: hello field 'image_transport' must be one of {IMAGE_TRANSPORTS}, "
            f"got {transport!r}"
        )
    name = str(message.get("name", "external"))
    peer = {"name": name, "wants": wants, "image_transport": transport}
    if "min_box_width" in message:
        width = message["min_box_width"]
        if isinstance(width, bool) or not isinstance(width, int | float) or not 0 <= width <= 1:
            raise StackError(
                f"{who}: hello field 'min_box_width' must be a number in [0, 1] (a fraction "
                f"of the image width), got {width!r}"
            )
        peer["min_box_width"] = float(width)
    if "min_box_sizes" in message:
        peer["min_box_sizes"] = _min_box_sizes(message["min_box_sizes"], who)
    if "centre_window" in message:
        peer["centre_window"] = _centre_window(message["centre_window"], who)
    return peer


def _centre_window(value: Any, who: str) -> tuple[float, float]:
    """The hello's ``centre_window``: [lo, hi], fractions of the image width, lo < hi."""
    ok = isinstance(value, list) and len(value) == 2 and all(_fraction(v) for v in value)
    if ok and value[0] < value[1]:
        return float(value[0]), float(value[1])
    raise StackError(
        f"{who}: hello field 'centre_window' must be [lo, hi] with 0 <= lo < hi <= 1 "
        f"(fractions of the image width), got {value!r}"
    )


def _min_box_sizes(sizes: Any, who: str) -> dict[str, tuple[float, float]]:
    """The hello's ``min_box_sizes``: class -> {width, height}, fractions in [0, 1]."""
    out: dict[str, tuple[float, float]] = {}
    if isinstance(sizes, dict):
        for label, size in sizes.items():
            wh = [size.get(k, 0.0) if isinstance(size, dict) else None for k in ("width", "height")]
            if not all(_fraction(v) for v in wh):
                break
            out[str(label)] = (float(wh[0]), float(wh[1]))
        else:
            return out
    raise StackError(
        f"{who}: hello field 'min_box_sizes' must map classes to {{width, height}} fractions "
        f'in [0, 1] of the image, e.g. {{"person": {{"height": 0.2}}}}, got {sizes!r}'
    )


def _fraction(value: Any) -> bool:
    return not isinstance(value, bool) and isinstance(value, int | float) and 0 <= value <= 1


def camera_dict(camera: CameraSpec) -> dict[str, Any]:
    """The camera as the stack sees it in the reset message."""
    return {
        "width": camera.width,
        "height": camera.height,
        "fov_deg": camera.fov_deg,
        "mount_x": camera.mount_x,
        "mount_z": camera.mount_z,
        "focal_px": camera.focal_px,
    }


def reset(info: RunInfo, *, grey_box: bool) -> dict[str, Any]:
    """The start-of-run message; the situation is included only in grey-box mode."""
    message: dict[str, Any] = {
        "type": "reset",
        "dt": info.dt,
        "route": [[float(x), float(y)] for x, y in info.route],
        "goal": [float(info.goal[0]), float(info.goal[1])],
        "map": info.map_name,
        "camera": camera_dict(info.camera),
        "seed": int(info.seed),
    }
    if grey_box and info.situation is not None:
        message["situation"] = info.situation.to_dict()
    return message


def step(observation: Observation, image: dict[str, Any] | None) -> dict[str, Any]:
    """The per-step message; ``image`` is the frame reference built by the caller."""
    ego = observation.ego
    detections = observation.detections
    message = {
        "type": "step",
        "t": observation.t,
        "ego": {"x": ego.x, "y": ego.y, "yaw": ego.yaw, "speed": ego.speed},
        "detections": None
        if detections is None
        else [{"box": list(d.box), "score": d.score, "label": d.label} for d in detections],
        "image": image,
    }
    if observation.objects is not None:
        message["objects"] = [o.to_dict() for o in observation.objects]
    return message


def _number(message: dict[str, Any], key: str, lo: float, hi: float, who: str) -> float:
    value = message.get(key, 0.0)
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise StackError(f"{who}: control field {key!r} must be a finite number, got {value!r}")
    return min(hi, max(lo, float(value)))


def parse_control(message: dict[str, Any], *, who: str) -> Control:
    """The stack's control; values are clipped to their ranges, missing ones are 0."""
    expect(message, "control", who=who)
    info = message.get("info") or {}
    if not isinstance(info, dict):
        raise StackError(f"{who}: control field 'info' must be an object, got {info!r}")
    return Control(
        throttle=_number(message, "throttle", 0.0, 1.0, who),
        brake=_number(message, "brake", 0.0, 1.0, who),
        steer=_number(message, "steer", -1.0, 1.0, who),
        info=info,
    )
