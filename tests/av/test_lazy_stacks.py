"""No verdict is earned by not driving: the example stacks that brake for ever or creep
10 m and stop fail every run under the default judge (and pass under the paper's)."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path

import pytest

from sitcov.campaign import load_config, open_store, run_campaign
from sitcov.campaign._summary import summarize_store
from sitcov.sim import Judge

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.mark.parametrize(
    ("script", "completion"),
    [("always_brake_stack.py", (0.0, 0.0)), ("creep_stack.py", (0.05, 0.25))],
)
def test_a_stack_that_does_not_drive_fails_every_run_under_default(script, completion):
    cmd = f"{shlex.quote(sys.executable)} {shlex.quote(str(EXAMPLES / script))}"
    store = open_store(None)
    cfg = load_config(
        overrides={"runs": 8, "generator": "random", "av": "cmd:" + cmd, "workers": 1}
    )
    run_campaign(cfg, store)
    default = summarize_store(store)
    assert default["judge"] == "default"
    assert default["failures"] == default["runs"] == 8
    kinds = {k for k, v in default["failures_by_kind"].items() if v["failures"]}
    assert kinds <= {"blocked", "route_incomplete"}
    done = default["route_completion"]
    assert done["goal_rate"] == 0.0 and completion[0] <= done["mean"] <= completion[1]
    # the paper's judge cannot tell: the same facts pass
    assert all(Judge.from_spec("paper")(r.outcome).status == "pass" for r in store.runs())
