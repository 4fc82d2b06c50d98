"""An in-memory campaign store (for tests, notebooks and throw-away campaigns).

It keeps the same JSON round trip as the SQLite store, so what a campaign reads back (and
tells its generator) is identical whichever store holds it.
"""

from __future__ import annotations

import copy
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from sitcov.campaign import _json
from sitcov.campaign._records import RunRecord
from sitcov.campaign._store import CampaignInfo, PlannedRun, Store, StoreError, _statuses
from sitcov.hyperspace import Situation
from sitcov.sim import Outcome


def _roundtrip(obj: Any) -> Any:
    return _json.loads(_json.dumps(obj))


class MemoryStore(Store):
    """A store that lives in this process only."""

    location = ":memory:"

    def __init__(self) -> None:
        self._campaigns: dict[str, CampaignInfo] = {}
        self._runs: dict[str, dict[int, dict[str, Any]]] = {}

    def campaigns(self) -> list[CampaignInfo]:
        return sorted(self._campaigns.values(), key=lambda c: (c.created, c.name))

    def find_campaign(self, name: str) -> CampaignInfo | None:
        info = self._campaigns.get(name)
        return copy.deepcopy(info) if info is not None else None

    def create_campaign(self, info: CampaignInfo, runs: Sequence[PlannedRun] = ()) -> None:
        if info.name in self._campaigns:
            raise StoreError(f"{self.location}: campaign {info.name!r} already exists")
        self._campaigns[info.name] = CampaignInfo(
            name=info.name,
            config=_roundtrip(dict(info.config)),
            hyperspace=_roundtrip(dict(info.hyperspace)),
            sitcov_version=info.sitcov_version,
            created=info.created,
            generator=info.generator,
            generator_state=_roundtrip(info.generator_state),
            batch_start=runs[0].index if runs else info.batch_start,
            tags=_roundtrip(dict(info.tags)),
            world_version=info.world_version,
        )
        self._runs[info.name] = {}
        self._insert(info.name, runs)

    def update_config(self, name: str, config: Mapping[str, Any]) -> None:
        info = self.campaign(name)
        self._campaigns[name] = _replace(info, config=_roundtrip(dict(config)))

    def _insert(self, name: str, runs: Sequence[PlannedRun]) -> None:
        table = self._runs[name]
        for r in runs:
            if r.index in table:
                raise StoreError(f"{self.location}: run {name}:{r.index} already exists")
        for r in runs:
            table[r.index] = {
                "situation": _roundtrip(r.situation.to_dict()),
                "seed": int(r.seed),
                "status": "pending",
                "outcome": None,
                "wall_time": None,
                "trace": None,
                "replay_of": r.replay_of,
            }

    def plan_batch(
        self,
        name: str,
        generator_state: Mapping[str, Any] | None,
        runs: Sequence[PlannedRun],
    ) -> None:
        info = self.campaign(name)
        self._insert(name, runs)
        self._campaigns[name] = _replace(
            info,
            generator_state=_roundtrip(generator_state),
            batch_start=runs[0].index if runs else info.batch_start,
        )

    def record_result(self, name: str, index: int, outcome: Outcome, wall_time: float) -> None:
        row = self._runs.get(name, {}).get(int(index))
        if row is None:
            raise StoreError(f"{self.location}: no run {name}:{index}")
        row["status"] = outcome.status
        row["outcome"] = _roundtrip(outcome.to_dict())
        row["wall_time"] = float(wall_time)
        trace = outcome.trace
        row["trace"] = (
            _roundtrip({"ego": trace.ego, "ov": trace.ov, "meta": trace.meta}) if trace else None
        )

    def _record(self, name: str, index: int, row: dict[str, Any], trace: bool) -> RunRecord:
        outcome = None
        if row["outcome"] is not None:
            data = copy.deepcopy(row["outcome"])
            if trace and row["trace"] is not None:
                data["trace"] = copy.deepcopy(row["trace"])
            outcome = Outcome.from_dict(data)
        return RunRecord(
            campaign=name,
            index=index,
            situation=Situation.from_dict(row["situation"]),
            seed=row["seed"],
            status=row["status"],
            outcome=outcome,
            wall_time=row["wall_time"],
            config=self._campaigns[name].config,
            replay_of=row["replay_of"],
        )

    def _select(
        self, campaign: str | None, status: str | Sequence[str] | None, start: int = 0
    ) -> Iterator[tuple[str, int, dict[str, Any]]]:
        wanted = _statuses(status)
        names = sorted(self._runs) if campaign is None else [campaign]
        for name in names:
            table = self._runs.get(name, {})
            for index in sorted(table):
                row = table[index]
                if index >= start and (wanted is None or row["status"] in wanted):
                    yield name, index, row

    def iter_runs(
        self,
        campaign: str | None = None,
        status: str | Sequence[str] | None = None,
        *,
        start: int = 0,
    ) -> Iterator[RunRecord]:
        for name, index, row in list(self._select(campaign, status, start)):
            yield self._record(name, index, row, trace=False)

    def get_run(self, campaign: str, index: int, *, with_trace: bool = True) -> RunRecord:
        self.campaign(campaign)
        row = self._runs[campaign].get(int(index))
        if row is None:
            raise StoreError(f"{self.location}: campaign {campaign!r} has no run {index}")
        return self._record(campaign, int(index), row, trace=with_trace)

    def count_runs(
        self, campaign: str | None = None, status: str | Sequence[str] | None = None
    ) -> int:
        return sum(1 for _ in self._select(campaign, status))


def _replace(info: CampaignInfo, **changes: Any) -> CampaignInfo:
    from dataclasses import replace

    return replace(info, **changes)
