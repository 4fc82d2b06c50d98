"""An external stack that misbehaves: each way ends in a stored error run, in bounded time,
with nothing left running, and the campaign goes on (fixture: stacks/unruly_stack.py)."""

from __future__ import annotations

import resource
import sys
import time
from pathlib import Path

import pytest
from reliability_helpers import processes_mentioning, wait_for

from sitcov.campaign import CampaignConfig, open_store, run_campaign

STACK = Path(__file__).resolve().parent / "stacks" / "unruly_stack.py"
RUNS = 9

#: mode -> (status of the misbehaving runs, words their stored message contains)
CASES = {
    "flood-stdout": ("error", "sent more than one line in answer to step"),
    "long-line": ("error", "wrote more than 4 MiB on stdout without a newline"),
    # logged in 16 KiB pieces; writing 100 MB may outlast the 1 s step time-out under load
    "stderr-flood": (None, ""),
    "bad-utf8": ("error", "expected a JSON object with a 'type' on stdout"),
    "exit0": ("error", "exited with code 0 during step"),
    "ignore-term": ("timeout", "did not answer the step within 1 s"),
    "fork-escape": ("error", "exited with code 5 during step"),
    "memory": ("error", "MemoryError"),
}


def children_rss_mb() -> float:
    """Peak resident memory of this process's reaped children [MiB]."""
    return resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024


@pytest.mark.parametrize("mode", list(CASES))
def test_a_misbehaving_stack_fails_only_its_runs(tmp_path, mode):
    status, words = CASES[mode]
    config = CampaignConfig(
        name=mode,
        av=f"cmd:{sys.executable} {STACK} {mode}",
        av_params={"step_timeout": 1.0},
        backend_options={"sim_timeout": 0.5},
        runs=RUNS,
        seed=4,
        executor="serial",
    )
    began, peak = time.perf_counter(), resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    with open_store(tmp_path / "c.db") as store:
        result = run_campaign(config, store)
        runs = store.runs(mode)
    took = time.perf_counter() - began
    grew = (resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - peak) / 1024
    assert result.counts["pending"] == 0 and len(runs) == RUNS
    bad = [r for r in runs if r.seed % 3 == 1]
    good = [r for r in runs if r.seed % 3 != 1]
    assert bad and good
    assert all(r.status in ("pass", "fail") for r in good), [r.status for r in good]
    for run in bad:
        if status is None:
            assert run.status in ("pass", "fail", "timeout"), run.outcome.message
            continue
        assert run.status == status, run.outcome.message
        first = run.outcome.message.splitlines()[0]
        assert words in first and len(first) < 600, first
    assert took < 20 * len(bad) + 30, took  # bounded: step time-out, not the stack's sleep
    assert grew < 150, f"this process grew by {grew:.0f} MiB"  # a flood is never held
    wait_for(lambda: processes_mentioning(str(STACK)) == [], 5, "the stack processes to end")
    wait_for(lambda: processes_mentioning("unruly-daemon") == [], 5, "the escaped daemon")
    print(f"{mode}: {len(bad)} bad runs of {RUNS}, {took:.1f} s, parent grew {grew:.0f} MiB")
