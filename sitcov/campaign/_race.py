"""The generator race: every generator on the same budget and seeds, scored by
``sitcov.analysis._race`` against the failure regions of a reference campaign.

Campaigns (all ordinary, tagged ``{"experiment": "race", ...}``, so running again completes
what is missing and the report can read them):

- ``race/reference``: ``reference_runs`` uniform random runs with campaign seed
  ``seed + 100000`` (disjoint from the contestants' seeds); only used to define regions;
- ``race/GEN/sS``: generator GEN, ``runs`` runs, campaign seed ``seed + S``. Every
  generator sees the same seeds, hence the same simulation seeds run by run. Learning
  generators are told outcomes every ``batch_size`` runs; ``nsga2`` gets
  ``pop_size = batch_size`` so its generations line up with the batches.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from sitcov.campaign._judged import require_judged
from sitcov.errors import ConfigError

EXPERIMENT = "race"
REFERENCE = f"{EXPERIMENT}/reference"
#: offset of the reference campaign's seed from the base seed
REFERENCE_SEED_OFFSET = 100_000
#: the contestants by default (the paper's, the baselines, the learners, the search)
RACE_GENERATORS = ("random", "sitcov", "tway", "failure-guided", "surrogate", "nsga2")


def race_configs(
    generators: Sequence[str],
    *,
    runs: int,
    seeds: int,
    seed: int,
    reference_runs: int,
    batch_size: int,
    settings: Mapping[str, Any],
) -> list[Any]:
    """The reference campaign's config, then one per (generator, seed index)."""
    from sitcov.campaign._config import CampaignConfig

    if not generators:
        raise ConfigError(field="--generators", value="", expected="at least one generator")
    if seeds < 1 or runs < 1 or reference_runs < 1:
        raise ConfigError(field="--runs/--seeds/--reference-runs", value=(runs, seeds,
                          reference_runs), expected="positive integers")  # fmt: skip
    common = {**settings, "batch_size": batch_size}
    configs = [
        CampaignConfig(
            name=REFERENCE, generator="random", runs=reference_runs,
            seed=seed + REFERENCE_SEED_OFFSET, tags={"experiment": EXPERIMENT,
            "role": "reference"}, **common,
        )
    ]  # fmt: skip
    for gen in generators:
        options = {"pop_size": batch_size} if gen == "nsga2" else {}
        for s in range(seeds):
            configs.append(
                CampaignConfig(
                    name=f"{EXPERIMENT}/{gen}/s{s}", generator=gen, generator_options=options,
                    runs=runs, seed=seed + s, tags={"experiment": EXPERIMENT, "role":
                    "contestant", "generator": gen, "seed_index": s}, **common,
                )
            )  # fmt: skip
    return configs


def _run_in_process(db: str, config_json: dict[str, Any]) -> str:
    """Worker entry point: run one campaign against the database file (own connection)."""
    from sitcov.campaign import open_store
    from sitcov.campaign._config import CampaignConfig
    from sitcov.campaign._runner import run_campaign

    config = CampaignConfig(**config_json)
    store = open_store(db)
    store.mark_checked()  # the parent process checked the file before starting workers
    try:
        run_campaign(config, store)
    finally:
        store.close()
    return config.name


def run_race(
    store: Any,
    configs: Sequence[Any],
    *,
    workers: int = 1,
    progress: Callable[[str, int], None] | None = None,
) -> dict[str, Any]:
    """Run (or complete) the race's campaigns and return :func:`race_result`.

    With ``workers > 1`` and a file store, campaigns run in parallel processes (each
    serially); results do not depend on it, every run deriving from (campaign seed, index).
    """
    from sitcov.campaign._build import make_generator, resolve_hyperspace
    from sitcov.campaign._runner import run_campaign

    hyperspace = resolve_hyperspace(configs[0].hyperspace)
    for config in {c.generator: c for c in configs}.values():  # bad names fail here
        make_generator(config, hyperspace)
    if workers > 1 and store.location != ":memory:":
        store.check()  # once here: the workers' own connections skip it
        with ProcessPoolExecutor(max_workers=min(workers, len(configs))) as pool:
            futures = {
                pool.submit(_run_in_process, store.location, c.model_dump(mode="json")): c
                for c in configs
            }
            for future, config in futures.items():
                future.result()
                if progress:
                    progress(config.name, config.runs)
    else:
        for config in configs:
            run_campaign(config, store)
            if progress:
                progress(config.name, config.runs)
    require_judged(store, [c.name for c in configs], EXPERIMENT)
    return race_result(store)


def race_result(store: Any, checkpoints: Sequence[int] = (50, 100, 200, 300)) -> dict[str, Any]:
    """Regions of the stored reference campaign, metrics per contestant campaign, and the
    race table (``sitcov.analysis._race``)."""
    from sitcov.analysis._race import campaign_metrics, race_table, reference_regions
    from sitcov.campaign._summary import campaign_hyperspace

    if store.find_campaign(REFERENCE) is None:
        raise ConfigError(f"{store.location}: no campaign {REFERENCE!r} (run the race first)")
    hs = campaign_hyperspace(store, REFERENCE)
    regions = reference_regions(hs, store.iter_runs(REFERENCE))
    per_gen: dict[str, list[dict[str, Any]]] = {}
    campaigns = []
    for info in sorted(store.campaigns(), key=lambda i: i.name):
        tags = dict(info.tags or {})
        if tags.get("experiment") != EXPERIMENT or tags.get("role") != "contestant":
            continue
        runs = [r for r in store.iter_runs(info.name) if r.status != "pending"]
        metrics = campaign_metrics(hs, runs, regions, checkpoints)
        metrics["campaign"], metrics["seed_index"] = info.name, tags.get("seed_index")
        per_gen.setdefault(str(tags["generator"]), []).append(metrics)
        campaigns.append(metrics)
    for metrics in per_gen.values():
        metrics.sort(key=lambda m: m["seed_index"])
    rank = {name: i for i, name in enumerate(RACE_GENERATORS)}
    per_gen = dict(sorted(per_gen.items(), key=lambda kv: (rank.get(kv[0], len(rank)), kv[0])))
    reference = [r for r in store.iter_runs(REFERENCE) if r.status != "pending"]
    return {
        "reference": {
            "runs": len(reference),
            "failures": sum(r.status == "fail" for r in reference),
        },
        "regions": regions,
        "table": race_table(per_gen),
        "campaigns": campaigns,
    }


def _fmt(cell: Mapping[str, Any] | None, digits: int = 1, scale: float = 1.0) -> str:
    if not cell or cell.get("mean") is None:
        return "-"
    text = f"{scale * cell['mean']:.{digits}f}"
    if cell.get("ci95"):
        lo, hi = (scale * v for v in cell["ci95"])
        text += f" [{lo:.{digits}f}, {hi:.{digits}f}]"
    return text


#: (column header, metric label in the race table, digits, scale)
COLUMNS = (
    ("failures", "failures", 1, 1.0),
    ("regions found", "regions", 1, 1.0),
    ("regions @100", "regions_100", 1, 1.0),
    ("runs to region", "runs_to_region", 0, 1.0),
    ("bins @50", "bins_50", 1, 1.0),
    ("pairs % end", "pairs_end", 1, 100.0),
    ("evenness", "evenness", 3, 1.0),
)


def race_markdown(result: Mapping[str, Any]) -> list[str]:
    """The race table as Markdown lines (mean [95 % CI over seeds])."""
    lines = [
        "| generator | seeds | " + " | ".join(c[0] for c in COLUMNS) + " |",
        "|---|---|" + "---|" * len(COLUMNS),
    ]
    for gen, row in result["table"].items():
        cells = [_fmt(row[label], digits, scale) for _, label, digits, scale in COLUMNS]
        lines.append(f"| {gen} | {row['seeds']} | " + " | ".join(cells) + " |")
    return lines


def race_lines(result: Mapping[str, Any]) -> list[str]:
    """Text report: the regions, the table and the paired differences from random."""
    ref = result["reference"]
    lines = [
        f"{len(result['regions'])} failure regions from the reference campaign "
        f"({ref['failures']}/{ref['runs']} runs failed):"
    ]
    for i, r in enumerate(result["regions"], start=1):
        lines.append(f"  R{i}: {r['text']} ({r['failures']}/{r['support']} fail)")
    lines += race_markdown(result)
    for gen, row in result["table"].items():
        end, early = row["regions"].get("vs_random"), row["regions_100"].get("vs_random")
        if end:
            lines.append(
                f"{gen} - random, paired by seed: regions found {_fmt(end, 2)}, "
                f"at 100 runs {_fmt(early, 2)}"
            )
    return lines
