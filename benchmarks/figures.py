"""Published figures, generated, not typed: check docs/figures.yaml against fresh runs.

Every figure in README.md and docs/*.md that a command produces is an entry of
docs/figures.yaml: where it is (file and the exact text), the command that produces it, how
the number is read from the command's output, the published value, a tolerance, a cost
class and when it was last measured (date, machine load). This tool

- ``texts``: checks that every entry's text is still in its file (a figure edited in the
  docs without its entry, or the reverse, fails);
- ``check [--cost cheap|expensive|all] [--id ID ...]``: runs the commands (each in a fresh
  temporary directory) and checks each figure within its tolerance; exits 1 on any miss,
  printing published vs measured for every figure.

CI (.ci/run) runs ``check`` on the cheap figures (seconds to a minute of CPU each); the
expensive ones (timings that depend on the machine, camera-mode runs) are re-measured by
hand at least once per change of the world model, and their ``measured`` field updated.

Why a script here and not a ``sitcov`` sub-command: the figures and the documents they
live in belong to the repository, not to the installed package (a wheel has no docs/), and
the tool only re-runs public ``sitcov`` commands.

Usage::

    python benchmarks/figures.py texts
    python benchmarks/figures.py check                 # the cheap figures (CI)
    python benchmarks/figures.py check --id flakiness-flaky --cost all
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

ROOT = Path(__file__).resolve().parents[1]
FIGURES = ROOT / "docs" / "figures.yaml"
COSTS = ("cheap", "expensive")
_REQUIRED = ("id", "file", "text", "command", "read", "value", "tolerance", "cost", "measured")


class FigureError(Exception):
    """docs/figures.yaml is malformed (the message names the entry and field)."""


@dataclass(frozen=True)
class Figure:
    """One published figure (see the module docstring and docs/figures.yaml's header)."""

    id: str
    file: str
    text: str
    command: str
    read: Mapping[str, Any]
    value: float
    tolerance: float
    relative: bool
    cost: str
    measured: Mapping[str, Any]


def load(path: Path = FIGURES) -> list[Figure]:
    """The entries of ``path``, validated (FigureError naming entry and field)."""
    doc = yaml.safe_load(path.read_text())
    entries = doc.get("figures") if isinstance(doc, dict) else None
    if not isinstance(entries, list) or not entries:
        raise FigureError(f"{path}: figures: expected a non-empty list")
    out, seen = [], set()
    for i, raw in enumerate(entries):
        where = f"{path}: figures[{i}]"
        if not isinstance(raw, dict):
            raise FigureError(f"{where}: expected a mapping")
        missing = [k for k in _REQUIRED if k not in raw]
        if missing:
            raise FigureError(f"{where} ({raw.get('id')}): missing {', '.join(missing)}")
        if raw["id"] in seen:
            raise FigureError(f"{where}: id {raw['id']!r} used twice")
        seen.add(raw["id"])
        if raw["cost"] not in COSTS:
            raise FigureError(f"{where}: cost: expected {' | '.join(COSTS)}, got {raw['cost']!r}")
        read = raw["read"]
        if not isinstance(read, dict) or len(read) != 1 or not {"json", "regex"} & set(read):
            raise FigureError(f"{where}: read: expected {{json: PATH}} or {{regex: PATTERN}}")
        tol = str(raw["tolerance"])
        relative = tol.endswith("%")
        measured = raw["measured"]
        if not isinstance(measured, dict) or not {"date", "load"} <= set(measured):
            raise FigureError(f"{where}: measured: expected {{date, load}}")
        out.append(
            Figure(
                id=str(raw["id"]),
                file=str(raw["file"]),
                text=str(raw["text"]),
                command=str(raw["command"]),
                read=read,
                value=float(raw["value"]),
                tolerance=float(tol.rstrip("%")) / (100.0 if relative else 1.0),
                relative=relative,
                cost=str(raw["cost"]),
                measured=measured,
            )
        )
    return out


def missing_texts(figures: Sequence[Figure], root: Path = ROOT) -> list[str]:
    """One line per figure whose text is no longer in its file."""
    problems = []
    for f in figures:
        path = root / f.file
        if not path.is_file():
            problems.append(f"{f.id}: {f.file} does not exist")
        elif f.text not in " ".join(path.read_text().split()):
            problems.append(f"{f.id}: {f.file} no longer says {f.text!r}")
    return problems


def read_value(read: Mapping[str, Any], output: str) -> float:
    """The number in a command's ``output``: ``json`` = a dotted path into the last line
    that parses as JSON (``a.b.0``); ``regex`` = the first group of the first match."""
    if "json" in read:
        data = _last_json(output)
        for key in str(read["json"]).split("."):
            data = data[int(key)] if isinstance(data, list) else data[key]
        return float(data)
    match = re.search(str(read["regex"]), output)
    if match is None:
        raise FigureError(f"no match for {read['regex']!r} in the output")
    return float(match.group(1))


def _last_json(output: str) -> Any:
    """The last JSON value of ``output``: a JSON line, or a pretty-printed block running
    from a line that starts with ``{`` or ``[`` to the end (``rich``'s ``print_json``)."""
    lines = output.strip().splitlines()
    for i in range(len(lines) - 1, -1, -1):
        for candidate in (lines[i], "\n".join(lines[i:])):
            if candidate.lstrip()[:1] in ("{", "["):
                try:
                    return json.loads(candidate)
                except ValueError:
                    continue
    raise FigureError("no JSON in the output")


def within(figure: Figure, measured: float) -> bool:
    """``measured`` equals the published value within the figure's tolerance."""
    allowed = figure.tolerance * (abs(figure.value) if figure.relative else 1.0)
    return abs(measured - figure.value) <= allowed + 1e-12


def run_command(command: str, cwd: Path) -> str:
    """stdout + stderr of ``command`` (bash, in ``cwd``, with this checkout importable)."""
    env = dict(os.environ)
    env["PYTHONPATH"] = str(ROOT) + (os.pathsep + env["PYTHONPATH"] if "PYTHONPATH" in env else "")
    env["SITCOV_ROOT"] = str(ROOT)
    proc = subprocess.run(
        ["bash", "-c", f"set -euo pipefail; {command}"],
        cwd=cwd,
        env=env,
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        tail = (proc.stderr or proc.stdout).strip().splitlines()[-3:]
        raise FigureError(f"exit {proc.returncode}: {' | '.join(tail)}")
    return proc.stdout + proc.stderr


def check(figures: Sequence[Figure], out: Any = sys.stdout) -> int:
    """Run each figure's command (one run per distinct command) and compare; the number of
    figures that do not hold."""
    outputs: dict[str, str | FigureError] = {}
    bad = 0
    for f in figures:
        if f.command not in outputs:
            start = time.perf_counter()
            with tempfile.TemporaryDirectory(prefix="sitcov-figure-") as tmp:
                try:
                    outputs[f.command] = run_command(f.command, Path(tmp))
                except FigureError as exc:
                    outputs[f.command] = exc
            print(f"  ran {f.command!r} in {time.perf_counter() - start:.1f} s", file=out)
        got = outputs[f.command]
        try:
            if isinstance(got, FigureError):
                raise got
            value = read_value(f.read, got)
        except (FigureError, KeyError, IndexError, TypeError, ValueError) as exc:
            print(f"FAIL {f.id}: {exc}", file=out)
            bad += 1
            continue
        tol = f"{100 * f.tolerance:g}%" if f.relative else f"{f.tolerance:g}"
        ok = within(f, value)
        bad += not ok
        verdict = "ok  " if ok else "FAIL"
        print(f"{verdict} {f.id}: published {f.value:g}, measured {value:g} (+-{tol})", file=out)
    return bad


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="what", required=True)
    sub.add_parser("texts", help="every figure's text is in its file")
    run = sub.add_parser("check", help="re-run the figures' commands and compare")
    run.add_argument("--cost", choices=(*COSTS, "all"), default="cheap")
    run.add_argument("--id", action="append", default=[], help="only these figures")
    args = parser.parse_args(argv)
    try:
        figures = load()
    except FigureError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    problems = missing_texts(figures)
    for line in problems:
        print(f"FAIL {line}")
    if args.what == "texts":
        print(f"{len(figures) - len(problems)}/{len(figures)} figure texts found")
        return 1 if problems else 0
    chosen = [
        f
        for f in figures
        if (args.cost == "all" or f.cost == args.cost) and (not args.id or f.id in args.id)
    ]
    if args.id and len(chosen) < len(set(args.id)):
        known = sorted({f.id for f in chosen})
        print(f"error: --id: unknown or not of cost {args.cost}: {set(args.id) - set(known)}")
        return 2
    bad = check(chosen)
    print(f"{len(chosen) - bad}/{len(chosen)} figures hold ({args.cost})")
    return 1 if bad or problems else 0


if __name__ == "__main__":
    sys.exit(main())
