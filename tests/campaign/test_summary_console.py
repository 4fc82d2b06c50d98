"""The console summary states what the JSON summary states (issue 26).

It printed 10/30 = 33.3 % and "errors + timeouts 0" where the JSON said a failure rate of
0.4 and 5 time-outs (the console divided by runs - errors, forgetting time-outs), and its
per-kind rates added up to more than the total. Now every number of the console table is
the JSON's: checked here on a campaign with errors and time-outs, through the CLI.
"""

from __future__ import annotations

import json
import re

from sitcov.campaign import CampaignInfo, PlannedRun, open_store
from sitcov.cli import main
from sitcov.generation import make_generator
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import Outcome

#: (status, failure kind) of the 30 runs: 6 collisions, 4 road departures, 10 passes,
#: 5 errors and 5 time-outs: 10 failures out of 20 judged.
PLAN = (
    [("fail", "collision")] * 6
    + [("fail", "road_departure")] * 4
    + [("pass", "pass")] * 10
    + [("error", "error")] * 5
    + [("timeout", "timeout")] * 5
)


def _campaign(db) -> None:
    import numpy as np

    hs = load_hyperspace()
    gen = make_generator("random", hs)
    rng = np.random.default_rng(4)
    store = open_store(db)
    store.create_campaign(
        CampaignInfo(
            name="c",
            config={"name": "c", "judge": "default"},
            hyperspace=hs.to_dict(),
            sitcov_version="t",
            created="2026-01-01T00:00:00+00:00",
            generator="random",
            world_version=1,
        ),
        [PlannedRun(i, gen.ask(rng), i) for i in range(len(PLAN))],
    )
    for i, (status, kind) in enumerate(PLAN):
        if status in ("error", "timeout"):
            outcome = Outcome.errored("boom", status=status)
        else:
            outcome = Outcome(status=status, end_reason="goal", failure_kind=kind)
        store.record_result("c", i, outcome, 0.01)
    store.close()


def _cli(capsys, args: list[str]) -> str:
    main(args)
    return capsys.readouterr().out


def _row(text: str, label: str) -> str:
    for line in text.splitlines():
        cells = line.strip().strip("│").strip()
        if re.match(rf"{re.escape(label)}\s{{2,}}", cells) or re.match(
            rf"{re.escape(label)}\s+\S", cells
        ):
            return cells[len(label) :].strip(" │")
    raise AssertionError(f"no row {label!r} in:\n{text}")


def _pct(x: float) -> str:
    return f"{100 * x:.1f}%"


def test_console_and_json_summaries_agree_with_errors_and_timeouts(tmp_path, capsys) -> None:
    db = tmp_path / "c.db"
    _campaign(db)
    data = json.loads(_cli(capsys, ["summary", "--db", str(db), "--json"]))
    text = _cli(capsys, ["summary", "--db", str(db)])
    # the JSON, as documented: failures over judged runs (pass + fail)
    assert (data["runs"], data["failures"], data["passes"]) == (30, 10, 10)
    assert (data["errors"], data["timeouts"]) == (5, 5)
    assert data["failure_rate"] == 0.5
    # the console says the same, number for number
    judged = data["passes"] + data["failures"]
    assert _row(text, "runs").startswith(f"{data['runs']}  ({judged} judged)")
    rate = _row(text, "failure rate")
    lo, hi = data["ci95"]
    assert rate.startswith(f"{_pct(data['failure_rate'])}  (95% CI {_pct(lo)} - {_pct(hi)})")
    assert f"of {judged} judged" in rate
    assert _row(text, "errors + timeouts") == f"{data['errors']} + {data['timeouts']}"
    shown = 0.0
    for kind, k in data["failures_by_kind"].items():
        if not k["failures"]:
            continue
        row = _row(text, kind.replace("_", " "))
        klo, khi = k["ci95"]
        assert row.startswith(f"{k['failures']}  {_pct(k['failure_rate'])}  (95% CI {_pct(klo)}")
        assert khi >= k["failure_rate"]
        shown += k["failure_rate"]
    # the kinds partition the failures: their rates add up to the total, not more
    assert shown == data["failure_rate"]
