"""The gymnasium environment ``sitcov/TJunction-v0`` and ``PolicyStack``."""

from __future__ import annotations

import threading
from pathlib import Path

import numpy as np
import pytest
from needs import need_module

gym = need_module("gymnasium", "gym")

from sitcov.errors import ConfigError  # noqa: E402
from sitcov.gym import ENV_ID, PolicyStack, TJunctionEnv  # noqa: E402
from sitcov.hyperspace import load_hyperspace  # noqa: E402
from sitcov.sim import make_backend  # noqa: E402

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture
def policy_module(monkeypatch: pytest.MonkeyPatch):
    monkeypatch.syspath_prepend(str(ROOT))
    from examples import gym_policy

    return gym_policy


def episode(env, policy, **reset) -> tuple[list, dict, float, bool, bool]:
    obs, info = env.reset(**reset)
    if hasattr(policy, "reset"):
        policy.reset()
    ego, total = [obs["ego"].copy()], 0.0
    while True:
        obs, reward, terminated, truncated, last = env.step(policy(obs))
        ego.append(obs["ego"].copy())
        total += reward
        if terminated or truncated:
            return ego, {**info, **last}, total, terminated, truncated


def test_registered_and_passes_the_gymnasium_checker() -> None:
    from gymnasium.utils.env_checker import check_env

    assert ENV_ID == "sitcov/TJunction-v0" and ENV_ID in gym.registry
    env = gym.make(ENV_ID, backend_options={"sim_timeout": 2.0})
    try:
        check_env(env.unwrapped, skip_render_check=True)
        obs, _ = env.reset(seed=3)
        assert env.observation_space.contains(obs)
        assert env.action_space.shape == (3,)
    finally:
        env.close()


def test_episode_equals_the_campaign_run_of_the_same_situation(policy_module) -> None:
    """The env is the backend's own closed loop: same situation + seed, same outcome."""
    hs = load_hyperspace()
    rng = np.random.default_rng(5)
    bins = {e: hs.labels(e)[0] for e in hs.element_names} | {"intsit": "IntSit-2"}
    situation = hs.situation_from_bins(bins, rng)
    env = TJunctionEnv()
    try:
        policy = policy_module.Policy()
        ego, info, total, terminated, _ = episode(
            env, policy, seed=1, options={"situation": situation, "run_seed": 77}
        )
    finally:
        env.close()
    direct = make_backend("embedded").run(situation, PolicyStack(policy_module.Policy()), 77)
    assert info["situation"]["id"] == situation.id
    assert info["outcome"] == direct.to_dict()
    assert terminated is (direct.end_reason in ("collision", "goal"))
    assert len(ego) == direct.metrics["steps"] + 1  # reset's observation + one per step
    # reward = metres of progress along the route - 100 if the run ends in a collision;
    # progress computed independently: arc length of the last observed position's projection
    route = np.array(info["route"], dtype=float)
    seg = route[1:] - route[:-1]
    rel = ego[-1][:2].astype(float) - route[:-1]
    u = np.clip((rel * seg).sum(1) / (seg * seg).sum(1), 0.0, 1.0)
    dist = np.linalg.norm(rel - u[:, None] * seg, axis=1)
    i = int(np.argmin(dist))
    arc = np.linalg.norm(seg, axis=1)
    expected = arc[:i].sum() + u[i] * arc[i] - (100.0 if direct.collision else 0.0)
    assert total == pytest.approx(expected, abs=0.05)


def test_reset_options_seeds_and_determinism() -> None:
    env = TJunctionEnv(backend_options={"sim_timeout": 1.0})
    coast = lambda obs: np.array([0.3, 0.0, 0.0], dtype=np.float32)  # noqa: E731
    try:
        a = episode(env, coast, seed=11, options={"situation": {"intsit": "IntSit-7"}})
        b = episode(env, coast, seed=11, options={"situation": {"intsit": "IntSit-7"}})
        c = episode(env, coast, seed=12, options={"situation": {"intsit": "IntSit-7"}})
        assert a[1]["situation"]["bins"]["intsit"] == "IntSit-7"
        assert a[1]["situation"] == b[1]["situation"] and np.array_equal(a[0], b[0])
        assert a[1]["run_seed"] == b[1]["run_seed"] != c[1]["run_seed"]
        assert a[1]["end_reason"] == "sim_timeout" and (a[3], a[4]) == (False, True)
        full = env.reset(options={"situation": a[1]["situation"]})[1]["situation"]
        assert full == a[1]["situation"]  # a to_dict() form is taken as is
        with pytest.raises(ConfigError, match="options.situation"):
            env.reset(options={"situation": 42})
        env.reset(seed=1)
        with pytest.raises(ConfigError, match="throttle, brake, steer"):
            env.step([0.1, 0.2])
    finally:
        env.close()


def test_reset_mid_episode_and_close_end_the_worker_thread() -> None:
    before = threading.active_count()
    env = TJunctionEnv()
    env.reset(seed=0)
    for _ in range(5):
        env.step([0.5, 0.0, 0.0])
    assert threading.active_count() == before + 1
    env.reset(seed=1)  # abandons the first episode
    env.step([0.5, 0.0, 0.0])
    assert threading.active_count() == before + 1
    env.close()
    assert threading.active_count() == before


def test_max_time_truncates() -> None:
    env = TJunctionEnv(max_time=0.5)
    try:
        ego, info, _, terminated, truncated = episode(env, lambda obs: [1.0, 0.0, 0.0], seed=0)
        assert (terminated, truncated, info["end_reason"]) == (False, True, "max_time")
        assert ego[-1][4] == pytest.approx(0.5)
    finally:
        env.close()


def test_policy_stack_campaign_is_stored(policy_module, tmp_path: Path) -> None:
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    config = CampaignConfig(
        name="policy",
        av="examples.gym_policy:GymPolicyStack",
        runs=6,
        seed=2,
        executor="serial",
        backend_options={"sim_timeout": 20.0},
    )
    with open_store(tmp_path / "policy.db") as store:
        result = run_campaign(config, store)
        runs = store.runs("policy")
    assert result.counts["pending"] == 0 and len(runs) == 6
    assert {r.status for r in runs} <= {"pass", "fail"}
    assert all(r.outcome.metrics["steps"] > 10 for r in runs)


def test_gym_policy_example_runs_episodes(policy_module, capsys) -> None:
    policy_module.main(intsits=2)
    lines = capsys.readouterr().out.splitlines()
    assert [line.split()[0] for line in lines] == ["IntSit-1", "IntSit-2"]
    assert all(line.split()[1] in ("goal", "collision", "sim_timeout", "stopped") for line in lines)


def test_the_gym_snippet_in_the_docs_runs() -> None:
    import re

    page = (ROOT / "docs" / "your-own-stack.md").read_text()
    (snippet,) = re.findall(r"```python\n(.*?)```", page, flags=re.S)
    namespace: dict = {}
    exec(compile(snippet, "your-own-stack.md", "exec"), namespace)  # noqa: S102
    try:
        assert namespace["info"] == {} or "end_reason" in namespace["info"]
        assert namespace["env"].observation_space.contains(namespace["obs"])
    finally:
        namespace["env"].close()
