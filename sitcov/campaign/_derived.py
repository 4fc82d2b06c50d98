"""Campaigns planned from another campaign's stored situations.

The Table 2 protocol (fault replays of the NF campaign) and the flakiness experiment (the
same situations with other seeds) both create a campaign whose runs are fixed in advance
from a base campaign; the new campaign inherits the base's hyperspace and generator state,
so coverage and reports read it as the base's situations.
"""

from __future__ import annotations

import datetime as _dt
from collections.abc import Sequence
from typing import Any

from sitcov.campaign._store import CampaignInfo, PlannedRun


def create_derived_campaign(
    store: Any, base: CampaignInfo, config: Any, planned: Sequence[PlannedRun]
) -> None:
    """Create campaign ``config`` in ``store`` with ``planned`` runs taken from ``base``.

    Args:
        store: the open store.
        base: the stored campaign whose situations are planned again.
        config: the new campaign's ``CampaignConfig`` (name, generator, tags).
        planned: the runs to plan, each with its situation and simulation seed.
    """
    from sitcov._version import __version__
    from sitcov.sim import WORLD_MODEL_VERSION

    info = CampaignInfo(
        name=config.name,
        config=config.model_dump(mode="json"),
        hyperspace=base.hyperspace,
        sitcov_version=__version__,
        created=_dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        generator=config.generator,
        generator_state=base.generator_state,
        batch_start=base.batch_start,
        tags=dict(config.tags),
        world_version=WORLD_MODEL_VERSION,
    )
    store.create_campaign(info, list(planned))
