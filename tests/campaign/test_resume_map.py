"""Resume of derived-hyperspace campaigns compares the maps configs name by the file they
resolve to: a built-in name and a path to the same shipped file are one map, a campaign
stored without a map option ran on the default t-junction, and other maps are refused in
one line."""

from __future__ import annotations

from pathlib import Path

import pytest

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.campaign._build import map_file, stored_map_as_given, with_hyperspace_map
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.sim.embedded._map import MAPS_DIR

DERIVED = Path(__file__).resolve().parents[2] / "sitcov/hyperspace/data/derived"
T_JUNCTION = str(DERIVED / "t-junction.yaml")
CROSSROADS = str(DERIVED / "crossroads.yaml")
#: The shipped crossroads map file, by a relative path with a detour (not its name).
CROSSROADS_FILE = str(MAPS_DIR / ".." / "maps" / "crossroads.yaml")


def config(hyperspace: str, runs: int = 2, **options: str) -> CampaignConfig:
    return CampaignConfig(
        name="c",
        hyperspace=hyperspace,
        runs=runs,
        batch_size=2,
        seed=4,
        executor="serial",
        workers=1,
        backend_options=dict(options),
    )


def stored(db: Path, cfg: CampaignConfig, options: dict[str, str]) -> None:
    """Run ``cfg``, then store its config with ``options`` as backend_options (what a
    campaign made before the map came from the hyperspace metadata, or by hand, holds)."""
    with open_store(db) as store:
        run_campaign(cfg, store)
        info = store.campaign(cfg.name)
        store.update_config(cfg.name, {**info.config, "backend_options": options})


def test_map_file_resolves_names_and_paths_to_the_same_file() -> None:
    assert map_file("crossroads") == map_file(CROSSROADS_FILE)
    assert map_file("crossroads") != map_file("roundabout")
    assert map_file("t-junction") == str((MAPS_DIR / "t-junction.yaml").resolve())


def test_a_path_to_the_hyperspace_map_is_not_a_contradiction() -> None:
    hs = load_hyperspace(CROSSROADS)
    cfg = config(CROSSROADS, map=CROSSROADS_FILE)
    assert with_hyperspace_map(cfg, hs) == cfg  # kept as the user wrote it
    with pytest.raises(ConfigError, match="contradicts"):
        with_hyperspace_map(config(CROSSROADS, map=str(MAPS_DIR / "merge.yaml")), hs)


def test_stored_map_as_given_respells_only_the_same_map() -> None:
    new = config(CROSSROADS, map="crossroads")
    old = {**new.model_dump(mode="json"), "backend_options": {"map": CROSSROADS_FILE}}
    assert stored_map_as_given(old, new, "db")["backend_options"] == {"map": "crossroads"}
    plain = {**old, "backend_options": {}}  # stored without a map: ran on the t-junction
    with pytest.raises(ConfigError) as err:
        stored_map_as_given(plain, new, "db: campaign 'c'")
    text = str(err.value)
    assert "\n" not in text and "'t-junction' (no map option: the default)" in text
    assert "'crossroads'" in text and "another --name" in text


def test_a_campaign_stored_without_a_map_option_resumes(tmp_path: Path) -> None:
    """Stored before the map came from the metadata: no map option; it ran on the default
    t-junction, which the derived t-junction hyperspace names: resume without any option."""
    db = tmp_path / "a.db"
    stored(db, config(T_JUNCTION), {})
    with open_store(db) as store:
        result = run_campaign(config(T_JUNCTION, runs=4), store)
        assert result.resumed and store.count_runs("c") == 4


def test_a_campaign_stored_with_a_map_path_resumes_by_name_or_path(tmp_path: Path) -> None:
    db = tmp_path / "b.db"
    stored(db, config(CROSSROADS), {"map": CROSSROADS_FILE})
    with open_store(db) as store:
        assert run_campaign(config(CROSSROADS, runs=4), store).resumed  # from the metadata
        by_path = config(CROSSROADS, runs=6, map=str(Path(CROSSROADS_FILE).resolve()))
        assert run_campaign(by_path, store).resumed
        assert store.count_runs("c") == 6
        assert {r.status for r in store.iter_runs("c")} <= {"pass", "fail"}


def test_resume_on_another_map_is_one_line_naming_both(tmp_path: Path) -> None:
    db = tmp_path / "c.db"
    stored(db, config(CROSSROADS), {})  # stored without a map: ran on the t-junction
    with open_store(db) as store, pytest.raises(ConfigError) as err:
        run_campaign(config(CROSSROADS, runs=4), store)
    text = str(err.value)
    assert "\n" not in text and str(db) in text and "campaign 'c'" in text
    assert "'t-junction'" in text and "'crossroads'" in text
