"""The campaign store interface: campaigns, planned runs and their outcomes.

A store holds, per campaign, its configuration, the hyperspace it ran on, the generator's
saved state and one row per run. The run loop writes it in two kinds of transaction
(see ``sitcov.campaign._runner``):

1. :meth:`Store.plan_batch` - the generator state after a batch of asks, together with the
   batch's runs as ``pending`` rows (situation and seed), in ONE transaction;
2. :meth:`Store.record_result` - one finished run's outcome, in a short transaction.

So the stored generator state always matches the stored plan, and a campaign killed at any
moment resumes by re-running its pending rows. Implementations: SQLite (files) and memory.
"""

from __future__ import annotations

import abc
import contextlib
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

from sitcov.campaign._records import RunRecord
from sitcov.errors import SitcovError
from sitcov.hyperspace import Situation
from sitcov.sim import Outcome

#: Statuses of stored runs: ``pending`` (planned, not yet finished) and the outcome statuses.
RUN_STATUSES = ("pending", "pass", "fail", "error", "timeout")


class StoreError(SitcovError):
    """The campaign store cannot be opened or does not hold what was asked for."""


class CampaignBusyError(StoreError):
    """Another live process is running the campaign (see :meth:`Store.lock_campaign`)."""


@dataclass(frozen=True)
class CampaignInfo:
    """A stored campaign (without its runs).

    Attributes:
        name: unique name within the store.
        config: the campaign configuration (``CampaignConfig`` as JSON data).
        hyperspace: the hyperspace it runs on (``Hyperspace.to_dict()``).
        sitcov_version: the sitcov version that created it.
        created: creation time, ISO 8601 UTC.
        generator: the generator's name.
        generator_state: the generator's saved state after the last planned batch.
        batch_start: index of the first run of the last planned batch (the runs the
            generator has not been told about yet).
        tags: free labels, e.g. ``{"experiment": "faults", "fault": "f1", "seed": 3}``.
        world_version: ``sitcov.sim.WORLD_MODEL_VERSION`` when the campaign was created;
            None for a campaign stored before versions were recorded (the legacy world
            model: no physics profiles, collision-only verdicts).
    """

    name: str
    config: Mapping[str, Any]
    hyperspace: Mapping[str, Any]
    sitcov_version: str
    created: str
    generator: str
    generator_state: Mapping[str, Any] | None = None
    batch_start: int = 0
    tags: Mapping[str, Any] = field(default_factory=dict)
    world_version: int | None = None

    @property
    def legacy(self) -> bool:
        """Made with the legacy world model (before world versions were stored)."""
        return self.world_version is None


@dataclass(frozen=True)
class PlannedRun:
    """A run to store as ``pending``: its index, situation and simulation seed."""

    index: int
    situation: Situation
    seed: int
    replay_of: str | None = None


class Store(abc.ABC):
    """Where campaigns and their runs live (the analogue of Optuna's storage).

    Reads return :class:`RunRecord` objects ordered by (campaign, index). ``iter_runs``
    streams them, so long campaigns are never held in memory at once.
    """

    #: Where the data lives (a file path, or ``":memory:"``); used in error messages.
    location: str = ":memory:"

    # -- campaigns ---------------------------------------------------------------------------
    @abc.abstractmethod
    def campaigns(self) -> list[CampaignInfo]:
        """All campaigns, ordered by creation (then name)."""

    @abc.abstractmethod
    def find_campaign(self, name: str) -> CampaignInfo | None:
        """The campaign called ``name``, or None."""

    def campaign(self, name: str) -> CampaignInfo:
        """The campaign called ``name``; a StoreError naming the known ones if absent."""
        info = self.find_campaign(name)
        if info is None:
            known = ", ".join(c.name for c in self.campaigns()) or "none"
            raise StoreError(f"{self.location}: no campaign {name!r} (campaigns: {known})")
        return info

    @abc.abstractmethod
    def create_campaign(self, info: CampaignInfo, runs: Sequence[PlannedRun] = ()) -> None:
        """Add a campaign and (same transaction) its first planned runs; error if it exists."""

    @abc.abstractmethod
    def update_config(self, name: str, config: Mapping[str, Any]) -> None:
        """Replace a campaign's stored config (e.g. when ``runs`` extends it)."""

    def check(self) -> None:  # noqa: B027
        """Read back everything stored, once per store object, before the first write of a
        campaign: a damaged store is refused (StoreError) while it is still unchanged.
        This default is for stores that cannot be damaged (in memory)."""

    def mark_checked(self) -> None:  # noqa: B027
        """Skip :meth:`check`: another connection of this command checked the same file
        (the parent of worker processes that open their own connections)."""

    def lock_campaign(self, name: str) -> contextlib.AbstractContextManager[Any]:
        """Mark ``name`` as run by this process until the returned context exits.

        A store shared between processes refuses (:class:`CampaignBusyError`, naming the
        other process) while another live process holds the campaign, and takes over the
        mark of one that died. This default is for stores only one process can see.
        """
        return contextlib.nullcontext()

    # -- runs --------------------------------------------------------------------------------
    @abc.abstractmethod
    def plan_batch(
        self,
        name: str,
        generator_state: Mapping[str, Any] | None,
        runs: Sequence[PlannedRun],
    ) -> None:
        """In ONE transaction: save the generator state and add ``runs`` as pending.

        ``batch_start`` becomes the first index of ``runs``.
        """

    @abc.abstractmethod
    def record_result(self, name: str, index: int, outcome: Outcome, wall_time: float) -> None:
        """Store a finished run's outcome (and its trace, if it has one)."""

    @abc.abstractmethod
    def iter_runs(
        self,
        campaign: str | None = None,
        status: str | Sequence[str] | None = None,
        *,
        start: int = 0,
    ) -> Iterator[RunRecord]:
        """Stream runs ordered by (campaign, index), optionally filtered.

        Args:
            campaign: only this campaign's runs.
            status: only runs with this status (or any of these statuses).
            start: only runs with index >= start.
        """

    @abc.abstractmethod
    def get_run(self, campaign: str, index: int, *, with_trace: bool = True) -> RunRecord:
        """One run (with its stored trace, if any); StoreError if absent."""

    @abc.abstractmethod
    def count_runs(
        self, campaign: str | None = None, status: str | Sequence[str] | None = None
    ) -> int:
        """How many runs match (same filters as :meth:`iter_runs`)."""

    def runs(
        self, campaign: str | None = None, status: str | Sequence[str] | None = None
    ) -> list[RunRecord]:
        """All matching runs as a list, ordered by (campaign, index)."""
        return list(self.iter_runs(campaign, status))

    def status_counts(self, campaign: str | None = None) -> dict[str, int]:
        """Run count per status (every status in :data:`RUN_STATUSES` present)."""
        return {s: self.count_runs(campaign, s) for s in RUN_STATUSES}

    def close(self) -> None:  # noqa: B027
        """Release the underlying connection."""

    def __enter__(self) -> Store:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _statuses(status: str | Sequence[str] | None) -> tuple[str, ...] | None:
    """Normalise a status filter to a tuple (None = no filter), checking the names."""
    if status is None:
        return None
    wanted = (status,) if isinstance(status, str) else tuple(status)
    bad = [s for s in wanted if s not in RUN_STATUSES]
    if bad:
        raise StoreError(f"unknown run status {bad[0]!r}; expected one of {RUN_STATUSES}")
    return wanted
