"""Fuzzing the external stack protocol: whatever a stack writes, sitcov answers with a
StackError (one line) or a valid message - never another exception, never a hang, and
nothing left running."""

from __future__ import annotations

import json
import sys
import tempfile
from pathlib import Path

import pytest
from fuzz_helpers import fuzz_settings, no_hang, ok_or_one_line
from hypothesis import example, given
from hypothesis import strategies as st
from mutations import VALUES, mutated_bytes

from sitcov.av import EgoState, Observation, RunInfo
from sitcov.av import _protocol as proto
from sitcov.av._external import ExternalProcessStack
from sitcov.errors import StackError
from sitcov.perception import CameraSpec, Detection

WHO = "external stack 'fuzz'"
WORK = Path(tempfile.mkdtemp(prefix="sitcov-fuzz-protocol-"))
REPLAY = Path(__file__).resolve().parent / "replay_stack.py"

VALID = {
    "hello": '{"type": "hello", "protocol": 1, "name": "s", "wants": "detections", '
    '"image_transport": "file", "min_box_width": 0.01}',
    "ready": '{"type": "ready"}',
    "control": '{"type": "control", "throttle": 0.4, "brake": 0.1, "steer": -0.2, '
    '"info": {"note": "ok"}}',
}

#: One line from a stack: a valid message damaged, random JSON, or random bytes.
LINES = (
    st.sampled_from(list(VALID.values())).flatmap(mutated_bytes)
    | VALUES.map(lambda v: json.dumps(v).encode())
    | st.dictionaries(st.text(max_size=8), VALUES, max_size=5).map(
        lambda d: json.dumps({"type": "control", **d}).encode()
    )
    | st.binary(max_size=200)
)


def parse_all(line: bytes) -> None:
    """What sitcov does with a line: decode it, then read it as each message kind."""
    message = proto.decode(line, who=WHO)
    assert isinstance(message, dict) and isinstance(message["type"], str)
    for parse in (proto.parse_hello, proto.parse_control):
        try:
            parse(message, who=WHO)
        except StackError as exc:
            assert "\n" not in str(exc) and len(str(exc)) < 2000, str(exc)


@fuzz_settings()
@given(LINES)
@example(b'{"type": "control", "throttle": ' + b"1" * 5000 + b"}")  # int of 5000 digits
@example(b'{"type": "control", "info": ' + b"[" * 100_000 + b"]" * 100_000 + b"}")
@example(b'{"type": "hello", "name": "\xff\xfe"}')
def test_any_line_is_a_message_or_one_stack_error(line):
    assert ok_or_one_line(lambda: parse_all(line)) in ("ok", "error")


@fuzz_settings()
@given(st.dictionaries(st.text(max_size=12), VALUES, max_size=6))
def test_any_fields_in_a_hello_or_control(fields):
    for kind, parse in (("hello", proto.parse_hello), ("control", proto.parse_control)):
        message = {**json.loads(VALID[kind]), **fields, "type": kind}
        assert ok_or_one_line(lambda: parse(message, who=WHO)) in ("ok", "error")  # noqa: B023


def _info(seed: int) -> RunInfo:
    route = tuple((float(i), 0.0) for i in range(30))
    return RunInfo(0.05, route, (29.0, 0.0), "t-junction", CameraSpec(), seed)


def _observation(k: int) -> Observation:
    t = 0.05 * k
    dets = (Detection((100.0, 200.0, 180.0, 260.0), 0.9),)
    return Observation(t, EgoState(float(k), 0.0, 0.0, 5.0, t), dets, None)


ANSWERS = st.lists(
    LINES.map(lambda b: b + b"\n") | LINES | st.sampled_from([b"", b"\n", b"\n\n"]),
    min_size=1,
    max_size=8,
)


@pytest.mark.slow
@fuzz_settings(examples=12, long_examples=300)
@given(ANSWERS)
def test_a_stack_answering_anything_fails_runs_cleanly(answers):
    """Two runs of 4 steps against a stack answering with ``answers``: every call returns a
    control or raises a StackError; then nothing of the stack is left running."""
    script = WORK / "answers.json"
    script.write_text(json.dumps([a.decode("latin-1") for a in answers]))
    stack = ExternalProcessStack(
        [sys.executable, str(REPLAY), str(script)], step_timeout=0.5, start_timeout=2.0
    )
    pids = set()
    try:
        with no_hang(60):
            for seed in (1, 2):
                try:
                    stack.reset(_info(seed))
                    pids.add(stack.pid)
                    for k in range(4):
                        stack.step(_observation(k))
                except StackError as exc:
                    first = str(exc).splitlines()[0]
                    assert first.startswith(f"{stack.who}") or stack.who in first, first
    finally:
        stack.close()
    for pid in pids - {None}:
        assert (
            not Path(f"/proc/{pid}").exists()
            or "Z" in Path(f"/proc/{pid}/stat").read_text().split(") ")[1][:1]
        ), f"stack process {pid} left running"
