"""Published figures are generated, not typed (issue 26): docs/figures.yaml lists them and
benchmarks/figures.py checks them. These tests check the list and the tool itself; CI runs
``python benchmarks/figures.py check`` (the cheap figures re-measured, .ci/run)."""

from __future__ import annotations

import importlib.util
import io
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _tool():
    spec = importlib.util.spec_from_file_location("figures_tool", ROOT / "benchmarks/figures.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules["figures_tool"] = module
    spec.loader.exec_module(module)
    return module


figures = _tool()


def test_every_listed_figure_is_where_the_list_says() -> None:
    listed = figures.load()
    assert figures.missing_texts(listed) == []
    assert {f.cost for f in listed} == {"cheap", "expensive"}
    for f in listed:
        assert "sitcov " in f.command or "python " in f.command, f.id  # public commands
        assert str(f.measured["load"]).strip() and str(f.measured["date"]).strip(), f.id


def test_the_figures_issue_26_found_wrong_are_listed() -> None:
    ids = {f.id for f in figures.load()}
    assert {"explain-600-failures", "explain-600-cpu", "flakiness-flaky", "flakiness-flip",
            "readme-runs-per-core", "agreement-pooled"} <= ids  # fmt: skip


def _figure(**kw):
    base = dict(id="x", file="README.md", text="sitcov", command="echo", read={"json": "a.b"},
                value=10.0, tolerance=0.5, relative=False, cost="cheap",
                measured={"date": "d", "load": "l"})  # fmt: skip
    return figures.Figure(**{**base, **kw})


def test_reading_and_tolerances() -> None:
    assert figures.read_value({"json": "a.1"}, 'noise\n{"a": [0, 3.5]}\nmore\n') == 3.5
    assert figures.read_value({"regex": r"(\d+) flaky"}, "x 45 flaky (22 %)") == 45.0
    pretty = 'running...\n{\n  "runs_per_s": 212.5,\n  "rounds": 3\n}\n'  # rich print_json
    assert figures.read_value({"json": "runs_per_s"}, pretty) == 212.5
    with pytest.raises(figures.FigureError):
        figures.read_value({"regex": r"(\d+) nope"}, "nothing")
    assert figures.within(_figure(), 10.4) and not figures.within(_figure(), 10.6)
    rel = _figure(tolerance=0.1, relative=True)
    assert figures.within(rel, 10.9) and not figures.within(rel, 11.2)


def test_check_runs_each_command_once_and_reports_misses(tmp_path) -> None:
    good = _figure(id="good", command="""echo '{"a": {"b": 10.2}}'""")
    same = _figure(id="same", command=good.command, value=11.0)  # misses its tolerance
    broken = _figure(id="broken", command="exit 3")
    out = io.StringIO()
    assert figures.check([good, same, broken], out=out) == 2
    text = out.getvalue()
    assert text.count("ran ") == 2  # the shared command ran once
    assert "ok   good: published 10, measured 10.2" in text
    assert "FAIL same: published 11, measured 10.2" in text
    assert "FAIL broken: exit 3" in text


def test_a_malformed_list_is_one_clear_error(tmp_path) -> None:
    bad = tmp_path / "f.yaml"
    bad.write_text("figures:\n  - {id: a, file: README.md}\n")
    with pytest.raises(figures.FigureError, match=r"figures\[0\] \(a\): missing text"):
        figures.load(bad)
