"""Build the self-contained HTML report of a campaign store.

``build_report(db, out)`` writes ``out/index.html`` (inline CSS, figures embedded as base64 PNG,
no scripts, no external resources) and the same figures as files in ``out/figures/``. All
user-provided text (campaign names, tags, element names, labels, configs) goes through
jinja2's autoescaping.
"""

from __future__ import annotations

from collections.abc import Sequence
from importlib.resources import files
from pathlib import Path

from sitcov.errors import ConfigError
from sitcov.report import _sections as sec
from sitcov.report._breakdown_section import breakdown_section
from sitcov.report._criticality_section import criticality_section
from sitcov.report._data import NO_FAULT, load_campaigns
from sitcov.report._explain_section import explain_section
from sitcov.report._pictures import failure_pictures

#: Element pair of the default heat map (the paper's two most telling elements).
DEFAULT_HEATMAP = ("intsit", "friction")
#: Rows of the worst-bins and worst-combinations tables.
TOP = 10
#: A bin or pair needs this many judged runs to be ranked (fewer say too little).
MIN_JUDGED = 10


def _heat_pair(names: Sequence[str], heatmap: tuple[str, str] | None) -> tuple[str, str] | None:
    if heatmap is None:
        if all(e in names for e in DEFAULT_HEATMAP):
            return DEFAULT_HEATMAP
        return (names[0], names[1]) if len(names) >= 2 else None
    for element in heatmap:
        if element not in names:
            raise ConfigError(
                field="--heatmap", value=element, expected="one of " + ", ".join(names)
            )
    return heatmap


def build_report(
    db_path: str | Path,
    out_dir: str | Path,
    *,
    campaigns: Sequence[str] | None = None,
    heatmap: tuple[str, str] | None = None,
    pictures: int = 4,
) -> Path:
    """Write the HTML report of the store at ``db_path`` into ``out_dir``.

    Args:
        db_path: the SQLite campaign store.
        out_dir: directory for ``index.html`` and ``figures/`` (created if needed).
        campaigns: only these campaigns (default: all).
        heatmap: the two elements of the heat map (default intsit × friction, or the first
            two elements of the hyperspace if those are absent).
        pictures: how many failing runs to draw top-down (0 for none).

    Returns:
        The path of ``index.html``.

    Raises:
        ConfigError: no such database, no campaigns, unknown campaign or element.
    """
    import jinja2

    from sitcov._version import __version__
    from sitcov.analysis import worst_bins, worst_pairs
    from sitcov.campaign import fault_table, open_store

    db = Path(db_path)
    if not db.is_file():
        raise ConfigError(field="--db", value=str(db), expected="an existing sitcov database")
    out = Path(out_dir)
    store = open_store(db)
    try:
        views = load_campaigns(store, campaigns)
        if not views:
            raise ConfigError(f"{db}: the database holds no campaigns")
        hs = sec.hyperspace_of(views)
        pair = _heat_pair(hs.element_names, heatmap)
        fig_dir = out / "figures"
        fig_dir.mkdir(parents=True, exist_ok=True)

        all_runs = [r for v in views for r in v.runs]
        # with seeded faults stored, bin-level findings use the no-fault runs only
        has_nf = any(v.fault == NO_FAULT for v in views)
        primary = [r for v in views if v.fault == NO_FAULT or not has_nf for r in v.runs]
        faulted = len(primary) < len(all_runs)
        scope = "Computed over the runs without a seeded fault." if faulted else ""
        experiment = {}
        if any(v.is_fault_experiment for v in views):
            experiment = fault_table(store)["generators"]
        experiment_cmd = sec.experiment_command(str(db), experiment)

        page = sec.headline_section(hs, views, all_runs)
        page.update(breakdown_section(hs, primary, scope))
        page.update(sec.element_section(hs, views, fig_dir))
        page.update(sec.growth_section(hs, views, has_nf, page["bins_total"], fig_dir))
        page.update(sec.heat_section(hs, primary, pair, scope, fig_dir))
        page.update(explain_section(hs, primary, scope))
        primary_names = list(dict.fromkeys(r.campaign for r in primary))
        page.update(criticality_section(store, str(db), primary_names, fig_dir))
        page.update(sec.provenance_section(str(db), str(out), views, pair, experiment_cmd))
        page["pictures"], page["picture_note"] = failure_pictures(
            store, str(db), primary, fig_dir, pictures
        )
        page.update(
            title=db.name,
            db=str(db),
            version=__version__,
            n_campaigns=len(views),
            n_runs=len(all_runs),
            scope_note="Headline numbers pool every run of the campaigns listed below"
            + (", including runs with seeded faults." if faulted else "."),
            scope_primary=scope,
            table2=sec.table2_section(experiment, fig_dir),
            worst_bins=sec.ranked_rows(worst_bins(hs, primary, min_judged=MIN_JUDGED, top=TOP)),
            worst_pairs=sec.ranked_rows(
                worst_pairs(hs, primary, min_judged=MIN_JUDGED, top=TOP, beyond_bins=True)
            ),
            min_judged=MIN_JUDGED,
        )
    finally:
        store.close()
    env = jinja2.Environment(autoescape=True, undefined=jinja2.StrictUndefined)
    template = env.from_string(
        files("sitcov.report").joinpath("index.html.j2").read_text(encoding="utf-8")
    )
    index = out / "index.html"
    index.write_text(template.render(**page), encoding="utf-8")
    return index
