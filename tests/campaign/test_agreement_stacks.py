"""The agreement experiment per stack: rows per stack, pairs within a stack, left/right sides."""

from __future__ import annotations

from dataclasses import asdict
from pathlib import Path

import pytest

from sitcov.campaign import _agreement as ag
from sitcov.errors import SitcovError
from sitcov.sim import WORLD_MODEL_VERSION

ROOT = Path(__file__).resolve().parents[2]
#: From tests/av/test_plugins.py: where the OV comes from in each intsit bin.
OV_FROM_LEFT = ("IntSit-5", "IntSit-8", "IntSit-9", "IntSit-10")
OV_FROM_RIGHT = ("IntSit-3", "IntSit-4", "IntSit-6", "IntSit-7")
SIDES = ag.situation_sides([3], 200)


def fake_run(job: ag.Job) -> dict:
    """A verdict from the run seed; the stack ``blind`` also fails every situation whose
    road user comes from the right."""
    seed = ag.stream_seed(job.stream, job.seed, job.index)
    failed = seed % 100 < 30 or (job.stack == "blind" and SIDES[job.seed, job.index] == "right")
    return {
        **asdict(job), "situation_id": f"sit-{job.seed}-{job.index}", "run_seed": seed,
        "status": "fail" if failed else "pass", "failed": failed, "aeb_time": None,
        "cpu_s": 0.5, "wall_s": 0.5, "world_model": WORLD_MODEL_VERSION,
    }  # fmt: skip


def test_approach_side_agrees_with_the_intsit_bins() -> None:
    from sitcov.hyperspace import load_hyperspace

    hs = load_hyperspace()
    for b in hs.element("intsit").bins:
        side = ag.approach_side({}, {"intsit": b.draw()})
        expected = (
            "left" if b.label in OV_FROM_LEFT else "right" if b.label in OV_FROM_RIGHT else "ahead"
        )
        assert side == expected, b.label
    assert ag.approach_side({}, {}) == "other"


def test_every_stack_gets_its_rows_pairs_and_sides(tmp_path: Path) -> None:
    out = tmp_path / "rows.csv"
    summary = ag.run_agreement(
        seeds=[3], situations=200, out=out, run_job=fake_run, stacks=["reference", "blind"],
        pairs=["pem-camera", "camera-camera"],
    )  # fmt: skip
    rows = ag.read_rows(out)
    assert {r["stack"] for r in rows} == {"reference", "blind"}
    assert len(rows) == 2 * 200 * 3  # per stack: camera@A, camera@B, pem@B
    assert set(summary["stacks"]) == {"reference", "blind"}
    assert summary["pairs"] == summary["stacks"]["reference"]["pairs"]
    ref, blind = summary["stacks"]["reference"], summary["stacks"]["blind"]
    for side in ("camera@A", "camera@B", "pem@B"):
        # the blind stack fails every right-side situation, significantly more than left
        assert blind["sides"][side]["right"]["failure_rate"] == 1.0
        assert blind["sides"][side]["p_right_fails_more"] < 1e-6
        assert ref["sides"][side]["p_right_fails_more"] > 0.01
    lines = ag.table_lines(summary)
    assert "== stack blind" in lines and any("from the right 100.0%" in x for x in lines)
    assert blind["side_verdict"] == "from the right fails more in both modes (the stack's)"
    assert any(x.startswith("  sides, p < 0.05: from the right") for x in lines)


def test_camera_rows_are_reused_per_stack(tmp_path: Path) -> None:
    ag.run_agreement(seeds=[3], situations=10, out=tmp_path / "a.csv", run_job=fake_run,
                     stacks=["blind"], pairs=["camera-camera"])  # fmt: skip
    calls = []

    def counting(job: ag.Job) -> dict:
        calls.append(job)
        return fake_run(job)

    ag.run_agreement(seeds=[3], situations=10, out=tmp_path / "b.csv", run_job=counting,
                     stacks=["reference", "blind"], pairs=["pem-camera"],
                     camera_rows=tmp_path / "a.csv")  # fmt: skip
    assert {(j.perception, j.stack) for j in calls} == {("pem", "reference"), ("pem", "blind"),
                                                        ("camera", "reference")}  # fmt: skip


def test_stack_names_are_checked(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.syspath_prepend(str(ROOT))
    assert ag.parse_stacks(None) == ["reference"]
    names = ag.parse_stacks(["reference,examples.aeb_stacks:RightBlind", "reference"])
    assert names == ["reference", "examples.aeb_stacks:RightBlind"]
    with pytest.raises(SitcovError):
        ag.parse_stacks(["no-such-stack"])


def test_the_side_verdict_says_whose_weakness_a_side_is() -> None:
    """Both modes: the stack's; PEM mode only: the PEM's bias; camera only: hidden by the
    PEM; one mode's rows alone: no verdict."""

    def row(p_right: float, p_left: float) -> dict:
        return {"p_right_fails_more": p_right, "p_left_fails_more": p_left}

    both = {"camera@A": row(1e-5, 1.0), "pem@B": row(0.002, 1.0)}
    assert ag.side_verdict(both) == "from the right fails more in both modes (the stack's)"
    pem_only = {"camera@A": row(0.8, 0.37), "camera@B": row(0.6, 0.3), "pem@A": row(0.99, 0.03)}
    said = ag.side_verdict(pem_only)
    assert said.startswith("from the left fails more in PEM mode only (not shown to be the")
    assert "under-reports close cars from the left" in said
    right_only = {"camera@A": row(0.8, 0.37), "pem@A": row(0.03, 0.99)}
    assert "under-reports" not in ag.side_verdict(right_only)
    hidden = {"camera@A": row(0.01, 0.9), "pem@B": row(0.2, 0.7)}
    assert (
        ag.side_verdict(hidden)
        == "from the right fails more in camera mode only (the PEM hides it)"
    )
    none = {"camera@A": row(0.5, 0.5), "pem@B": row(0.5, 0.5)}
    assert ag.side_verdict(none) == "neither side fails significantly more in either mode"
    assert ag.side_verdict({"pem@A": row(0.001, 1.0), "pem@B": row(0.5, 0.5)}) is None
