"""The flakiness experiment: the same situations re-run with other seeds, stored as campaigns.

Protocol: the campaign ``NAME/base`` is generated and run as any campaign (``situations``
runs). Then ``NAME/r1`` .. ``NAME/r{K-1}`` *replay* its stored situations (the identical
situation values, also for learning generators) with fresh simulation seeds derived from
(base run seed, repeat number), so each situation is run with ``K`` seeds. Every campaign is
tagged ``{"experiment": "flakiness", "group": NAME, "repeat": r}``; running again completes
what is missing.

Coverage stays honest: ``NAME/base`` holds each situation once, so
``sitcov summary --campaign NAME/base`` counts situations, while a summary of the whole
database counts every run (a repeat is a run, with its own verdict).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any

import numpy as np

from sitcov.campaign._judged import require_judged
from sitcov.errors import ConfigError

EXPERIMENT = "flakiness"
_REPEAT_STREAM = 4  # apart from the campaign's 0/1 and the shrinker's 2/3


def repeat_seed(seed: int, repeat: int) -> int:
    """The simulation seed of repeat ``repeat`` (>= 1) of a run whose seed is ``seed``."""
    state = np.random.SeedSequence([_REPEAT_STREAM, int(repeat), int(seed)])
    return int(state.generate_state(1, dtype=np.uint32)[0])


def _plan_repeat(store: Any, base: Any, config: Any, repeat: int) -> None:
    """Create campaign ``config`` as the base's situations with repeat seeds."""
    from sitcov.campaign._derived import create_derived_campaign
    from sitcov.campaign._store import PlannedRun

    planned = [
        PlannedRun(r.index, r.situation, repeat_seed(r.seed, repeat))
        for r in store.iter_runs(base.name)
    ]
    create_derived_campaign(store, base, config, planned)


def run_flakiness_experiment(
    store: Any,
    base: Any,
    *,
    repeats: int,
    progress: Callable[[str, int], None] | None = None,
) -> dict[str, Any]:
    """Run (or complete) the experiment; return :func:`flakiness_table`.

    Args:
        store: an open campaign store.
        base: the ``CampaignConfig`` of ``NAME/base`` (its name must end in ``/base``).
        repeats: seeds per situation, K >= 2 (the base run counts as one).
        progress: called with (campaign name, runs) after each campaign completes.
    """
    from sitcov.campaign._runner import run_campaign

    if repeats < 2:
        raise ConfigError(field="--repeats", value=repeats, expected="at least 2")
    group = base.name.rsplit("/", 1)[0]
    run_campaign(base, store)
    if store.count_runs(base.name, "pending"):
        raise ConfigError(f"{store.location}: campaign {base.name!r} did not finish")
    if progress:
        progress(base.name, base.runs)
    stored = store.campaign(base.name)
    for r in range(1, repeats):
        config = base.model_copy(
            update={"name": f"{group}/r{r}", "tags": {**base.tags, "repeat": r}}
        )
        if store.find_campaign(config.name) is None:
            _plan_repeat(store, stored, config, r)
        run_campaign(config, store)
        if progress:
            progress(config.name, config.runs)
    names = [base.name] + [f"{group}/r{r}" for r in range(1, repeats)]
    require_judged(store, names, EXPERIMENT)
    return flakiness_table(store, group)


def base_config(name: str, settings: Mapping[str, Any]) -> Any:
    """The ``CampaignConfig`` of ``NAME/base`` from ``sitcov run``-style settings."""
    from sitcov.campaign._config import CampaignConfig

    tags = {"experiment": EXPERIMENT, "group": name, "repeat": 0}
    return CampaignConfig(name=f"{name}/base", tags=tags, **settings)


def flakiness_table(store: Any, group: str = EXPERIMENT, seed: int = 0) -> dict[str, Any]:
    """Flakiness of the stored experiment ``group`` (see ``sitcov.analysis._flaky``).

    Situations are matched by run index across the group's campaigns; a repeat campaign
    still running contributes the runs it has finished. Each of the flakiest situations
    has ``replay``, the command that re-runs its base run (``sitcov replay --db ...``).
    """
    from sitcov.analysis._flaky import flakiness
    from sitcov.campaign._export import replay_command
    from sitcov.campaign._summary import campaign_hyperspace

    base = f"{group}/base"
    if store.find_campaign(base) is None:
        raise ConfigError(f"{store.location}: no campaign {base!r} (run the experiment first)")
    members = [
        info.name
        for info in store.campaigns()
        if dict(info.tags or {}).get("experiment") == EXPERIMENT
        and dict(info.tags or {}).get("group") == group
    ]
    statuses: dict[int, list[str]] = {}
    bins: dict[int, dict[str, str]] = {}
    for name in members:
        for run in store.iter_runs(name):
            statuses.setdefault(run.index, []).append(run.status)
            if name == base:
                bins[run.index] = dict(run.bins)
    order = sorted(bins)
    result = flakiness(
        campaign_hyperspace(store, base), [(bins[i], statuses[i]) for i in order], seed=seed
    )
    for item in result["flakiest"]:
        item["index"] = order[item.pop("position")]
        item["replay"] = replay_command(store.location, base, item["index"])
    result["group"] = group
    result["campaigns"] = sorted(members)
    return result


def _pct(x: float | None) -> str:
    return "-" if x is None else f"{100 * x:.0f}%"


def flakiness_lines(table: dict[str, Any], n_bins: int = 8) -> list[str]:
    """Plain-text report: overall flakiness, the flakiest bins and situations."""
    o = table["overall"]
    lines = [
        f"flakiness of {o['situations']} situations x {table['repeats']} seeds "
        f"({table['group']}): {o['flaky']} flaky ({_pct(o['flaky_share'])}, 95% CI "
        f"{_pct((o['flaky_ci95'] or [None])[0])}-{_pct((o['flaky_ci95'] or [None, None])[1])});"
        f" two seeds disagree {_pct(o['flip'])} of the time (95% CI "
        f"{_pct((o['flip_ci95'] or [None])[0])}-{_pct((o['flip_ci95'] or [None, None])[1])})",
    ]
    ranked = [
        (stats["flip_ci95"][0], stats["flip"], element, label, stats)
        for element, bins in table["elements"].items()
        for label, stats in bins.items()
        if stats["flip"] is not None
    ]
    ranked.sort(key=lambda r: (-r[0], -r[1], r[2], r[3]))
    if ranked:
        lines.append("flakiest bins by lower 95% bound (flip = chance two seeds disagree):")
    for _, flip, element, label, stats in ranked[:n_bins]:
        lo, hi = stats["flip_ci95"]
        lines.append(
            f"  {element}={label}: flip {_pct(flip)} [{_pct(lo)}, {_pct(hi)}], "
            f"{stats['flaky']}/{stats['situations']} situations flaky"
        )
    if table["flakiest"]:
        lines.append("flakiest situations (failures/seeds, replay line):")
    for item in table["flakiest"][:5]:
        lines.append(f"  {item['failures']}/{item['judged']}  {item['replay']}")
    return lines
