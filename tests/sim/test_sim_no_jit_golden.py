"""The plain-Python fallback gives the golden runs bit for bit, end to end.

numba is a dependency, so the suite's own process runs the compiled kernels; a process
started with ``SITCOV_NO_JIT=1`` runs the Python source of every kernel instead. Each
kernel is compared with its Python code in ``test_sim_jit.py``; this test checks that a
whole run, made of all of them, also lands on the same bits: the fast subsets of both
golden files (two cars; many actors on every shipped map) pass in such a process.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

HERE = Path(__file__).parent
ROOT = HERE.parent.parent


@pytest.mark.slow
def test_golden_subsets_pass_without_numba() -> None:
    env = {**os.environ, "SITCOV_NO_JIT": "1", "PYTHONPATH": str(ROOT)}
    tests = [
        f"{HERE / 'test_sim_world_golden.py'}::test_every_seventh_golden_run_is_reproduced_exactly",
        f"{HERE / 'test_sim_world_actors_golden.py'}"
        "::test_every_fifth_golden_multi_actor_run_is_reproduced_exactly",
    ]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", *tests],
        cwd=ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "2 passed" in done.stdout, done.stdout[-2000:]
