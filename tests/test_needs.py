"""Tests cannot vanish in CI: missing requirements fail there, and sitcov is never skipped."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from needs import missing, need_module, need_program

TESTS = Path(__file__).resolve().parent


def test_missing_skips_locally_and_fails_in_ci(monkeypatch):
    monkeypatch.delenv("CI", raising=False)
    with pytest.raises(pytest.skip.Exception, match="no such thing"):
        missing("no such thing")
    for value in ("true", "1", "yes"):
        monkeypatch.setenv("CI", value)
        with pytest.raises(pytest.fail.Exception, match="no such thing.*CI is set"):
            missing("no such thing")
    monkeypatch.setenv("CI", "true")
    with pytest.raises(pytest.fail.Exception, match="sitcov\\[camera\\]"):
        need_module("no_such_module_xyz", "camera")
    with pytest.raises(pytest.fail.Exception, match="no_such_program_xyz"):
        need_program("no_such_program_xyz")


def test_sitcov_itself_is_never_optional():
    with pytest.raises(ValueError, match="never skipped"):
        need_module("sitcov.sim.embedded", "none")


def test_no_test_skips_around_tests_needs():
    """Every skip for a missing requirement goes through tests/needs.py (CI turns it into a
    failure); importorskip, skipif and a bare pytest.skip would vanish silently in CI."""
    pattern = re.compile(r"importorskip\(|mark\.skipif\(|pytest\.skip\(")
    offenders = [
        f"{path.relative_to(TESTS)}:{n}"
        for path in TESTS.rglob("*.py")
        if path.name not in ("needs.py", Path(__file__).name)
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if pattern.search(line)
    ]
    assert offenders == [], "use tests/needs.py: " + ", ".join(offenders)
