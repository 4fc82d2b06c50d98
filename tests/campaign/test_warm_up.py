"""Before a campaign, the CLI compiles (first use) or loads numba's kernels in its own
process and says so, instead of a bar sitting at 0/1000 for 10-20 s (issue 26)."""

from __future__ import annotations

from campaign_helpers import fake_config

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.campaign._build import warm_up


def test_warm_up_runs_one_embedded_situation_and_changes_nothing(tmp_path, monkeypatch) -> None:
    config = CampaignConfig(runs=6, executor="serial", seed=3)
    with open_store(tmp_path / "a.db") as store:
        run_campaign(config, store)
        before = [(r.seed, r.status, r.outcome.min_distance) for r in store.runs("default")]
    assert warm_up(config) > 0.0
    with open_store(tmp_path / "b.db") as store:
        run_campaign(config, store)
        after = [(r.seed, r.status, r.outcome.min_distance) for r in store.runs("default")]
    assert after == before  # nothing stored, no state kept: the same campaign
    # nothing to compile: another backend, camera mode, or numba switched off
    assert warm_up(fake_config()) == 0.0
    camera = config.model_copy(update={"backend_options": {"perception": "camera"}})
    assert warm_up(camera) == 0.0
    monkeypatch.setenv("SITCOV_NO_JIT", "1")
    assert warm_up(config) == 0.0
