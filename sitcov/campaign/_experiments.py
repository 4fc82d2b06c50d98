"""The seeded-fault experiment (the paper's Table 2), stored as ordinary campaigns.

Protocol, per generator: the runs are split across seeds (100 runs over 5 seeds = 20 per seed).
For each (generator, seed) the no-fault campaign ``faults/GEN/sS/NF`` is generated and run;
then ``.../F1``, ``.../F2`` and ``.../F3`` *replay* its stored situations and run seeds with the
fault switched on. Replaying (rather than generating again) guarantees the identical sequence
even for generators that learn from outcomes. Every campaign is tagged
``{"experiment": "faults", "generator", "seed", "fault"}``, so :func:`fault_table` can rebuild
Table 2 from any database, and running the experiment again completes whatever is missing.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from sitcov.campaign._judged import require_judged
from sitcov.errors import ConfigError

#: Table 2's columns: label -> fault passed to the AV stack (None = no fault).
FAULT_LABELS: dict[str, str | None] = {"NF": None, "F1": "f1", "F2": "f2", "F3": "f3"}
#: Tag value marking the campaigns of this experiment.
EXPERIMENT = "faults"


def campaign_name(generator: str, seed_index: int, label: str) -> str:
    """``faults/GEN/sS/LABEL``, e.g. ``faults/random/s0/NF``."""
    return f"{EXPERIMENT}/{generator}/s{seed_index}/{label}"


def split_runs(runs: int, seeds: int) -> list[int]:
    """Runs per seed: ``runs`` split as evenly as possible, the first seeds taking the rest.

    Raises:
        ConfigError: fewer runs than seeds, or no seeds.
    """
    if seeds < 1:
        raise ConfigError(field="--seeds", value=seeds, expected="at least 1")
    if runs < seeds:
        raise ConfigError(field="--runs", value=runs, expected=f"at least --seeds ({seeds})")
    base, extra = divmod(runs, seeds)
    return [base + (1 if i < extra else 0) for i in range(seeds)]


def _base_config(generator: str, seed_index: int, runs: int, seed: int, settings: Mapping) -> Any:
    from sitcov.campaign._config import CampaignConfig

    return CampaignConfig(
        name=campaign_name(generator, seed_index, "NF"),
        generator=generator,
        runs=runs,
        seed=seed + seed_index,
        tags={
            "experiment": EXPERIMENT,
            "generator": generator,
            "seed": seed + seed_index,
            "fault": "NF",
        },
        **settings,
    )


def _replay_into(store: Any, nf: Any, config: Any) -> None:
    """Create the fault campaign ``config`` planned as replays of ``nf``'s stored runs."""
    from sitcov.campaign._derived import create_derived_campaign
    from sitcov.campaign._store import PlannedRun

    planned = [PlannedRun(r.index, r.situation, r.seed) for r in store.iter_runs(nf.name)]
    if len(planned) != config.runs or any(p.index != i for i, p in enumerate(planned)):
        raise ConfigError(
            f"{store.location}: campaign {nf.name!r} holds {len(planned)} runs, expected "
            f"{config.runs}; it was not made by this experiment with these settings"
        )
    create_derived_campaign(store, nf, config, planned)


def _run_chain(store: Any, base: Any, progress: Callable[[str, int], None] | None) -> None:
    """The NF campaign of one (generator, seed), then its three fault replays."""
    from sitcov.campaign._runner import run_campaign

    run_campaign(base, store)
    if store.count_runs(base.name, "pending"):
        raise ConfigError(f"{store.location}: campaign {base.name!r} did not finish")
    if progress:
        progress(base.name, base.runs)
    nf = store.campaign(base.name)
    for label, fault in FAULT_LABELS.items():
        if fault is None:
            continue
        name = f"{base.name.rsplit('/', 1)[0]}/{label}"
        config = base.model_copy(
            update={"name": name, "fault": fault, "tags": {**base.tags, "fault": label}}
        )
        if store.find_campaign(name) is None:
            _replay_into(store, nf, config)
        run_campaign(config, store)
        if progress:
            progress(name, config.runs)


def _check_parts(bases: Sequence[Any]) -> None:
    """Build every part once up front, so a bad name fails here with a clear error rather
    than inside a worker process."""
    from sitcov.campaign._build import (
        build_backend,
        build_stack,
        make_generator,
        resolve_hyperspace,
    )

    hyperspace = resolve_hyperspace(bases[0].hyperspace)
    for base in {b.generator: b for b in bases}.values():
        make_generator(base, hyperspace)
    build_backend(bases[0]).close()
    for fault in FAULT_LABELS.values():
        stack = build_stack(bases[0].model_copy(update={"fault": fault}))
        stack.close()


def _chain_in_process(db: str, base_json: dict[str, Any]) -> str:
    """Worker entry point: run one chain against the database file (own connection)."""
    from sitcov.campaign import open_store
    from sitcov.campaign._config import CampaignConfig

    base = CampaignConfig(**base_json)
    store = open_store(db)
    store.mark_checked()  # the parent process checked the file before starting workers
    try:
        _run_chain(store, base, None)
    finally:
        store.close()
    return base.name


def run_fault_experiment(
    store: Any,
    *,
    generators: Sequence[str] = ("random", "sitcov"),
    runs: int = 100,
    seeds: int = 5,
    seed: int = 0,
    hyperspace: str = "t-junction",
    av: str = "reference",
    av_params: Mapping[str, Any] | None = None,
    backend: str = "embedded",
    backend_options: Mapping[str, Any] | None = None,
    physics: str = "carla",
    judge: str | Sequence[str] = "default",
    executor: str = "processes",
    workers: int | None = None,
    batch_size: int | None = None,
    progress: Callable[[str, int], None] | None = None,
) -> dict[str, Any]:
    """Run (or complete) the Table 2 protocol into ``store``; return :func:`fault_table`.

    With ``executor="processes"`` and a file store, the (generator, seed) chains run in
    parallel in ``workers`` processes, each running its campaigns serially (a 20-run
    campaign is too small to be worth a worker pool of its own). Otherwise every campaign
    runs with the executor given. Results do not depend on the executor: every run's
    situation and seed derive from (campaign seed, index).

    Args:
        store: an open campaign store.
        generators: generator names, compared side by side.
        runs: runs per generator, split across ``seeds``.
        seeds: number of seeds; seed index ``s`` uses campaign seed ``seed + s``.
        seed: base seed.
        hyperspace, av, av_params, backend, backend_options, physics, judge: as for
            ``sitcov run`` (``judge="paper"`` counts collisions only, as the paper did).
        executor: ``serial`` | ``processes`` | ``ray``.
        workers: parallel workers (default: CPU count).
        batch_size: asks per batch of the no-fault campaigns, i.e. how often a learning
            generator is told outcomes (default: the campaign default).
        progress: called with (campaign name, runs) after each campaign completes.

    Returns:
        The Table 2 dict of :func:`fault_table` for ``generators``.
    """
    import os

    if not generators:
        raise ConfigError(field="--generators", value="", expected="at least one generator")
    per_seed = split_runs(runs, seeds)
    workers = workers or os.cpu_count() or 1
    parallel = executor == "processes" and workers > 1 and store.location != ":memory:"
    settings = {
        "hyperspace": hyperspace,
        "av": av,
        "av_params": dict(av_params) if av_params else None,
        "backend": backend,
        "backend_options": dict(backend_options or {}),
        "physics": physics,
        "judge": judge,
        "executor": "serial" if parallel or executor == "processes" and workers == 1 else executor,
        "workers": 1 if parallel else workers,
    }
    if batch_size is not None:
        settings["batch_size"] = batch_size
    bases = [
        _base_config(gen, s, n, seed, settings)
        for gen in generators
        for s, n in enumerate(per_seed)
    ]
    _check_parts(bases)
    if parallel:  # the workers open their own connections to the same file
        db = store.location
        store.check()  # once here: the workers' own connections skip it
        with ProcessPoolExecutor(max_workers=min(workers, len(bases))) as pool:
            futures = [pool.submit(_chain_in_process, db, b.model_dump(mode="json")) for b in bases]
            for base, future in zip(bases, futures, strict=True):
                future.result()
                if progress:
                    for label in FAULT_LABELS:
                        progress(base.name.rsplit("/", 1)[0] + "/" + label, base.runs)
    else:
        for base in bases:
            _run_chain(store, base, progress)
    chains = [b.name.rsplit("/", 1)[0] for b in bases]
    require_judged(store, [f"{c}/{label}" for c in chains for label in FAULT_LABELS], EXPERIMENT)
    return fault_table(store, generators=generators)


def fault_table(store: Any, generators: Sequence[str] | None = None) -> dict[str, Any]:
    """Table 2 from the fault-experiment campaigns stored in ``store``.

    Per generator: failures of the no-fault runs (``NF``) and of each fault (``F1``..``F3``)
    out of ``runs``; ``triggered`` = F − NF (the paper's measure); ``newly_failing`` = runs
    failing with the fault and not without it (same situation and seed); ``cured`` = the
    reverse; ``ci95`` = Wilson 95 % interval of each failure count out of ``runs``;
    ``errors`` = runs that could not be judged; ``seeds`` = the campaign seeds; ``complete``
    whether every fault campaign holds every NF run, finished.

    Args:
        store: a campaign store.
        generators: restrict to (and order by) these generators; default all stored.
    """
    from sitcov.analysis import wilson_interval

    # generator -> seed -> label -> index -> status
    found: dict[str, dict[Any, dict[str, dict[int, str]]]] = {}
    for info in store.campaigns():
        tags = dict(info.tags or {})
        if tags.get("experiment") != EXPERIMENT or tags.get("fault") not in FAULT_LABELS:
            continue
        gen = str(tags.get("generator"))
        statuses = {r.index: r.status for r in store.iter_runs(info.name)}
        found.setdefault(gen, {}).setdefault(tags.get("seed"), {})[tags["fault"]] = statuses

    order = list(generators) if generators is not None else sorted(found)
    result: dict[str, Any] = {}
    for gen in order:
        per_seed = found.get(gen, {})
        counts = dict.fromkeys(FAULT_LABELS, 0)
        errors = dict.fromkeys(FAULT_LABELS, 0)
        newly = dict.fromkeys(list(FAULT_LABELS)[1:], 0)
        cured = dict.fromkeys(list(FAULT_LABELS)[1:], 0)
        runs, complete = 0, bool(per_seed)
        for by_label in per_seed.values():
            nf = by_label.get("NF", {})
            runs += sum(1 for s in nf.values() if s != "pending")
            for label in FAULT_LABELS:
                statuses = by_label.get(label, {})
                if set(statuses) != set(nf) or "pending" in statuses.values():
                    complete = False
                counts[label] += sum(1 for s in statuses.values() if s == "fail")
                errors[label] += sum(1 for s in statuses.values() if s in ("error", "timeout"))
                if label == "NF":
                    continue
                for index, status in statuses.items():
                    base = nf.get(index)
                    if base is None or status == "pending" or base == "pending":
                        continue
                    if status == "fail" and base == "pass":
                        newly[label] += 1
                    elif status == "pass" and base == "fail":
                        cured[label] += 1
        ci95 = {}
        for label, k in counts.items():
            ci95[label] = [float(x) for x in wilson_interval(k, runs)] if runs else None
        result[gen] = {
            **counts,
            "runs": runs,
            "triggered": {label: counts[label] - counts["NF"] for label in list(FAULT_LABELS)[1:]},
            "newly_failing": newly,
            "cured": cured,
            "ci95": ci95,
            "errors": errors,
            "seeds": sorted(per_seed, key=str),
            "complete": complete,
        }
    return {"generators": result}
