"""Campaign summaries: the JSON of ``sitcov summary --json`` and the console table.

The numbers come from ``sitcov.analysis.summarize`` over the finished runs (pending runs
are not counted). Bins are ranked "worst" by the lower end of their Wilson 95% interval,
so a bin with 1 failure in 1 run does not outrank one with 30 in 60.

The summary also says how the verdicts were made: the physics profile, the judge (what
counts as a failure) and the world-model version of the campaign(s). A campaign stored
before these existed is labelled ``legacy``: its physics was the old compounded weather
model and its judge counted collisions only.
"""

from __future__ import annotations

import json
from collections.abc import Iterable, Iterator, Mapping
from typing import Any

from sitcov.campaign._store import CampaignInfo, Store, StoreError

FINISHED = ("pass", "fail", "error", "timeout")


def campaign_hyperspace(store: Store, campaign: str | None = None) -> Any:
    """The hyperspace of ``campaign`` (or of every campaign, which must share one)."""
    from sitcov.hyperspace import Hyperspace

    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    if not infos:
        raise StoreError(f"{store.location}: the store holds no campaigns")
    first = infos[0].hyperspace
    others = [c.name for c in infos if c.hyperspace != first]
    if others:
        raise StoreError(
            f"{store.location}: campaigns use different hyperspaces ({infos[0].name} vs "
            f"{', '.join(others)}); choose one with --campaign"
        )
    return Hyperspace.from_dict(first, file=f"{store.location} (campaign {infos[0].name})")


def campaign_setup(info: CampaignInfo) -> dict[str, Any]:
    """Physics profile, judge and world model a stored campaign was made with."""
    if info.legacy:
        return {"physics": "legacy", "judge": "paper", "world_model": "legacy",
                "perception_draws": 1}  # fmt: skip
    return {
        "physics": info.config.get("physics", "carla"),
        "judge": _judge_text(info.config.get("judge", "default")),
        "world_model": info.world_version,
        "perception_draws": int(info.config.get("perception_draws") or 1),
    }


def _judge_text(spec: Any) -> str:
    """A judge setting as text: a name, or its kinds comma-separated."""
    return spec if isinstance(spec, str) else ",".join(spec)


def _one_or_all(values: list[Any]) -> Any:
    """The value if all campaigns agree, else the distinct values in order."""
    distinct = [v for i, v in enumerate(values) if v not in values[:i]]
    return distinct[0] if len(distinct) == 1 else distinct


def events_by_kind(facts: Iterable[Mapping[str, Any]]) -> dict[str, int]:
    """Judged runs in which each failure event happened, whether the judge counted it or not
    (what another judge would add; legacy runs report collisions only), from the runs'
    facts (:func:`sitcov.campaign._facts.iter_facts`)."""
    from sitcov.sim import FAILURE_KINDS

    counts = dict.fromkeys(FAILURE_KINDS, 0)
    for run in facts:
        if run["status"] in ("pass", "fail"):
            for kind in run["events"]:
                counts[kind] += 1
    return counts


def summarize_store(store: Store, campaign: str | None = None) -> dict[str, Any]:
    """The `sitcov summary --json` object of the finished runs of ``campaign`` (or all), plus
    ``physics``, ``judge`` and ``world_model`` (one value, or a list when the campaigns
    differ), ``judge_counts`` (the kinds that fail a run), ``legacy_world_model`` (any
    campaign made before world versions), ``events_by_kind`` (judged runs with each event,
    counted or not), ``not_counted`` (the kinds the judge does not count that happened,
    with their run counts), ``route_completion``
    (:func:`sitcov.analysis.route_completion_stats` over the judged runs) and
    ``actor_collisions`` (runs with a collision between two other road users, and how many
    such collisions: recorded, never the ego's failure), ``perception_draws`` (draws per
    run, one value or a list) and ``draws`` (:func:`~sitcov.campaign._facts.draw_facts`,
    None without draws).

    The runs are read once, as a stream of their facts (no run records are built), so a
    100,000-run campaign is summarised in seconds with flat memory.
    """
    from sitcov.analysis import route_completion_stats, summarize
    from sitcov.campaign._breakdown import slot_types
    from sitcov.campaign._facts import draw_facts, iter_facts
    from sitcov.sim import FAILURE_KINDS, Judge

    hyperspace = campaign_hyperspace(store, campaign)
    events = dict.fromkeys(FAILURE_KINDS, 0)
    completions: list[float | None] = []
    contacts = [0, 0]  # runs with a collision between two other road users, collisions

    def stream() -> Iterator[Mapping[str, Any]]:
        for facts in iter_facts(store, campaign, FINISHED):
            if facts["status"] in ("pass", "fail"):
                for kind in facts["events"]:
                    events[kind] += 1
                completions.append(facts.get("completion"))
                n = facts.get("actor_collisions") or 0
                contacts[0] += n > 0
                contacts[1] += n
            yield facts

    summary = summarize(hyperspace, stream(), slot_types(hyperspace))
    infos = [store.campaign(campaign)] if campaign else store.campaigns()
    setups = [campaign_setup(i) for i in infos]
    for key in ("physics", "judge", "world_model", "perception_draws"):
        summary[key] = _one_or_all([s[key] for s in setups])
    if len({s["judge"] for s in setups}) == 1:
        summary["judge_counts"] = list(Judge.from_spec(setups[0]["judge"]).counts)
    summary["legacy_world_model"] = any(i.legacy for i in infos)
    summary["events_by_kind"] = events
    summary["route_completion"] = route_completion_stats(completions)
    counted = summary.get("judge_counts")
    summary["not_counted"] = (
        {k: n for k, n in events.items() if n and k not in counted} if counted else {}
    )
    summary["actor_collisions"] = {"runs": contacts[0], "collisions": contacts[1]}
    summary["draws"] = (
        draw_facts(store, campaign) if any(s["perception_draws"] > 1 for s in setups) else None
    )
    return summary


#: a bin needs this many runs to be ranked among the worst (fewer say too little)
MIN_RANKED = 10


def worst_bins(summary: dict[str, Any], n: int = 5) -> list[tuple[str, str, dict[str, Any]]]:
    """The ``n`` bins with the highest Wilson lower bound of failure rate (ties: rate,
    count), among bins with at least :data:`MIN_RANKED` runs."""
    ranked = []
    for element, bins in summary.get("elements", {}).items():
        for label, stats in bins.items():
            enough = stats.get("generated", 0) >= MIN_RANKED
            if enough and stats.get("failures") and stats.get("ci95"):
                key = (stats["ci95"][0], stats["failure_rate"], stats["generated"])
                ranked.append((key, element, label, stats))
    ranked.sort(key=lambda r: r[0], reverse=True)
    return [(e, lab, s) for _, e, lab, s in ranked[:n]]


def summary_table(summary: dict[str, Any], title: str = "campaign summary") -> Any:
    """A rich renderable: totals, coverage and the worst bins."""
    from rich.console import Group
    from rich.table import Table

    # Every number comes from the JSON summary (``sitcov summary --json``), never recomputed
    # here: the failure rate is over judged runs (pass + fail), errors and time-outs apart.
    runs, failures = summary["runs"], summary["failures"]
    errors, timeouts = summary["errors"], summary.get("timeouts", 0)
    judged = summary.get("passes", 0) + failures
    totals = Table(title=title, show_header=False, title_justify="left")
    totals.add_column(style="bold")
    totals.add_column(justify="right")
    totals.add_row("runs", f"{runs}  ({judged} judged)")
    totals.add_row("failures", str(failures))
    totals.add_row("failure rate", _rate_text(summary["failure_rate"], summary["ci95"], judged))
    for kind, k in summary.get("failures_by_kind", {}).items():
        if k["failures"]:
            text = f"{k['failures']}  {_rate_text(k['failure_rate'], k['ci95'], judged)}"
            totals.add_row(f"  {kind.replace('_', ' ')}", text)
    for kind, n in summary.get("not_counted", {}).items():
        totals.add_row(f"  not counted: {kind.replace('_', ' ')}", _uncounted_text(n, judged))
    # (events that happened in runs the campaign's judge passes or fails for another kind)
    contacts = summary.get("actor_collisions") or {}
    if contacts.get("runs"):
        totals.add_row("  other road users collided", f"{contacts['runs']} runs (never the ego's)")
    if "route_completion" in summary:
        from sitcov.analysis import completion_lines

        head, dist = completion_lines(summary["route_completion"])
        totals.add_row("route completion", head)
        if dist:
            totals.add_row("  distribution", dist)
    totals.add_row("errors + timeouts", f"{errors} + {timeouts}")
    for key, label in (("physics", "physics"), ("judge", "judge"), ("world_model", "world model")):
        if key in summary:
            totals.add_row(label, _setup_text(summary, key))
    if summary.get("draws"):
        totals.add_row("perception draws", _draws_text(summary))
    cov = summary.get("coverage", {})
    totals.add_row("bins covered", f"{cov.get('bins_covered', 0)} / {cov.get('bins_total', 0)}")
    totals.add_row("pairwise coverage", f"{cov.get('pairwise', 0.0):.1%}")
    worst = Table(
        title=f"worst bins (by Wilson lower bound; bins of >= {MIN_RANKED} runs)",
        title_justify="left",
    )
    for col in ("element", "bin", "runs", "failures", "rate", "95% CI"):
        worst.add_column(col, justify="left" if col in ("element", "bin") else "right")
    for element, label, s in worst_bins(summary):
        lo, hi = s["ci95"]
        worst.add_row(
            element,
            label,
            str(s["generated"]),
            str(s["failures"]),
            f"{s['failure_rate']:.0%}",
            f"{lo:.0%} - {hi:.0%}",
        )
    parts = [totals, *breakdown_tables(summary)]
    if worst.row_count:
        parts.append(worst)
    elif summary.get("failures"):
        parts.append(f"worst bins: none ranked yet (a bin needs >= {MIN_RANKED} runs)")
    return Group(*parts)


#: Titles of the breakdown tables of the console summary.
BREAKDOWN_TITLES = {"actor_kind": "actor kind", "conflict_type": "conflict type"}


def breakdown_tables(summary: dict[str, Any]) -> list[Any]:
    """Rich tables of the failure rate per actor kind and per conflict type (runs involving
    each; rows with runs only; none for a summary without breakdowns)."""
    from rich.table import Table

    tables = []
    for key, title in BREAKDOWN_TITLES.items():
        rows = {
            k: r for k, r in summary.get("breakdowns", {}).get(key, {}).items() if r["generated"]
        }
        if not rows:
            continue
        table = Table(title=f"failure rate by {title}", title_justify="left")
        for col in (title, "runs", "failures", "rate", "95% CI"):
            table.add_column(col, justify="left" if col == title else "right")
        for name, r in rows.items():
            rate = "n/a" if r["failure_rate"] is None else f"{r['failure_rate']:.1%}"
            ci = "n/a" if r["ci95"] is None else f"{r['ci95'][0]:.1%} - {r['ci95'][1]:.1%}"
            table.add_row(name.replace("_", " "), str(r["generated"]), str(r["failures"]), rate, ci)
        tables.append(table)
    hit = hit_table(summary.get("breakdowns", {}).get("hit_kind", {}))
    return tables + ([hit] if hit is not None else [])


def hit_table(rows: Mapping[str, Any]) -> Any:
    """Rich table of the collisions per kind of road user the ego hit (None: no rows with
    runs)."""
    from rich.table import Table

    rows = {k: r for k, r in rows.items() if r["generated"]}
    if not rows:
        return None
    table = Table(title="collisions by the road user hit", title_justify="left")
    for col in ("road user hit", "runs with it", "collisions", "rate", "95% CI", "share"):
        table.add_column(col, justify="left" if col == "road user hit" else "right")
    for name, r in rows.items():
        rate = "n/a" if r["collision_rate"] is None else f"{r['collision_rate']:.1%}"
        ci = "n/a" if r["ci95"] is None else f"{r['ci95'][0]:.1%} - {r['ci95'][1]:.1%}"
        share = "n/a" if r["share"] is None else f"{r['share']:.0%}"
        table.add_row(name, str(r["generated"]), str(r["collisions"]), rate, ci, share)
    return table


def _rate_text(rate: float | None, ci95: Any, judged: int) -> str:
    """``r%  (95% CI lo% - hi%) of N judged`` as the JSON summary states it; n/a if none."""
    if rate is None or not ci95:
        return "n/a (no judged run)"
    return f"{rate:.1%}  (95% CI {ci95[0]:.1%} - {ci95[1]:.1%}) of {judged} judged"


def _uncounted_text(n: int, judged: int) -> str:
    """``12 runs (6.0%)``: runs with an event the judge does not count."""
    runs = "1 run" if n == 1 else f"{n} runs"
    return f"{runs} ({n / judged:.1%})" if judged else runs


def _draws_text(summary: dict[str, Any]) -> str:
    """The perception-draws row: draws per run, the mean share of failing draws (what one
    draw per run would give as the failure rate) and the runs whose draws split."""
    d, k = summary["draws"], summary["perception_draws"]
    per = f"{k} per run" if isinstance(k, int) else "/".join(map(str, k)) + " per run"
    return (
        f"{per}, majority verdict; failing draws {d['failing_draw_share']:.1%}; "
        f"{d['split_runs']} of {d['runs']} runs split"
    )


def _setup_text(summary: dict[str, Any], key: str) -> str:
    """One line for the physics / judge / world model row of the console summary."""
    value = summary[key]
    if isinstance(value, list):
        return "mixed: " + ", ".join(str(v) for v in value)
    if key == "judge" and summary.get("judge_counts"):
        counts = " + ".join(k.replace("_", " ") for k in summary["judge_counts"])
        legacy = ", legacy" if summary.get("legacy_world_model") else ""
        return f"{value} ({counts}{legacy})"
    if key == "world_model" and value == "legacy":
        return "legacy (before physics profiles and failure kinds)"
    return str(value)


def summary_json(store: Store, campaign: str | None = None) -> str:
    """``sitcov summary --json`` output (one JSON object)."""
    return json.dumps(summarize_store(store, campaign))
