"""The gymnasium environment's old home in ``sitcov.av``: still works, warns, names the new one."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from needs import need_module

gym = need_module("gymnasium", "gym")

import sitcov.gym  # noqa: E402
from sitcov import av  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("name", ["ENV_ID", "PolicyStack", "TJunctionEnv"])
def test_old_names_resolve_to_the_new_objects_with_a_warning(name: str) -> None:
    moved = rf"sitcov\.av\.{name} moved to sitcov\.gym\.{name}"
    with pytest.warns(DeprecationWarning, match=moved):
        old = getattr(av, name)
    assert old is getattr(sitcov.gym, name)


def test_the_warning_points_at_the_importing_line() -> None:
    with pytest.warns(DeprecationWarning) as caught:
        from sitcov.av import TJunctionEnv  # noqa: F401
    assert {Path(w.filename).name for w in caught} == {Path(__file__).name}


def test_other_names_are_still_missing_without_a_warning(recwarn) -> None:
    with pytest.raises(AttributeError, match="no attribute 'TJunctionEnv2'"):
        av.TJunctionEnv2  # noqa: B018
    with pytest.raises(AttributeError, match="no attribute 'observation_space'"):
        av.observation_space  # noqa: B018 - moved with the environment, but never public here
    assert not [w for w in recwarn if issubclass(w.category, DeprecationWarning)]


def test_the_id_is_registered_at_the_new_entry_point() -> None:
    assert gym.registry[sitcov.gym.ENV_ID].entry_point == "sitcov.gym:TJunctionEnv"


def test_the_old_entry_point_still_makes_the_environment() -> None:
    """A spec saved with the entry point of older versions (``sitcov.av._gym``) still loads."""
    env_id = "sitcov-test/OldEntryPoint-v0"
    gym.register(id=env_id, entry_point="sitcov.av._gym:TJunctionEnv")
    try:
        with pytest.warns(DeprecationWarning, match=r"sitcov\.av\._gym\.TJunctionEnv moved"):
            env = gym.make(env_id, backend_options={"sim_timeout": 1.0})
        try:
            assert isinstance(env.unwrapped, sitcov.gym.TJunctionEnv)
            obs, _ = env.reset(seed=0)
            assert env.observation_space.contains(obs)
        finally:
            env.close()
    finally:
        del gym.registry[env_id]


def test_importing_the_stacks_imports_no_gym() -> None:
    """``sitcov.av`` (and ``sitcov``) stay importable without the optional extra; asking
    the old homes for a name that never moved imports nothing either."""
    code = (
        "import sys, sitcov.av, sitcov.av._gym as old\n"
        "assert not hasattr(sitcov.av, 'observation_space') and not hasattr(old, 'Foo')\n"
        "print(sorted(m for m in sys.modules if 'gym' in m and m != 'sitcov.av._gym'))"
    )
    out = subprocess.run(
        [sys.executable, "-c", code],
        cwd=ROOT,
        env={**os.environ, "PYTHONPATH": str(ROOT)},
        capture_output=True,
        text=True,
        check=True,
    )
    assert out.stdout.strip() == "[]"
