"""CI behaves like a fresh machine (issue 26: a green CI hid a missing step because its user
cache already held the detector model). .ci/run and .ci/fresh-clone source .ci/fresh-env."""

from __future__ import annotations

import os
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def test_fresh_env_gives_sitcov_empty_home_and_caches(tmp_path) -> None:
    env = {**os.environ, "TMPDIR": str(tmp_path), "SITCOV_MODEL_DIR": "/somewhere/with/a/model"}
    script = (
        f"source {ROOT / '.ci/fresh-env'} >/dev/null; "
        "for v in FRESH HOME XDG_CACHE_HOME XDG_DATA_HOME NUMBA_CACHE_DIR PYTEST_ADDOPTS; "
        'do echo "$v=${!v}"; done; echo "SITCOV_MODEL_DIR=${SITCOV_MODEL_DIR-unset}"'
    )
    out = subprocess.run(["bash", "-c", script], env=env, capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    got = dict(line.split("=", 1) for line in out.stdout.splitlines())
    fresh = Path(got["FRESH"])
    assert fresh.parent == tmp_path
    for key in ("HOME", "XDG_CACHE_HOME", "XDG_DATA_HOME"):
        path = Path(got[key])
        assert path.is_dir() and fresh in path.parents and not any(path.iterdir()), key
    assert fresh in Path(got["NUMBA_CACHE_DIR"]).parents
    assert f"-o cache_dir={fresh}/pytest-cache" in got["PYTEST_ADDOPTS"]
    assert got["SITCOV_MODEL_DIR"] == "unset"  # the model comes from the fixture, fetched


def test_ci_run_uses_it_and_checks_the_figures() -> None:
    text = (ROOT / ".ci/run").read_text()
    assert "source .ci/fresh-env" in text
    assert text.index("source .ci/fresh-env") < text.index('bash -c "$TEST_CMD"')
    assert "python benchmarks/figures.py check" in text
    assert 'source "$repo/.ci/fresh-env"' in (ROOT / ".ci/fresh-clone").read_text()


def test_no_test_sees_the_user_model() -> None:
    """The autouse fixture of tests/conftest.py: the default model directory is empty."""
    from sitcov.perception import model_dir

    assert model_dir() == Path(os.environ["SITCOV_MODEL_DIR"])
    assert not any(model_dir().iterdir())
