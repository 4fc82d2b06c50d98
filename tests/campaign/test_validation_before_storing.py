"""A campaign whose parts cannot be built fails before it writes anything to the store."""

from __future__ import annotations

import pytest

from sitcov.campaign import CampaignConfig, open_store, run_campaign
from sitcov.errors import ConfigError


@pytest.mark.parametrize(
    ("fields", "message"),
    [
        ({"fault": "f9"}, "unknown fault 'f9'"),
        ({"av": "nosuch.module:Cls"}, "cannot import module 'nosuch.module'"),
        ({"av": "cmd:/nonexistent/stack"}, "av_cmd: expected an executable program"),
        ({"av": "cmd:no_such_program_on_path_xyz --flag"}, "no_such_program_on_path_xyz"),
        ({"generator": "nope"}, "unknown generator 'nope'"),
    ],
)
def test_bad_part_raises_and_leaves_no_campaign(tmp_path, fields, message):
    store = open_store(tmp_path / "c.db")
    config = CampaignConfig(runs=3, executor="serial", **fields)
    with pytest.raises(ConfigError, match=message):
        run_campaign(config, store)
    assert store.campaigns() == []
    # the same database then accepts a corrected campaign under the same name
    run_campaign(CampaignConfig(runs=2, executor="serial"), store)
    assert store.count_runs("default") == 2
    store.close()
