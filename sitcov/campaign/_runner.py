"""The run loop: ask in batches, store the plan, execute, store results, tell, repeat.

For each batch of ``B = config.batch_size`` runs (independent of the worker count):

1. tell the generator the outcomes of the previous batch (read back from the store, in
   index order);
2. ask ``B`` situations, run ``i`` with ``ask_rng(seed, i)``;
3. in ONE transaction store the generator state and the ``B`` runs as ``pending`` with their
   situation and ``run_seed(seed, i)``;
4. execute them (in any order, on any executor) and store each result as it arrives,
   judged by the campaign's judge (``config.judge``): every executor's results pass
   through :func:`judge_of` here, after ``Backend.run``, so the simulation never depends
   on what counts as a failure.

A campaign killed at any moment therefore resumes exactly: the stored generator state is
the one that produced the stored plan; pending runs are re-run with their stored situation
and seed; the previous batch's outcomes are told again from the store. Nothing per run is
kept in memory beyond the current batch.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

from sitcov._seeding import ask_rng, run_seed
from sitcov.campaign._build import (
    build_backend,
    build_stack,
    check_backend_hyperspace,
    make_generator,
    resolve_hyperspace,
    restore_generator,
    stored_map_as_given,
    with_hyperspace_map,
)
from sitcov.campaign._config import CampaignConfig, config_differences
from sitcov.campaign._executors import Executor, make_executor
from sitcov.campaign._store import CampaignInfo, PlannedRun, Store
from sitcov.errors import ConfigError, SitcovError
from sitcov.sim import WORLD_MODEL_VERSION, Judge


@dataclass(frozen=True)
class CampaignProgress:
    """What a progress callback receives.

    Attributes:
        event: ``start`` (before the first run of this call), ``run`` (a run finished) or
            ``end``.
        campaign: the campaign's name.
        done: finished runs in the campaign (all calls together).
        total: runs the campaign will have.
        failures: ``fail`` runs so far; ``errors``: ``error`` + ``timeout`` runs so far.
        executed: runs executed by this call so far.
        no_effect: hyperspace elements the backend ignores (reported at ``start``).
        resumed: True if the campaign existed before this call.
    """

    event: str
    campaign: str
    done: int
    total: int
    failures: int
    errors: int
    executed: int
    no_effect: tuple[str, ...] = ()
    resumed: bool = False


@dataclass(frozen=True)
class CampaignResult:
    """The state of a campaign after :func:`run_campaign`.

    Attributes:
        name: campaign name.
        counts: runs per status over the whole campaign (``pending`` included).
        executed: runs executed by this call.
        wall_time: seconds this call took.
        no_effect: hyperspace elements the backend ignores.
        resumed: the campaign existed before this call.
        replayed: runs that replay stored failures of other campaigns.
    """

    name: str
    counts: dict[str, int]
    executed: int
    wall_time: float
    no_effect: tuple[str, ...] = ()
    resumed: bool = False
    replayed: int = 0

    @property
    def runs(self) -> int:
        """Finished runs in the campaign."""
        return sum(v for k, v in self.counts.items() if k != "pending")

    @property
    def failures(self) -> int:
        """Runs with status ``fail``."""
        return self.counts.get("fail", 0)

    @property
    def errors(self) -> int:
        """Runs with status ``error`` or ``timeout``."""
        return self.counts.get("error", 0) + self.counts.get("timeout", 0)


def _version() -> str:
    from sitcov._version import __version__

    return __version__


def _failures_to_replay(store: Store, name: str, hyperspace: dict, limit: int) -> list[PlannedRun]:
    """Failing runs of the store's other campaigns on the same hyperspace, de-duplicated."""
    same = {c.name for c in store.campaigns() if c.name != name and c.hyperspace == hyperspace}
    seen: set[tuple[str, int]] = set()
    planned: list[PlannedRun] = []
    for run in store.iter_runs(status="fail"):
        if run.campaign not in same or (run.situation.id, run.seed) in seen:
            continue
        seen.add((run.situation.id, run.seed))
        planned.append(
            PlannedRun(len(planned), run.situation, run.seed, f"{run.campaign}:{run.index}")
        )
        if len(planned) >= limit:
            break
    return planned


def judge_of(config: CampaignConfig) -> Judge:
    """The judge a campaign's runs are stored with (``config.judge``)."""
    return Judge.from_spec(config.judge)


def _refuse_other_world(store: Store, info: CampaignInfo) -> None:
    """A campaign made with another world model cannot be extended: its verdicts would mix."""
    if info.world_version == WORLD_MODEL_VERSION:
        return
    made = "the legacy world model" if info.legacy else f"world model {info.world_version}"
    raise ConfigError(
        f"{store.location}: campaign {info.name!r} was made with {made} and cannot be "
        f"extended or resumed with world model {WORLD_MODEL_VERSION} (summary, report and "
        "export still work); start a new campaign with another --name",
        field="name",
        value=info.name,
    )


def no_effect_elements(hyperspace: Any, backend: Any) -> tuple[str, ...]:
    """Elements of ``hyperspace`` that ``backend.effects()`` does not list."""
    effects = backend.effects()
    return tuple(e for e in hyperspace.element_names if e not in effects)


#: Tag holding the score threshold fault F1 resolved to when the campaign was created.
F1_THRESHOLD_TAG = "f1_threshold"


def fault_tags(config: CampaignConfig) -> dict[str, Any]:
    """Tags that pin what a fault resolved to: F1's threshold is computed from the PEM, so a
    recalibration moves it; the value the campaign's runs used is stored with it."""
    if config.fault != "f1":
        return {}
    stack = build_stack(config)
    try:
        threshold = getattr(stack, "params", {}).get("threshold")
    finally:
        stack.close()
    return {} if threshold is None else {F1_THRESHOLD_TAG: round(float(threshold), 6)}


def check_fault_tags(name: str, stored: dict[str, Any], config: CampaignConfig) -> None:
    """Refuse to resume an F1 campaign whose threshold now resolves to another value.

    Raises:
        ConfigError: one line with both thresholds.
    """
    if F1_THRESHOLD_TAG not in stored:
        return  # stored before thresholds were pinned, or not F1
    now = fault_tags(config).get(F1_THRESHOLD_TAG)
    if now is not None and now != stored[F1_THRESHOLD_TAG]:
        raise ConfigError(
            f"campaign {name!r} ran fault f1 with threshold {stored[F1_THRESHOLD_TAG]} (resolved "
            f"from the PEM then); it now resolves to {now} (recalibrated PEM), and one campaign "
            "must not mix two thresholds: use another --name",
            field="fault",
            value="f1",
        )


def _open_campaign(config: CampaignConfig, store: Store, hyperspace: Any) -> tuple[Any, bool, int]:
    """Create the campaign or check it against ``config``; return (generator, resumed, replays)."""
    hs_data = json.loads(json.dumps(hyperspace.to_dict()))  # as the store returns it
    info = store.find_campaign(config.name)
    if info is None:
        generator = make_generator(config, hyperspace)
        replays = (
            _failures_to_replay(store, config.name, hs_data, config.runs)
            if config.replay_failures_first
            else []
        )
        store.create_campaign(
            CampaignInfo(
                name=config.name,
                config=config.model_dump(mode="json"),
                hyperspace=hs_data,
                sitcov_version=_version(),
                created=datetime.now(timezone.utc).isoformat(timespec="seconds"),
                generator=config.generator,
                generator_state=generator.state(),
                tags={**config.tags, **fault_tags(config)},
                world_version=WORLD_MODEL_VERSION,
            ),
            replays,
        )
        return generator, False, len(replays)
    _refuse_other_world(store, info)
    where = f"{store.location}: campaign {config.name!r}"
    diffs = config_differences(stored_map_as_given(info.config, config, where), config)
    if info.hyperspace != hs_data:
        diffs.append(f"hyperspace content: the elements or bins of {config.hyperspace!r} changed")
    if diffs:
        raise ConfigError(
            f"{store.location}: campaign {config.name!r} exists with a different config "
            f"({'; '.join(diffs)}); use another --name or the same settings",
            field="name",
            value=config.name,
        )
    _check_runs(store, info, config)
    check_fault_tags(config.name, dict(info.tags or {}), config)
    generator = restore_generator(config, hyperspace, dict(info.generator_state or {}))
    replays = store.count_runs(config.name) and sum(
        1 for r in store.iter_runs(config.name) if r.replay_of
    )
    return generator, True, int(replays)


def _check_runs(store: Store, info: CampaignInfo, config: CampaignConfig) -> None:
    """Extend the stored ``runs`` if ``config`` asks for more; refuse fewer (one line)."""
    stored = int(info.config.get("runs", 0))
    if config.runs < stored:
        raise ConfigError(
            f"{store.location}: campaign {config.name!r} is stored with runs: {stored}; "
            f"runs: {config.runs} would shrink it (a campaign can only be extended)",
            field="runs",
            value=config.runs,
        )
    if config.runs > stored:
        store.update_config(config.name, {**info.config, "runs": config.runs})


def _runs_as_stored(config: CampaignConfig, store: Store) -> CampaignConfig:
    """``config`` with the stored campaign's ``runs`` if ``runs`` was not given explicitly."""
    info = store.find_campaign(config.name)
    if info is None or "runs" in config.model_fields_set:
        return config
    return config.model_copy(update={"runs": int(info.config.get("runs", config.runs))})


def run_campaign(
    config: CampaignConfig,
    store: Store,
    *,
    progress: Callable[[CampaignProgress], None] | None = None,
    executor: Executor | None = None,
) -> CampaignResult:
    """Run (or resume, or extend) the campaign ``config.name`` up to ``config.runs`` runs.

    A stored campaign keeps its stored ``runs`` unless ``config`` sets ``runs`` explicitly;
    more extends it, fewer is refused.

    Args:
        config: the campaign configuration.
        store: where the campaign lives (see :func:`open_store`).
        progress: called with a :class:`CampaignProgress` at start, after every run and at
            the end.
        executor: an executor to use instead of the one ``config`` names (not closed here).

    A campaign is run by one process at a time: the store's lock on it is taken first
    (:meth:`Store.lock_campaign`) and released at the end, however the call ends.

    Raises:
        ConfigError: the campaign exists with a different defining config or with more
            ``runs``, or a part (hyperspace, generator, backend, stack) cannot be built.
        CampaignBusyError: another live process is running this campaign.
    """
    with store.lock_campaign(config.name):
        return _run_locked(config, store, progress, executor)


def _run_locked(
    config: CampaignConfig,
    store: Store,
    progress: Callable[[CampaignProgress], None] | None,
    executor: Executor | None,
) -> CampaignResult:
    """:func:`run_campaign` once the campaign's lock is held."""
    start = time.perf_counter()
    config = _runs_as_stored(config, store)
    hyperspace = resolve_hyperspace(config.hyperspace)
    config = with_hyperspace_map(config, hyperspace)
    backend = build_backend(config)
    check_backend_hyperspace(backend, hyperspace)
    build_stack(config).close()  # a bad stack or fault must fail before anything is stored
    no_effect = no_effect_elements(hyperspace, backend)
    generator, resumed, replayed = _open_campaign(config, store, hyperspace)
    name = config.name
    counts = store.status_counts(name)
    done = sum(v for k, v in counts.items() if k != "pending")
    state = {"done": done, "fail": counts["fail"], "err": counts["error"] + counts["timeout"]}
    state["executed"] = 0
    total = max(config.runs, store.count_runs(name))

    def report(event: str) -> None:
        if progress is not None:
            progress(
                CampaignProgress(
                    event=event,
                    campaign=name,
                    done=state["done"],
                    total=total,
                    failures=state["fail"],
                    errors=state["err"],
                    executed=state["executed"],
                    no_effect=no_effect,
                    resumed=resumed,
                )
            )

    pending = [
        PlannedRun(r.index, r.situation, r.seed, r.replay_of)
        for r in store.iter_runs(name, "pending")
    ]
    own = executor is None
    idle = not pending and store.count_runs(name) >= config.runs  # complete: start no workers
    if idle or not own or config.executor != "serial":
        backend.close()  # only the serial executor reuses the parent's backend
        backend = None
    report("start")
    if idle:
        report("end")
        return _result(store, name, state["executed"], start, no_effect, resumed, replayed)
    runner = executor or make_executor(config, backend)
    judge = judge_of(config)
    try:

        def execute(plans: list[PlannedRun]) -> None:
            tasks = [(p.index, p.situation.to_dict(), p.seed) for p in plans]
            for index, raw, wall in runner.map(tasks):
                outcome = judge(raw)
                store.record_result(name, index, outcome, wall)
                state["done"] += 1
                state["executed"] += 1
                state["fail"] += outcome.status == "fail"
                state["err"] += outcome.status in ("error", "timeout")
                report("run")

        if pending:
            execute(pending)
        while True:
            planned = store.count_runs(name)
            if planned >= config.runs:
                break
            batch_start = store.campaign(name).batch_start
            for run in list(store.iter_runs(name, start=batch_start)):
                if run.outcome is None:  # pragma: no cover - an executor lost a result
                    raise SitcovError(f"{store.location}: run {name}:{run.index} has no result")
                generator.tell(run.situation, run.outcome)
            plans = []
            for i in range(planned, min(planned + config.batch_size, config.runs)):
                plans.append(
                    PlannedRun(i, generator.ask(ask_rng(config.seed, i)), run_seed(config.seed, i))
                )
            store.plan_batch(name, generator.state(), plans)
            execute(plans)
    finally:
        if own:
            runner.close()
    report("end")
    return _result(store, name, state["executed"], start, no_effect, resumed, replayed)


def _result(
    store: Store,
    name: str,
    executed: int,
    start: float,
    no_effect: tuple[str, ...],
    resumed: bool,
    replayed: int,
) -> CampaignResult:
    return CampaignResult(
        name=name,
        counts=store.status_counts(name),
        executed=executed,
        wall_time=time.perf_counter() - start,
        no_effect=no_effect,
        resumed=resumed,
        replayed=replayed,
    )
