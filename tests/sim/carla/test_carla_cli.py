"""The CLI: `sitcov run --backend carla` without a server, and `sitcov export-xosc`."""

from __future__ import annotations

import json
import socket
import subprocess
import sys
import time

import pytest
from carla_testkit import situation
from needs import need_module

from sitcov.cli import main


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


def _run_without_server(tmp_path, executor: str) -> None:
    need_module("carla", "carla")
    cfg = tmp_path / "carla.yaml"
    cfg.write_text(
        f"backend_options: {{host: 127.0.0.1, port: {_free_port()}, timeout: 1.0}}\nruns: 3\n"
    )
    cmd = [sys.executable, "-c", "from sitcov.cli import main; main()"]
    args = ["run", "--backend", "carla", "--config", str(cfg), "--db", str(tmp_path / "c.db")]
    start = time.monotonic()
    proc = subprocess.run(
        [*cmd, *args, "--executor", executor], capture_output=True, text=True, timeout=120
    )
    elapsed = time.monotonic() - start
    assert proc.returncode != 0
    lines = [line for line in proc.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert "no CARLA server at 127.0.0.1:" in lines[0] and "after 1s" in lines[0]
    assert "Traceback" not in proc.stderr + proc.stdout
    assert elapsed < 60.0  # 1 s time-out plus interpreter and import start-up


def test_run_without_server_fails_with_one_line(tmp_path) -> None:
    _run_without_server(tmp_path, "serial")


@pytest.mark.slow
def test_run_without_server_fails_with_one_line_from_worker_processes(tmp_path) -> None:
    _run_without_server(tmp_path, "processes")


def test_export_xosc_from_situation_json(tmp_path, capsys) -> None:
    need_module("scenariogeneration", "xosc")
    sits = [situation(), situation("R-L", "B-L", "c2")]
    text = "\n".join(json.dumps(s.to_dict()) for s in sits)
    main(["export-xosc", "--situation-json", text, "--out", str(tmp_path)])
    out = capsys.readouterr().out.split()
    assert sorted(out) == sorted(str(tmp_path / f"{s.id}.xosc") for s in sits)


def test_export_xosc_needs_exactly_one_source(tmp_path, capsys) -> None:
    with pytest.raises(SystemExit) as info:
        main(["export-xosc", "--out", str(tmp_path)])
    assert info.value.code == 2
    assert "exactly one of --situation-json, --db" in capsys.readouterr().err


@pytest.mark.slow
def test_export_xosc_writes_the_failing_runs_of_a_database(tmp_path, capsys) -> None:
    need_module("scenariogeneration", "xosc")
    from sitcov.campaign import open_store

    db = tmp_path / "e.db"
    main(["run", "--db", str(db), "--runs", "12", "--executor", "serial", "--av", "no-perception"])
    store = open_store(db)
    failing = {r.situation.id for r in store.runs(status="fail")}
    store.close()
    assert failing  # a blind ego meets the adversary
    capsys.readouterr()
    main(["export-xosc", "--db", str(db), "--out", str(tmp_path / "x")])
    written = {p.stem for p in (tmp_path / "x").glob("*.xosc")}
    assert written == failing
