"""A stored run: what the store returns and what analysis and reports consume."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from sitcov.hyperspace import Situation
from sitcov.sim import Outcome


@dataclass(frozen=True)
class RunRecord:
    """One run of a campaign, as stored.

    Attributes:
        campaign: name of the campaign the run belongs to.
        index: 0-based run index within the campaign (the order of generation).
        situation: the situation that was run.
        seed: the run's simulation seed (derived from campaign seed and index).
        status: ``pending`` (planned, not yet run) or one of ``sitcov.sim.STATUSES``.
        outcome: the outcome, None while pending.
        wall_time: wall-clock seconds the run took, None while pending.
        config: the campaign-level settings the run was made with (generator, backend, av,
            fault, ...), for provenance.
        replay_of: ``CAMPAIGN:INDEX`` of the stored failure this run replays (runs made by
            ``sitcov run --replay-failures-first``), None for generated runs.
    """

    campaign: str
    index: int
    situation: Situation
    seed: int
    status: str
    outcome: Outcome | None = None
    wall_time: float | None = None
    config: Mapping[str, Any] = field(default_factory=dict)
    replay_of: str | None = None

    @property
    def bins(self) -> Mapping[str, str]:
        """Element -> bin label of the run's situation (what analysis groups by)."""
        return self.situation.bins

    @property
    def failure_kind(self) -> str | None:
        """``pass``, a kind of ``sitcov.sim.FAILURE_KINDS``, ``error`` or ``timeout``
        (``Outcome.kind``); None while pending."""
        return self.outcome.kind if self.outcome is not None else None

    @property
    def failed(self) -> bool:
        """True when the stack under test failed in this run."""
        return self.status == "fail"
