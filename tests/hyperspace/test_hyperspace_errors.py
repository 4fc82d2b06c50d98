"""Every bad hyperspace file gives one ConfigError line: file, field path, expectation."""

from __future__ import annotations

import pytest

from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace

GOOD_ELEMENT = "{name: b, bins: [{value: 1}, {value: 2}]}"


def doc(elements: str = "", constraints: str = "[]", top: str = "") -> str:
    elements = elements or "[{name: a, bins: [{value: 0}, {value: 20}]}, " + GOOD_ELEMENT + "]"
    head = f"name: t\n{top}axes:\n  - name: env\n"
    return head + f"    elements: {elements}\nconstraints: {constraints}\n"


CASES = [
    ("unknown top key", doc(top="colour: red\n"), ["colour", "no such key", "allowed: name"]),
    (
        "unknown element key",
        doc("[{name: a, units: m, bins: [{value: 1}]}]"),
        ["axes[0].elements[0].units", "no such key", "unit"],
    ),
    (
        "bins not a list",
        doc("[{name: a, bins: 5}]"),
        ["axes[0].elements[0].bins", "a list", "got 5"],
    ),
    (
        "name not a string",
        doc("[{name: 7, bins: [{value: 1}]}]"),
        ["axes[0].elements[0].name", "a string", "got 7"],
    ),
    ("empty bins", doc("[{name: a, bins: []}]"), ["axes[0].elements[0].bins", "at least one bin"]),
    (
        "duplicate labels",
        doc("[{name: a, bins: [{value: 1}, {label: '1', value: 3}]}]"),
        ["axes[0].elements[0].bins[1].label", "unique", "'1'"],
    ),
    (
        "duplicate elements",
        doc("[" + GOOD_ELEMENT + ", " + GOOD_ELEMENT + "]"),
        ["axes[0].elements[1].name", "unique element name", "'b'"],
    ),
    (
        "value and range",
        doc("[{name: a, bins: [{value: 1, range: [0, 2]}]}]"),
        ["axes[0].elements[0].bins[0]", "exactly one of 'value'"],
    ),
    (
        "neither value nor range",
        doc("[{name: a, bins: [{label: x}]}]"),
        ["bins[0]", "exactly one of"],
    ),
    ("bad range", doc("[{name: a, bins: [{range: [5, 1]}]}]"), ["bins[0].range", "lo < hi"]),
    (
        "range of strings",
        doc("[{name: a, bins: [{range: [a, 1]}]}]"),
        ["bins[0].range[0]", "got 'a'"],
    ),
    (
        "mapping category without label",
        doc("[{name: a, bins: [{value: {ego: L-B}}]}]"),
        ["bins[0].label", "a label"],
    ),
    (
        "constraint unknown element",
        doc(constraints="[{forbid: {zz: ['1']}}]"),
        ["constraints[0].forbid.zz", "an element name", "'zz'"],
    ),
    (
        "constraint unknown label",
        doc(constraints="[{forbid: {b: ['9']}}]"),
        ["constraints[0].forbid.b[0]", "a bin label of 'b'", "'9'"],
    ),
    (
        "everything forbidden",
        doc(constraints="[{forbid: {b: ['1', '2']}}]"),
        ["constraints", "at least one allowed situation"],
    ),
    ("yaml syntax", "name: t\naxes: [\n  - x: {\n", ["line 3", "expected valid YAML"]),
    ("duplicate yaml key", "name: t\nname: u\naxes: []\n", ["line 2", "duplicate key 'name'"]),
    ("not a mapping", "- 1\n- 2\n", ["(top level)", "a mapping"]),
    ("no axes", "name: t\naxes: []\n", ["axes", "at least one axis"]),
]


@pytest.mark.parametrize(("case", "text", "needles"), CASES, ids=[c[0] for c in CASES])
def test_bad_file_gives_one_clear_line(tmp_path, case, text, needles):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    with pytest.raises(ConfigError) as info:
        load_hyperspace(path)
    message = str(info.value)
    assert message.startswith(f"{path}: "), message
    assert "\n" not in message
    for needle in needles:
        assert needle in message, (needle, message)


def test_numbers_in_constraints_match_point_labels(tmp_path):
    path = tmp_path / "ok.yaml"
    path.write_text(doc(constraints="[{forbid: {a: [20], b: [2]}}]"))
    hs = load_hyperspace(path)
    assert hs.n_situations == 3


def test_missing_file(tmp_path):
    with pytest.raises(ConfigError, match="nope.yaml: file not found"):
        load_hyperspace(tmp_path / "nope.yaml")


def test_cli_prints_one_line_and_exit_code_2(tmp_path, capsys):
    path = tmp_path / "bad.yaml"
    path.write_text(doc("[{name: a, bins: []}]"))
    with pytest.raises(SystemExit) as info:
        main(["hyperspace", "show", "--hyperspace", str(path)])
    assert info.value.code == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.strip().count("\n") == 0 and "at least one bin" in err


def test_cli_show_default(capsys):
    main(["hyperspace", "show"])
    out = capsys.readouterr().out
    assert "20,155,392 distinct situations" in out
    assert "IntSit-12" in out and "friction" in out
