"""The sitcov command itself: usage errors and library errors end as one message, no traceback."""

from __future__ import annotations

import subprocess
import sys

import pytest


def sitcov(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run(
        [sys.executable, "-c", "from sitcov.cli import main; main()", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["generate", "-n", "2", "--seed", "x"], "Invalid value for '--seed'"),
        (["run", "--no-such-flag"], "No such option: --no-such-flag"),
        (["summary"], "Missing option '--db'"),
        (["summary", "--db", "no-such.db"], "no-such.db"),
        (["generate", "-n", "1", "--generator", "nope"], "unknown generator 'nope'"),
    ],
)
def test_bad_input_is_one_message_and_exit_code_2(args, message):
    result = sitcov(*args)
    assert result.returncode == 2
    assert message in result.stderr
    assert "Traceback" not in result.stderr + result.stdout


def test_help_lists_every_command_of_the_interface_contract():
    result = sitcov("--help")
    assert result.returncode == 0
    for command in ("run", "summary", "generate", "report", "experiment", "replay", "export"):
        assert command in result.stdout
