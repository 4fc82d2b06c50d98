"""Running ``sitcov`` in the test's own process (any test folder: tests/ is on sys.path)."""

from __future__ import annotations

from typing import Any


def run_cli(capsys: Any, *args: str) -> tuple[int, str, str]:
    """``sitcov ARGS`` in this process: (exit code, stdout, stderr). An exception escaping
    ``main`` (a traceback) fails the test."""
    from sitcov.cli import main

    try:
        main(list(args))
        code = 0
    except SystemExit as exc:
        code = int(exc.code or 0)
    out, err = capsys.readouterr()
    return code, out, err
