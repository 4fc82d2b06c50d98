"""Experiments whose campaigns judged nothing exit non-zero with one line (issue 26).

A backend whose every run raises used to give ``experiment faults`` an exit status 0 and a
table of "0/4, 0 %", ``experiment flakiness`` "0 situations" and ``experiment race``
"0 regions". Each now ends with one ``error:`` line naming the campaign and its first error.
"""

from __future__ import annotations

import pytest

from sitcov.cli import main

RAISING = "campaign_fakes:RaisingBackend"

COMMANDS = {
    "faults": ["experiment", "faults", "--runs", "4", "--seeds", "1", "--generators", "random",
               "--executor", "serial"],
    "flakiness": ["experiment", "flakiness", "--situations", "4", "--repeats", "2",
                  "--executor", "serial"],
    "race": ["experiment", "race", "--runs", "4", "--seeds", "1", "--generators", "random",
             "--reference-runs", "4", "--workers", "1"],
}  # fmt: skip


@pytest.mark.parametrize("experiment", sorted(COMMANDS))
def test_an_experiment_whose_runs_all_error_exits_with_one_line(tmp_path, capsys, experiment):
    db = tmp_path / f"{experiment}.db"
    args = [*COMMANDS[experiment], "--backend", RAISING, "--db", str(db)]
    with pytest.raises(SystemExit) as exit_info:
        main(args)
    out, err = capsys.readouterr()
    assert exit_info.value.code == 2
    lines = [line for line in err.splitlines() if line.strip()]
    assert len(lines) == 1 and lines[0].startswith("error:"), err
    assert "measured nothing" in lines[0] and "fake backend exploded" in lines[0]
    assert f"experiment {experiment}" in lines[0]
    assert "Traceback" not in out + err and "0/4" not in out
