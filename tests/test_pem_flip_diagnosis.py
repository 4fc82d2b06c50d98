"""benchmarks/pem_flip_diagnosis.py, whose flip classes and tables docs/pem.md quotes ("Why
the PEM and the camera disagree, frame by frame"): the firing probabilities it classifies
by, its run lengths, that its instrumented PEM runs decide as the plain ones do, and that
the stored rows' summary is the summary of their flips."""

from __future__ import annotations

import itertools
import json
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
from benchmark_modules import load_benchmark

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def diag() -> ModuleType:
    return load_benchmark("pem_flip_diagnosis")


def _brute_fire(probs: list[float], need: int) -> float:
    """P(some run of ``need`` successes) by enumerating every outcome."""
    total = 0.0
    for outcome in itertools.product((0, 1), repeat=len(probs)):
        p = float(np.prod([q if o else 1.0 - q for q, o in zip(probs, outcome, strict=True)]))
        run = best = 0
        for o in outcome:
            run = run + 1 if o else 0
            best = max(best, run)
        total += p * (best >= need)
    return total


def test_fire_probability_is_the_enumerated_one(diag) -> None:
    rng = np.random.default_rng(3)
    for n in (0, 1, 4, 9):
        probs = list(rng.uniform(0.0, 1.0, size=n))
        for need in (1, 2, 3):
            assert diag.p_fire(probs, need) == pytest.approx(_brute_fire(probs, need), abs=1e-12)


def test_runs_of_counts_consecutive_frames(diag) -> None:
    assert diag.runs_of([True, True, False, True, False, False, True, True, True]) == [2, 1, 3]
    assert diag.runs_of([]) == [] and diag.runs_of([False]) == []


def test_recorded_pem_runs_decide_as_plain_runs(diag) -> None:
    """The instrumented stack and PEM (the per-frame records) change no decision: the same
    verdict and AEB time as the plain PEM run, for each of the four stacks."""
    from sitcov._seeding import run_seed
    from sitcov.av import make_stack

    sim = diag.Simulator(8)
    for stack in diag.STACKS:
        for index in (0, 7):
            outcome, frames, _ = sim.run(index, stack, "pem")
            plain = sim.plain_backend.run(
                sim.situation(index), make_stack(stack), run_seed(8, index)
            )
            assert (outcome.failed, outcome.aeb_time) == (plain.failed, plain.aeb_time)
            assert frames and all(0.0 <= a["p"] <= 1.0 for f in frames for a in f["actors"])
            # the PEM's reported scores are its own detections of the road user
            assert any(a["score"] > 0.0 for f in frames for a in f["actors"])


def test_stored_summary_is_the_summary_of_the_stored_flips(diag) -> None:
    data = json.loads((ROOT / "docs/data/pem-flips-seed8.json").read_text(encoding="utf-8"))
    assert diag.summarise(data["flips"]) == json.loads(json.dumps(data["summary"]))
    counts = {s: v["flips"] for s, v in data["summary"]["stacks"].items()}
    assert counts == {"reference": 18, "threshold-0.7": 22, "three-frames": 24, "right-blind": 14}


def test_recorded_camera_run_decides_as_the_agreement_runner(diag, ssd_model_dir) -> None:
    """Camera mode: the instrumented stack with the low-floor detector reaches the verdict
    and AEB time of ``sitcov experiment agreement``'s own run of the same job (reference
    situation 9 of seed 8: the AEB fires at 11.0 s), and the frame it fired in holds a
    detection that passed on the road user."""
    from sitcov.campaign._agreement import Job, SideRunner, SideSettings

    sim = diag.Simulator(8)
    outcome, frames, _ = sim.run(9, "reference", "camera")
    row = SideRunner(SideSettings())(Job(8, 9, "camera", "A", "reference"))
    assert (outcome.failed, outcome.aeb_time) == (row["failed"], row["aeb_time"])
    fired = [f for f in frames if f["fire"]]
    assert fired and fired[0]["t"] == pytest.approx(outcome.aeb_time)
    assert any(a["dhit"] and a["score"] >= 0.5 for a in fired[0]["actors"])
