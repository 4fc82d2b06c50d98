"""A stored run's trace for pictures and animations: the stored one when complete, else one
re-simulation with recording from the run's stored situation, seed and campaign config
(runs are deterministic per seed, so the trace shows the stored run)."""

from __future__ import annotations

from typing import Any


def _complete(trace: Any) -> bool:
    """Whether a stored trace has every actor's rows (stores before this kept the ego's and
    the primary OV's only, so such a run is simulated again to draw the others)."""
    if trace is None:
        return False
    actors = (trace.meta or {}).get("actors") or {}
    return len(actors) <= 1 or set(actors) <= set(trace.actors or {})


def traced_outcome(store: Any, run: Any, builders: dict) -> Any:
    """The run's outcome with a complete trace: the stored one, else one re-simulation with
    ``record=True`` (backends and stacks are kept in ``builders`` per campaign; close them
    with :func:`close_builders`)."""
    stored = store.get_run(run.campaign, run.index, with_trace=True)
    if stored.outcome is not None and _complete(stored.outcome.trace):
        return stored.outcome
    from sitcov.campaign._build import build_backend, build_stack
    from sitcov.campaign._config import CampaignConfig

    key = run.campaign
    if key not in builders:
        known = set(CampaignConfig.model_fields)
        config = CampaignConfig(**{k: v for k, v in dict(run.config).items() if k in known})
        builders[key] = (build_backend(config), build_stack(config))
    backend, stack = builders[key]
    from sitcov.sim import Judge

    judge = Judge.from_spec(run.config.get("judge", "paper"))  # stored before judges: paper
    return judge(backend.run(stored.situation, stack, run.seed, record=True))


def close_builders(builders: dict) -> None:
    """Close the stacks and backends :func:`traced_outcome` built."""
    for backend, stack in builders.values():
        for obj in (stack, backend):
            close = getattr(obj, "close", None)
            if close is not None:
                close()
