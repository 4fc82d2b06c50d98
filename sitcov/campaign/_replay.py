"""Replaying a stored run: same situation and seed, same or another fidelity.

With the stored backend and options the outcome must equal the stored one exactly (every
field but the wall time and the trace); anything else is a reproducibility bug and is
reported field by field. With another backend or perception the two outcomes are shown side
by side - the way to confirm a fast PEM failure with the camera detector or in CARLA.

A run that raised is replayed the same way (its ``error`` message must match); a ``timeout``
run is re-run without a wall-time limit, so it reproduces only if it now finishes the same.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from sitcov.campaign._build import build_backend, build_stack
from sitcov.campaign._config import CampaignConfig
from sitcov.campaign._executors import execute
from sitcov.campaign._open import open_store
from sitcov.campaign._records import RunRecord
from sitcov.campaign._runner import judge_of
from sitcov.campaign._store import Store, StoreError
from sitcov.errors import ConfigError
from sitcov.sim import Judge, Outcome

_DEFAULT_PERCEPTION = "pem"  # the embedded backend's default perception


def parse_run_id(store: Store, text: str) -> tuple[str, int]:
    """``CAMPAIGN:INDEX`` or ``INDEX`` (when the store holds one campaign) -> (name, index)."""
    name, sep, index = text.rpartition(":")
    if not index.strip().lstrip("-").isdigit():
        raise ConfigError(field="RUN", value=text, expected="CAMPAIGN:INDEX or INDEX")
    if not sep:
        names = [c.name for c in store.campaigns()]
        if len(names) != 1:
            raise ConfigError(
                f"{store.location}: RUN {text!r} is ambiguous; the store holds "
                f"{len(names)} campaigns ({', '.join(names) or 'none'}): write CAMPAIGN:INDEX"
            )
        name = names[0]
    return name, int(index)


def _comparable(outcome: Outcome) -> dict[str, Any]:
    data = {**outcome.to_dict(), "failure_kind": outcome.kind}  # stored before kinds: derived
    return json.loads(json.dumps(data, sort_keys=True))


def outcome_differences(stored: Outcome, new: Outcome) -> dict[str, tuple[Any, Any]]:
    """Field -> (stored, new) for every differing field (metrics compared key by key)."""
    a, b = _comparable(stored), _comparable(new)
    diffs: dict[str, tuple[Any, Any]] = {}
    for key in sorted(set(a) | set(b)):
        if key == "metrics":
            ma, mb = a.get(key) or {}, b.get(key) or {}
            for m in sorted(set(ma) | set(mb)):
                if ma.get(m) != mb.get(m):
                    diffs[f"metrics.{m}"] = (ma.get(m), mb.get(m))
        elif a.get(key) != b.get(key):
            diffs[key] = (a.get(key), b.get(key))
    return diffs


@dataclass(frozen=True)
class ReplayResult:
    """A replayed run.

    Attributes:
        run: the stored run.
        outcome: the outcome of the replay.
        same_setup: replayed with the stored backend and options (so must reproduce).
        backend: backend used for the replay; ``options`` its options.
        differences: field -> (stored, new) where the outcomes differ.
        render: path of the top-down picture, if one was written.
    """

    run: RunRecord
    outcome: Outcome
    same_setup: bool
    backend: str
    options: dict[str, Any]
    differences: dict[str, tuple[Any, Any]] = field(default_factory=dict)
    render: str | None = None

    @property
    def reproduced(self) -> bool:
        """Same setup and an identical outcome."""
        return self.same_setup and not self.differences


def replay_run(
    store: Store,
    campaign: str,
    index: int,
    *,
    backend: str | None = None,
    perception: str | None = None,
    render: str | Path | None = None,
) -> ReplayResult:
    """Re-run a stored run with its stored config (or another backend / perception).

    Raises:
        StoreError: no such run, or it has not finished yet.
    """
    run = store.get_run(campaign, index, with_trace=False)
    if run.outcome is None:
        raise StoreError(f"{store.location}: run {campaign}:{index} has not run yet (pending)")
    try:
        config = CampaignConfig(**{k: v for k, v in run.config.items() if k != "workers"})
    except ValidationError as exc:
        first = exc.errors()[0]
        raise StoreError(
            f"{store.location}: campaign {campaign!r}: the stored config is not valid "
            f"({'.'.join(map(str, first['loc']))}: {first['msg']}; damaged database?)"
        ) from None
    options = dict(config.backend_options)
    if perception is not None:
        options["perception"] = perception
    name = backend or config.backend

    def effective(opts: dict[str, Any]) -> dict[str, Any]:
        return {"perception": _DEFAULT_PERCEPTION, **opts}

    same = name == config.backend and effective(options) == effective(dict(config.backend_options))
    sim = build_backend(config, backend=name, options=options)
    stack = build_stack(config)
    try:
        task = (index, run.situation.to_dict(), run.seed)
        _, raw, _ = execute(sim, stack, task, render is not None)
    finally:
        stack.close()
        sim.close()
    # judged as the campaign stored it (see _runner.run_campaign); legacy: collision only
    outcome = (judge_of(config) if "judge" in run.config else Judge.from_spec("paper"))(raw)
    written = None
    if render is not None:
        from sitcov.sim.embedded import render_topdown

        render_topdown(outcome, Path(render))
        written = str(render)
    diffs = outcome_differences(run.outcome, outcome)
    return ReplayResult(run, outcome, same, name, options, diffs, written)


def failing_situations(db: str | Path, campaign: str | None = None) -> list[Any]:
    """The situations of the failing runs stored in a campaign database.

    Raises:
        ConfigError: the database file does not exist.
    """
    if not Path(db).exists():
        raise ConfigError(field="--db", value=str(db), expected="an existing campaign database")
    store = open_store(db)
    try:
        if campaign is not None:
            store.campaign(campaign)  # a clear error naming the known campaigns
        return [run.situation for run in store.runs(campaign=campaign, status="fail")]
    finally:
        store.close()
