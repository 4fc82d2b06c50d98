"""The generator race on the fake backend: campaigns, seeds, resuming, the table."""

from __future__ import annotations

import pytest
from campaign_fakes import BACKEND, STACK
from needs import need_module

from sitcov.campaign import open_store
from sitcov.campaign._race import race_configs, race_lines, race_result, run_race
from sitcov.errors import ConfigError
from sitcov.report._race_figure import race_figure

SETTINGS = {"backend": BACKEND, "av": STACK, "executor": "serial", "workers": 1}


def configs(generators=("random", "surrogate", "nsga2"), runs=40):
    return race_configs(generators, runs=runs, seeds=2, seed=7, reference_runs=600,
                        batch_size=10, settings=SETTINGS)  # fmt: skip


def test_race_runs_every_generator_on_the_same_seeds(tmp_path):
    need_module("pymoo", "search")
    store = open_store(tmp_path / "r.db")
    result = run_race(store, configs())
    table = result["table"]
    assert list(table) == ["random", "surrogate", "nsga2"]
    assert all(row["seeds"] == 2 for row in table.values())
    # FakeBackend fails at friction <= 0.2 (60 %): the regions are low-friction boxes
    assert result["regions"]
    for region in result["regions"]:
        conds = {c["element"]: c["bins"] for c in region["conditions"]}
        assert set(conds.get("friction", [])) <= {"0.1", "0.2"} and conds.get("friction")
    seeds = {
        name: [r.seed for r in store.iter_runs(name)]
        for name in ("race/random/s1", "race/surrogate/s1", "race/nsga2/s1")
    }
    assert seeds["race/random/s1"] == seeds["race/surrogate/s1"] == seeds["race/nsga2/s1"]
    assert table["surrogate"]["regions"]["vs_random"]["n"] == 2
    assert any(line.startswith("| surrogate | 2 |") for line in race_lines(result))
    # running again plans nothing new and scores the same
    assert run_race(store, configs()) == result == race_result(store)
    png = race_figure(result, tmp_path / "race.png")
    assert png.startswith(b"\x89PNG") and (tmp_path / "race.png").exists()


def test_bad_race_input_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="--generators"):
        configs(generators=())
    with pytest.raises(ConfigError, match="no campaign 'race/reference'"):
        race_result(open_store(tmp_path / "empty.db"))
    store = open_store(tmp_path / "x.db")
    with pytest.raises(ConfigError, match="no-such-generator"):
        run_race(store, configs(generators=("random", "no-such-generator")))
    assert store.campaigns() == []  # checked before anything ran
