"""The Python examples in docs/campaigns.md run as written."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

DOC = Path(__file__).resolve().parents[2] / "docs" / "campaigns.md"


def blocks() -> list[str]:
    return re.findall(r"```python\n(.*?)```", DOC.read_text(), flags=re.S)


def test_there_is_an_example():
    assert blocks()


@pytest.mark.parametrize("code", blocks())
def test_example_runs(code, capsys):
    exec(compile(code, str(DOC), "exec"), {})
    out = capsys.readouterr().out
    assert "'demo'" in out and "'pending': 0" in out
