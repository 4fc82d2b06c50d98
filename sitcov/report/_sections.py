"""The sections of the HTML report, each computed from stored runs into template data.

Each ``*_section`` function returns the plain data (strings, numbers, base64 PNGs) its part of
``index.html.j2`` renders; :func:`sitcov.report.build_report` calls them in page order.
"""

from __future__ import annotations

import base64
import json
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sitcov.report import _figures
from sitcov.report._data import NO_FAULT, CampaignView, group_runs
from sitcov.report._stats import pair_table

#: At most this many campaigns get a coverage-growth line (more would be unreadable).
MAX_GROWTH_LINES = 10


def b64(data: bytes) -> str:
    """PNG bytes as the base64 text of a ``data:`` URI."""
    return base64.b64encode(data).decode("ascii")


def pct(x: float | None) -> str:
    """A fraction as a percentage with one decimal, ``–`` for None."""
    return "–" if x is None else f"{100.0 * x:.1f}%"


def rate_ci(k: int, n: int) -> str:
    """``k / n`` as a percentage with its Wilson 95 % interval, ``–`` when ``n`` is 0."""
    from sitcov.analysis import wilson_interval

    if n <= 0:
        return "–"
    lo, hi = wilson_interval(k, n)
    return f"{100.0 * k / n:.1f}% [{100.0 * lo:.1f}–{100.0 * hi:.1f}]"


def slug(text: str) -> str:
    """``text`` made safe for a file name."""
    keep = "".join(c if c.isalnum() or c in "-_" else "_" for c in text)
    return keep.strip("_") or "element"


def hyperspace_of(views: Sequence[CampaignView]) -> Any:
    """The hyperspace stored with the first campaign (else the one its config names)."""
    from sitcov.hyperspace import Hyperspace, load_hyperspace

    for view in views:
        if view.hyperspace:
            return Hyperspace.from_dict(view.hyperspace)
    name = next((v.config.get("hyperspace") for v in views if v.config.get("hyperspace")), None)
    return load_hyperspace(name)


def status_counts(runs: Sequence[Any]) -> dict[str, int]:
    """Runs per status (pass, fail, error, timeout always present)."""
    counts = {"pass": 0, "fail": 0, "error": 0, "timeout": 0}
    for run in runs:
        counts[run.status] = counts.get(run.status, 0) + 1
    return counts


def ranked_rows(rows: Sequence[dict[str, Any]]) -> list[dict[str, str]]:
    """Rows of :func:`sitcov.analysis.worst_bins` / ``worst_pairs`` formatted for the page."""
    out = []
    for row in rows:
        elements = row.get("elements") or (row["element"],)
        labels = row.get("labels") or (row["label"],)
        ci = row["ci95"]
        out.append(
            {
                "elements": " × ".join(elements),
                "labels": " × ".join(str(lab) for lab in labels),
                "fj": f"{row['failures']} / {row['judged']}",
                "rate": pct(row["failure_rate"]),
                "ci": f"{100 * ci[0]:.1f}–{100 * ci[1]:.1f}%" if ci else "–",
                "alone": " / ".join(pct(r) for r in row["bin_rates"]) if "bin_rates" in row else "",
            }
        )
    return out


def run_command(db: str, view: CampaignView, experiment: str | None) -> str:
    """The command that (re)creates ``view``'s campaign: ``sitcov run`` with its settings,
    or, for a fault-experiment campaign, the experiment command."""
    if view.is_fault_experiment and experiment:
        return experiment
    cfg = view.config
    parts = ["sitcov", "run", "--db", db, "--name", view.name]
    for key, flag in (
        ("hyperspace", "--hyperspace"),
        ("generator", "--generator"),
        ("runs", "--runs"),
        ("seed", "--seed"),
        ("batch_size", "--batch-size"),
        ("backend", "--backend"),
        ("av", "--av"),
        ("fault", "--fault"),
        ("physics", "--physics"),
        ("judge", "--judge"),
    ):
        value = cfg.get(key)
        if isinstance(value, list):
            value = ",".join(value)
        if value is not None and not (key == "hyperspace" and value == "t-junction"):
            parts += [flag, str(value)]
    perception = (cfg.get("backend_options") or {}).get("perception")
    if perception:
        parts += ["--perception", str(perception)]
    command = shlex.join(parts)
    if cfg.get("generator_options") or cfg.get("av_params") or cfg.get("replay_failures_first"):
        command += "   # plus the options in the config above: pass them with --config FILE"
    return command


def experiment_command(db: str, table: dict[str, Any]) -> str | None:
    """``sitcov experiment faults`` with the stored experiment's generators, runs and seeds."""
    if not table:
        return None
    first = next(iter(table.values()))
    seeds = [s for s in first["seeds"] if isinstance(s, int)]
    parts = ["sitcov", "experiment", "faults", "--db", db, "--generators", ",".join(table)]
    parts += ["--runs", str(first["runs"]), "--seeds", str(len(first["seeds"]))]
    if seeds:
        parts += ["--seed", str(min(seeds))]
    return shlex.join(parts)


def table2_section(table: dict[str, Any], out: Path) -> dict[str, Any] | None:
    """Table 2 rows and chart from :func:`sitcov.campaign.fault_table` output."""
    from sitcov.campaign._experiments import FAULT_LABELS

    if not table:
        return None
    faults = list(FAULT_LABELS)
    rows = []
    for gen, row in table.items():
        runs = row["runs"]
        for fault in faults:
            nf = fault == "NF"
            rows.append(
                {
                    "first": nf,
                    "generator": gen if nf else "",
                    "fault": fault,
                    "count": f"{row[fault]} / {runs}",
                    "rate": rate_ci(row[fault], runs),
                    "triggered": "" if nf else f"{row['triggered'][fault]:+d}",
                    "newly": "" if nf else str(row["newly_failing"][fault]),
                    "cured": "" if nf else str(row["cured"][fault]),
                }
            )
    png = _figures.save(_figures.table2_figure(table), out / "table2.png")
    runs_note = ", ".join(sorted({str(r["runs"]) for r in table.values()}))
    return {"faults": faults, "rows": rows, "figure": b64(png), "runs_note": runs_note}


def _setup_value(views: Sequence[CampaignView], key: str) -> str:
    """One physics / judge / world-model value for the cards, or ``mixed: a, b``."""
    values = list(dict.fromkeys(str(v.setup.get(key, "?")) for v in views))
    return values[0] if len(values) == 1 else "mixed: " + ", ".join(values)


#: What the summary's perception card says of each perception a campaign can run with
#: (the backend option ``perception``; the embedded and esmini backends default to the
#: PEM; the CARLA backend's is its own camera).
PERCEPTION_DETAIL = {
    "pem": "a per-frame model of the SSD detector (docs/pem.md)",
    "camera": "rendered frames and the SSD detector (docs/camera.md)",
    "carla": "the simulator's own camera",
}
#: What the summary says under the cards of a campaign run on the PEM: what the model is
#: known to get wrong, where it shows in verdicts, and how to check it.
PEM_NOTE = (
    "Perception was the PEM, a model of the detector checked on held-out frames per "
    "distance band. Within a band it under-reports close cars coming from the ego's left "
    'and over-reports oncoming cars at 10-20 m (docs/pem.md, "Within a band"): a stack '
    "braking at a score of 0.5 then fails road users from the left more often, and those "
    "from the right less often, than in camera mode (the default campaign re-run in camera "
    "mode: 52.5 % against 49.7 % from the left, 38.5 % against 40.5 % from the right). "
    "Confirm an effect of approach side or route with --perception camera before "
    "reporting it."
)


#: What the PEM note adds for a campaign whose runs were single perception draws, and for
#: one whose verdicts are majorities of several (``sitcov run --perception-draws``).
PEM_DRAWS_NOTE = (
    "Each run's verdict is one draw of the PEM's noise: two runs of the same world disagree "
    "far more often than two camera runs do. For per-situation verdicts run the campaign "
    'with --perception-draws (docs/pem.md, "Perception draws").'
)
PEM_MAJORITY_NOTE = (
    "Each run's verdict is the majority of {draws} perception draws of its world; the "
    "stored run is the first draw with the majority's verdict."
)


def draws_of(views: Sequence[CampaignView]) -> int:
    """The campaigns' perception draws per run (the largest; 1: single draws)."""
    return max((int(v.config.get("perception_draws") or 1) for v in views), default=1)


def pem_note(views: Sequence[CampaignView]) -> str:
    """The note under the cards: :data:`PEM_NOTE` and what the verdicts are draws of
    (empty when no campaign ran on the PEM)."""
    if "pem" not in perception_of(views):
        return ""
    draws = draws_of(views)
    tail = PEM_DRAWS_NOTE if draws == 1 else PEM_MAJORITY_NOTE.format(draws=draws)
    return f"{PEM_NOTE} {tail}"


def perception_of(views: Sequence[CampaignView]) -> str:
    """The campaigns' perception (``pem`` unless a backend option names another;
    ``carla`` for the CARLA backend), or ``mixed: a, b``."""
    values = []
    for view in views:
        cfg = view.config
        if str(cfg.get("backend", "embedded")) == "carla":
            values.append("carla")
        else:
            values.append(str((cfg.get("backend_options") or {}).get("perception") or "pem"))
    values = list(dict.fromkeys(values))
    return values[0] if len(values) == 1 else "mixed: " + ", ".join(values)


def _perception_card(views: Sequence[CampaignView]) -> dict[str, Any]:
    value = perception_of(views)
    detail = PERCEPTION_DETAIL.get(value, "campaigns differ: compare them per perception")
    draws = draws_of(views)
    if draws > 1:
        detail += f"; the majority of {draws} perception draws per run"
    return {"key": "perception", "value": value, "detail": detail}


def _setup_cards(views: Sequence[CampaignView]) -> list[dict[str, Any]]:
    from sitcov.sim import Judge

    judge = _setup_value(views, "judge")
    try:
        counted = " + ".join(k.replace("_", " ") for k in Judge.from_spec(judge).counts)
    except ValueError:  # mixed judges
        counted = "campaigns differ"
    world = _setup_value(views, "world_model")
    legacy = "legacy" in world
    return [
        {
            "key": "judge",
            "value": judge,
            "detail": f"fails on {counted}" + (" (legacy: collision only)" if legacy else ""),
        },
        {
            "key": "physics",
            "value": _setup_value(views, "physics"),
            "detail": f"world model {world}"
            + (" (before physics profiles and failure kinds)" if legacy else ""),
        },
        _perception_card(views),
    ]


def kinds_text(runs: Sequence[Any]) -> str:
    """Failures per kind, e.g. ``12 collision, 3 road departure`` (``–`` for none)."""
    counts: dict[str, int] = {}
    for run in runs:
        if run.status == "fail":
            kind = run.failure_kind or "collision"
            counts[kind] = counts.get(kind, 0) + 1
    return ", ".join(f"{n} {k.replace('_', ' ')}" for k, n in counts.items()) or "–"


def kind_rows(runs: Sequence[Any]) -> list[dict[str, str]]:
    """The failures-by-kind table: kind, failures / judged, rate with Wilson 95% CI."""
    from sitcov.analysis import failures_by_kind

    judged = sum(1 for r in runs if r.status in ("pass", "fail"))
    return [
        {
            "kind": kind.replace("_", " "),
            "fj": f"{row['failures']} / {judged}",
            "rate": rate_ci(row["failures"], judged),
        }
        for kind, row in failures_by_kind(runs).items()
    ]


def _completion(runs: Sequence[Any]) -> dict[str, Any]:
    """Route completion statistics of the judged runs (``sitcov.analysis``)."""
    from sitcov.analysis import route_completion_stats

    judged = (r for r in runs if r.status in ("pass", "fail"))
    return route_completion_stats(getattr(r, "completion", None) for r in judged)


def _completion_card(runs: Sequence[Any]) -> dict[str, Any]:
    stats = _completion(runs)
    if not stats["runs"]:
        return {"key": "route completion", "value": "n/a", "detail": "no run reports it"}
    return {
        "key": "route completion",
        "value": pct(stats["mean"]),
        "detail": f"mean; goal reached {pct(stats['goal_rate'])}, median {pct(stats['median'])}",
    }


def uncounted_rows(views: Sequence[CampaignView], runs: Sequence[Any]) -> list[dict[str, str]]:
    """Events that happened in judged runs but that the campaigns' judge does not count
    (per kind: runs with it, share of the judged runs), and collisions between two other
    road users (never the ego's failure); empty when the judges differ."""
    from sitcov.sim import FAILURE_KINDS, Judge

    judge = _setup_value(views, "judge")
    try:
        counted = set(Judge.from_spec(judge).counts)
    except ValueError:  # mixed judges
        return []
    judged = [r for r in runs if r.status in ("pass", "fail")]
    rows = []
    for kind in FAILURE_KINDS:
        if kind in counted:
            continue
        n = sum(kind in getattr(r, "events", ()) for r in judged)
        if n:
            share = pct(n / len(judged))
            rows.append({"kind": kind.replace("_", " "), "runs": str(n), "share": share})
    n = sum(getattr(r, "actor_collisions", 0) > 0 for r in judged)
    if n:
        rows.append(
            {
                "kind": "collision between two other road users (never the ego's)",
                "runs": str(n),
                "share": pct(n / len(judged)),
            }
        )
    return rows


def headline_section(hs: Any, views: Sequence[CampaignView], all_runs: Sequence[Any]) -> dict:
    """The summary cards, the failures by kind, the events the judge does not count, the
    route completion and the per-campaign table."""
    from sitcov.analysis import completion_lines, coverage

    counts = status_counts(all_runs)
    judged = counts["pass"] + counts["fail"]
    cov = coverage(hs, all_runs)
    ci = rate_ci(counts["fail"], judged).partition(" ")[2]
    cards = [
        {"key": "runs", "value": len(all_runs), "detail": f"{len(views)} campaign(s)"},
        {"key": "failures", "value": counts["fail"], "detail": f"of {judged} judged runs"},
        {
            "key": "failure rate",
            "value": pct(counts["fail"] / judged if judged else None),
            "detail": f"95% CI {ci}" if judged else "no judged runs",
        },
        {
            "key": "errors / timeouts",
            "value": f"{counts['error']} / {counts['timeout']}",
            "detail": "runs that could not be judged",
        },
        {
            "key": "bins covered",
            "value": f"{cov['bins_covered']} / {cov['bins_total']}",
            "detail": f"{len(hs.elements)} elements",
        },
        _completion_card(all_runs),
        {"key": "pairwise coverage", "value": pct(cov["pairwise"]), "detail": "2-way bins"},
        *_setup_cards(views),
    ]
    rows = []
    for view in views:
        c = status_counts(view.runs)
        s = coverage(hs, view.runs) if view.runs else None
        rows.append(
            {
                "name": view.name,
                "generator": view.generator,
                "fault": view.fault,
                "seed": view.seed,
                "runs": len(view.runs),
                "failures": c["fail"],
                "rate": rate_ci(c["fail"], c["pass"] + c["fail"]),
                "errors": c["error"],
                "timeouts": c["timeout"],
                "bins": f"{s['bins_covered']}/{s['bins_total']}" if s else "–",
                "pairwise": pct(s["pairwise"]) if s else "–",
                "kinds": kinds_text(view.runs),
                "completion": pct(_completion(view.runs)["mean"]),
                "physics": str(view.setup.get("physics", "?")),
                "judge": str(view.setup.get("judge", "?")),
            }
        )
    head, dist = completion_lines(_completion(all_runs))
    return {
        "cards": cards,
        "campaigns": rows,
        "bins_total": cov["bins_total"],
        "kinds": kind_rows(all_runs),
        "uncounted": uncounted_rows(views, all_runs),
        "completion": {"head": head, "distribution": dist},
        "perception_note": pem_note(views),
    }


def element_section(hs: Any, views: Sequence[CampaignView], fig_dir: Path) -> dict:
    """Per element: runs per bin and failure rate per bin, by (generator, fault)."""
    from sitcov.analysis import bin_stats

    groups = group_runs(views)
    stats = {key: bin_stats(hs, runs) for key, runs in groups.items()}
    generators = list(dict.fromkeys(g for g, _ in groups))
    faults = list(dict.fromkeys(f for _, f in groups))
    figures = []
    for element in hs.elements:
        name, labels = element.name, [b.label for b in element.bins]
        counts = {}
        for gen in generators:
            first = next(k for k in groups if k[0] == gen)  # NF if present: same situations
            counts[gen] = {lab: stats[first][name][lab]["generated"] for lab in labels}
        rates = {
            ("no fault" if f == NO_FAULT else f"fault {f}"): {
                g: stats[(g, f)][name] for g in generators if (g, f) in stats
            }
            for f in faults
        }
        if len(labels) > MAX_BARS:
            primary = stats[next(iter(groups))][name]
            figures += _many_bins_figures(element, primary, fig_dir)
            continue
        file = f"element_{slug(name)}.png"
        png = _figures.save(_figures.element_figure(name, labels, counts, rates), fig_dir / file)
        figures.append(
            {
                "png": b64(png),
                "alt": f"Runs and failure rate per bin of {name}",
                "caption": f"{name}: runs per bin and failure rate per bin",
                "file": f"figures/{file}",
                "wide": len(labels) > 8,
            }
        )
    series = ", ".join(generators)
    if len(faults) > 1:
        series += " (one panel per fault: " + ", ".join(faults) + ")"
    return {
        "element_figures": figures,
        "several_series": len(generators) > 1 or len(faults) > 1,
        "series_names": series,
    }


#: an element with more bins than this is drawn as its top bins and its groups
MAX_BARS = 24
#: bins shown in the top-bins figure of such an element
TOP_BARS = 25


def _rows(per_bin: dict[str, dict[str, Any]], labels: Sequence[str]) -> list[dict[str, Any]]:
    return [{"label": lab, **per_bin[lab]} for lab in labels if per_bin[lab]["judged"]]


def _many_bins_figures(element: Any, per_bin: dict[str, dict[str, Any]], fig_dir: Path) -> list:
    """An element with many bins (a derived map's situations): its bins grouped by road
    user and conflict type, and the :data:`TOP_BARS` bins with the highest failure rate
    (Wilson lower bound), each a horizontal bar chart whose height follows its rows."""
    from sitcov.analysis import wilson_interval
    from sitcov.analysis._regions import bin_group

    out = []
    groups: dict[str, list[int]] = {}
    for b in element.bins:
        s = per_bin[b.label]
        tally = groups.setdefault(bin_group(b.value), [0, 0])
        tally[0] += s["failures"]
        tally[1] += s["judged"]
    if len(groups) > 1:
        rows = []
        for group, (k, n) in groups.items():
            ci = wilson_interval(k, n)
            rows.append(
                {
                    "label": group,
                    "failures": k,
                    "judged": n,
                    "failure_rate": k / n if n else None,
                    "ci95": ci,
                }
            )
        rows.sort(key=lambda r: -(r["failure_rate"] or 0.0))
        out.append(
            _ranked_figure(
                element.name,
                "groups",
                rows,
                fig_dir,
                f"{len(element.bins)} bins in {len(rows)} groups "
                "(road-user kind and conflict type)",
            )
        )
    ranked = sorted(
        _rows(per_bin, element.labels),
        key=lambda r: (-(r["ci95"] or (0, 0))[0], -(r["failure_rate"] or 0)),
    )
    shown = ranked[:TOP_BARS]
    more = len(ranked) - len(shown)
    note = f"{len(shown)} of {len(element.bins)} bins, highest failure rate (Wilson lower bound)"
    if more:
        note += f"; and {more} more in the CSV export"
    out.append(_ranked_figure(element.name, "top bins", shown, fig_dir, note))
    return out


def _ranked_figure(name: str, what: str, rows: list, fig_dir: Path, note: str) -> dict:
    file = f"element_{slug(name)}_{slug(what)}.png"
    figure = _figures.ranked_bins_figure(f"{name}: failure rate, {what}", rows, note)
    png = _figures.save(figure, fig_dir / file)
    return {
        "png": b64(png),
        "alt": f"Failure rate of {name}, {what}",
        "caption": f"{name}: {note}",
        "file": f"figures/{file}",
        "wide": True,
    }


def growth_section(
    hs: Any, views: Sequence[CampaignView], has_nf: bool, bins_total: int, fig_dir: Path
) -> dict:
    """Coverage growth per campaign (fault replays are not drawn: same situations as NF)."""
    from sitcov.analysis import coverage_growth

    drawn = [v for v in views if v.runs and (v.fault == NO_FAULT or not has_nf)]
    note = ""
    if len(drawn) > MAX_GROWTH_LINES:
        note = f"first {MAX_GROWTH_LINES} of {len(drawn)} campaigns"
        drawn = drawn[:MAX_GROWTH_LINES]
    elif has_nf and len(drawn) < len(views):
        note = "fault campaigns replay these situations and are not drawn again"
    curves = {}
    for view in drawn:
        points = coverage_growth(hs, view.runs)
        curves[view.name] = (
            [p["bins_covered"] for p in points],
            [p["pairwise"] for p in points],
            bins_total,
        )
    png = _figures.save(_figures.growth_figure(curves), fig_dir / "coverage_growth.png")
    return {"growth_figure": b64(png), "growth_note": note}


def heat_section(
    hs: Any, runs: Sequence[Any], pair: tuple[str, str] | None, scope: str, fig_dir: Path
) -> dict:
    """The failure-rate heat map over two elements."""
    if pair is None:
        return {"heat": {"a": "", "b": "", "note": "fewer than two elements", "png": None}}
    a, b = pair
    cells = pair_table(runs, a, b)
    figure = _figures.heatmap_figure(a, hs.labels(a), b, hs.labels(b), cells)
    png = _figures.save(figure, fig_dir / "heatmap.png")
    note = f"Each cell: failures / judged runs; grey = no judged run. {scope}"
    return {"heat": {"a": a, "b": b, "png": b64(png), "note": note}}


def provenance_section(
    db: str,
    out: str,
    views: Sequence[CampaignView],
    heat: tuple[str, str] | None,
    experiment_cmd: str | None,
) -> dict:
    """Commands that recompute every number, and each campaign's stored config."""
    dbq = shlex.quote(db)
    commands = [f"sitcov summary --db {dbq} --json"]
    report = f"sitcov report --db {dbq} --out {shlex.quote(out)}"
    commands.append(report + (f" --heatmap {heat[0]},{heat[1]}" if heat else ""))
    if experiment_cmd:
        commands.append(experiment_cmd + " --json   # Table 2 (completes a partial one)")
    details = []
    if len(views) > 12:
        commands.append(f"sitcov summary --db {dbq} --campaign NAME --json   # one campaign")
    for view in views:
        if len(views) <= 12:
            name = shlex.quote(view.name)
            commands.append(f"sitcov summary --db {dbq} --campaign {name} --json")
        details.append(
            {
                "name": view.name,
                "seed": view.seed,
                "version": view.sitcov_version,
                "created": view.created,
                "tags": sorted((str(k), str(v)) for k, v in view.tags.items()),
                "config": json.dumps(view.config, indent=2, sort_keys=True, default=str),
                "command": run_command(db, view, experiment_cmd),
            }
        )
    return {"commands": commands, "campaign_details": details}
