"""The third observation kind: object lists for Python and external stacks, in PEM and camera
mode, and the example object-list planner (examples/object_stack.py)."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import pytest

from sitcov._seeding import ask_rng, run_seed
from sitcov.av import AVStack, Control, Observation, RunInfo, make_stack
from sitcov.generation import make_generator
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim.embedded import EmbeddedBackend

ROOT = Path(__file__).resolve().parents[2]
RECORDER = Path(__file__).resolve().parent / "stacks" / "recording_stack.py"
VALUES = {"intsit": {"ego": "L-B", "ov": "R-B", "conflict": "c4"}, "friction": 1.0}
SITUATION = Situation(dict.fromkeys(VALUES, "-"), VALUES)


class _ObjectRecorder(AVStack):
    """Drives straight on slowly and keeps every object list it gets."""

    wants = "objects"

    def __init__(self) -> None:
        self.lists: list[tuple[float, tuple]] = []
        self.other: list[Observation] = []

    def reset(self, info: RunInfo) -> None:
        self.lists.clear()

    def step(self, observation: Observation) -> Control:
        if observation.objects is not None:
            self.lists.append((observation.t, observation.objects))
        if observation.detections is not None or observation.image is not None:
            self.other.append(observation)
        return Control(throttle=0.2)


def test_python_stack_gets_the_same_object_lists_in_pem_and_camera_mode() -> None:
    """Objects come from the world, not the pixels: identical in both modes (no detector
    or renderer runs), every frame (10 Hz), the OV with a stable id."""
    runs = {}
    for mode in ("pem", "camera"):
        stack = _ObjectRecorder()
        EmbeddedBackend(perception=mode, sim_timeout=4.0).run(SITUATION, stack, 3)
        assert not stack.other
        runs[mode] = list(stack.lists)
    assert runs["pem"] == runs["camera"]
    times = [t for t, _ in runs["pem"]]
    assert times[:3] == pytest.approx([0.0, 0.1, 0.2])
    assert all(len(objs) == 1 and objs[0].id == 1 and objs[0].label == "car"
               for _, objs in runs["pem"])  # fmt: skip
    first, last = runs["pem"][0][1][0], runs["pem"][-1][1][0]
    assert math.hypot(last.x, last.y) < math.hypot(first.x, first.y)  # closing in


def test_noisy_object_lists_are_seeded_and_miss_some() -> None:
    """The OV stays ~90 m away in these 4 s: the shipped model reports it in ~2 % of frames
    (P halves at 60 m); with the range term moved out to 150 m it is reported in most and
    its positions carry the documented error. The misses are correlated in time (the
    shipped ``miss_tau: pem``) and seeded."""
    from sitcov.perception import load_object_noise

    shipped = _ObjectRecorder()
    EmbeddedBackend(object_noise="default", sim_timeout=4.0).run(SITUATION, shipped, 3)
    assert sum(bool(n) for _, n in shipped.lists) < 0.2 * len(shipped.lists)
    noisy = EmbeddedBackend(object_noise=load_object_noise(range_50=150.0), sim_timeout=4.0)
    a, b, truth = _ObjectRecorder(), _ObjectRecorder(), _ObjectRecorder()
    noisy.run(SITUATION, a, 3)
    noisy.run(SITUATION, b, 3)
    EmbeddedBackend(sim_timeout=4.0).run(SITUATION, truth, 3)
    assert a.lists == b.lists  # the same seed, the same noise
    assert a.lists != truth.lists
    assert sum(bool(n) for _, n in a.lists) > 0.7 * len(a.lists)
    err = [abs(n[0].x - g[0].x) for (_, n), (_, g) in zip(a.lists, truth.lists, strict=True)
           if n and g]  # fmt: skip
    assert 0.0 < sum(err) / len(err) < 1.0  # centimetres to decimetres, as documented


def test_bad_object_noise_option_is_one_line(tmp_path) -> None:
    from sitcov.errors import ConfigError

    with pytest.raises(ConfigError, match="object_noise"):
        EmbeddedBackend(object_noise=3)
    with pytest.raises(ConfigError, match="nope.yaml"):
        EmbeddedBackend(object_noise=str(tmp_path / "nope.yaml"))


def test_external_stack_receives_objects_over_the_protocol(tmp_path) -> None:
    log = tmp_path / "steps.jsonl"
    env = {"SITCOV_TEST_LOG": str(log), "SITCOV_TEST_WANTS": "objects"}
    stack = make_stack(f"cmd:{sys.executable} {RECORDER}", params={"env": env})
    try:
        EmbeddedBackend(sim_timeout=4.0).run(SITUATION, stack, 3)
    finally:
        stack.close()
    steps = [json.loads(line) for line in log.read_text().splitlines()]
    assert len(steps) >= 10 and all(s["detections"] is None and s["image"] is None
                                    for s in steps)  # fmt: skip
    ov = steps[0]["objects"][0]
    assert set(ov) == {"id", "label", "position", "heading", "velocity", "size"}
    assert ov["label"] == "car" and len(ov["size"]) == 3


@pytest.mark.slow
def test_the_example_object_planner_brakes_for_road_users_in_its_path() -> None:
    """20 random situations of the default hyperspace (seed 3), PEM backend: the blind stack
    collides in most, the object planner in few and reaches its goal in most (measured on
    40: blind 37 collisions, planner 11 collisions and 28 goals; the rest on ice)."""
    gen = make_generator("random", load_hyperspace())
    backend = EmbeddedBackend()
    planner = make_stack(f"cmd:{sys.executable} {ROOT / 'examples' / 'object_stack.py'}")
    blind = make_stack("no-perception")
    hits = {"planner": 0, "blind": 0}
    goals = 0
    try:
        for i in range(20):
            sit = gen.ask(ask_rng(3, i))
            out = backend.run(sit, planner, run_seed(3, i))
            hits["planner"] += out.collision
            goals += out.end_reason == "goal"
            hits["blind"] += backend.run(sit, blind, run_seed(3, i)).collision
    finally:
        planner.close()
    assert hits["blind"] >= 14
    assert hits["planner"] <= 0.5 * hits["blind"]
    assert goals >= 10
