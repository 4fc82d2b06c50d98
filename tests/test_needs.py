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


#: Every way a test can skip or expect failure without tests/needs.py: pytest's skip (call,
#: decorator, conditional decorator, module-level ``pytestmark``), xfail (call and mark),
#: importorskip, and unittest's SkipTest / skip decorators / skipTest / expectedFailure.
SKIP_FORMS = re.compile(
    r"importorskip\(|mark\.skip\b|mark\.skipif\b|\bpytest\.skip\b|\bskip\.Exception\b"
    r"|\bpytest\.xfail\b|mark\.xfail\b|\bSkipTest\b|\bunittest\.skip"
    r"|\.skipTest\(|\bexpectedFailure\b|\bskipIf\b|\bskipUnless\b"
)


def _offenders(root: Path, skip: tuple[str, ...]) -> list[str]:
    return [
        f"{path.relative_to(root)}:{n}"
        for path in root.rglob("*.py")
        if path.name not in skip
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if SKIP_FORMS.search(line)
    ]


def test_no_test_skips_around_tests_needs():
    """Every skip for a missing requirement goes through tests/needs.py (CI turns it into a
    failure); importorskip, skipif, xfail, unittest's SkipTest and a bare pytest.skip would
    vanish silently in CI."""
    offenders = _offenders(TESTS, ("needs.py", Path(__file__).name))
    assert offenders == [], "use tests/needs.py: " + ", ".join(offenders)


@pytest.mark.parametrize(
    "line",
    [
        "    pytest.skip('no gpu')",
        "@pytest.mark.skip(reason='later')",
        "@pytest.mark.skip",
        "pytestmark = pytest.mark.skipif(True, reason='x')",
        "    pytest.xfail('flaky')",
        "@pytest.mark.xfail(strict=False)",
        "    raise unittest.SkipTest('no')",
        "    raise SkipTest('no')",
        "@unittest.skip('x')",
        "@unittest.skipIf(True, 'x')",
        "@unittest.skipUnless(False, 'x')",
        "        self.skipTest('x')",
        "@unittest.expectedFailure",
        "np = pytest.importorskip('numpy')",
        "    raise pytest.skip.Exception('x')",
    ],
)
def test_the_guard_catches_every_skip_form(tmp_path, line):
    (tmp_path / "test_x.py").write_text(f"import pytest, unittest\n{line}\n")
    assert _offenders(tmp_path, ()) == ["test_x.py:2"]


def test_the_guard_lets_ordinary_code_through(tmp_path):
    text = "skipped = 0\nresult = run(skip_empty_frames=True)\nxfail_count = 3\n"
    (tmp_path / "test_y.py").write_text(text)
    assert _offenders(tmp_path, ()) == []
