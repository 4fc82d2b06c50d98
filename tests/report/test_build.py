"""The HTML report: content computed from stored runs, self-contained, escaped, fast.

Building a report draws about a dozen figures, so one report of a 1,000-run database is built
once per module and several tests inspect it.
"""

from __future__ import annotations

import re
import time
from pathlib import Path

import pytest
from report_fakes import add_campaign

from sitcov.campaign import open_store
from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.report import build_report

EVIL = "<script>alert('x')</script>"


def _cards(html: str) -> dict[str, str]:
    return dict(re.findall(r'<div class="k">([^<]+)</div><div class="v">([^<]+)</div>', html))


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """A 1,000-run store (two generators, one campaign with a hostile name) and its report."""
    root = tmp_path_factory.mktemp("report")
    db = root / "two.db"
    store = open_store(db)
    try:
        add_campaign(store, "rand", 500, seed=1, generator="random")
        add_campaign(store, EVIL, 500, seed=2, generator="sitcov", tags={"note": EVIL})
        statuses = [r.status for r in store.runs()]
    finally:
        store.close()
    start = time.perf_counter()
    index = build_report(db, root / "out", pictures=0)
    elapsed = time.perf_counter() - start
    return {
        "db": db,
        "out": root / "out",
        "html": index.read_text(),
        "statuses": statuses,
        "elapsed": elapsed,
    }


def test_report_is_self_contained(built):
    html = built["html"]
    assert not re.search(r"""(src|href)\s*=\s*["'](https?:|//|file:)""", html)
    assert "<link" not in html and "@import" not in html
    figures = {p.name for p in (built["out"] / "figures").iterdir()}
    for name in ("cloudiness", "friction", "intsit"):
        assert f"element_{name}.png" in figures
    assert {"coverage_growth.png", "heatmap.png"} <= figures
    embedded = html.count('src="data:image/png;base64,')
    assert embedded == len([f for f in figures if f.endswith(".png")]) == 12  # + criticality


def test_headline_numbers_are_the_stored_ones(built):
    statuses = built["statuses"]
    fails, passes = statuses.count("fail"), statuses.count("pass")
    assert fails > 0 and statuses.count("error") > 0
    cards = _cards(built["html"])
    assert cards["runs"] == "1000"
    assert cards["failures"] == str(fails)
    assert cards["failure rate"] == f"{100 * fails / (fails + passes):.1f}%"
    assert cards["errors / timeouts"] == f"{statuses.count('error')} / 0"
    assert cards["bins covered"] == "60 / 60"


def test_generators_compared_and_provenance_given(built):
    html = built["html"]
    compared = re.search(r"Series are compared side by side: ([^.<]+)\.", html).group(1)
    assert sorted(compared.split(", ")) == ["random", "sitcov"]
    assert f"sitcov summary --db {built['db']} --json" in html
    assert "sitcov run --db" in html and "--generator random" in html
    assert 'id="table2"' not in html  # no fault experiment stored


def test_worst_bins_rank_the_synthetic_weak_spot_first(built):
    worst = built["html"].split("<h3>Bins</h3>", 1)[1].split("</table>", 1)[0]
    first_row = re.search(r"<tr><td>([^<]+)</td><td>([^<]+)</td>", worst)
    # the synthetic judge fails low-friction runs with p >= 0.6: they must top the ranking
    assert first_row.groups() in {("friction", "0.1"), ("friction", "0.2")}


def test_user_names_are_escaped(built):
    html = built["html"]
    assert "<script" not in html
    assert "&lt;script&gt;alert(" in html


def test_thousand_run_report_is_fast(built):
    # a few seconds on an idle machine; generous bound for a loaded 2-core CI runner
    assert built["elapsed"] < 20.0, f"1,000-run report took {built['elapsed']:.1f} s"


def test_table2_shown_when_experiment_stored(make_db, tmp_path):
    def build(store):
        plan = add_campaign(
            store,
            "faults/random/s0/NF",
            30,
            seed=0,
            tags={"experiment": "faults", "generator": "random", "seed": 0, "fault": "NF"},
        )
        for label in ("F1", "F2", "F3"):
            add_campaign(
                store,
                f"faults/random/s0/{label}",
                30,
                seed=10 + int(label[1]),
                fault=label.lower(),
                situations=plan,
                tags={"experiment": "faults", "generator": "random", "seed": 0, "fault": label},
            )

    db = make_db("t2.db", build)
    html = build_report(db, tmp_path / "out", pictures=0).read_text()
    assert 'id="table2"' in html
    assert (tmp_path / "out" / "figures" / "table2.png").is_file()
    assert "one panel per fault: NF, F1, F2, F3" in html
    section = html.split('id="table2"', 1)[1].split("</table>", 1)[0]
    assert len(re.findall(r"<td>F[123]</td>", section)) == 3


def test_cli_report_selects_campaigns_and_heatmap(make_db, tmp_path, capsys):
    def build(store):
        add_campaign(store, "rand", 40, seed=1, generator="random")
        add_campaign(store, "cov", 30, seed=2, generator="sitcov")

    db = make_db("two.db", build)
    out = tmp_path / "cli"
    main(
        [
            "report",
            "--db",
            str(db),
            "--out",
            str(out),
            "--pictures",
            "0",
            "--campaign",
            "cov",
            "--heatmap",
            "fog_density,wetness",
        ]
    )
    assert "report written" in capsys.readouterr().out
    html = (out / "index.html").read_text()
    assert _cards(html)["runs"] == "30"
    assert "Failure rate over fog_density &times; wetness" in html
    assert "<td>rand</td>" not in html


@pytest.mark.parametrize(
    "kwargs, needle",
    [({"campaigns": ["nope"]}, "nope"), ({"heatmap": ("intsit", "altitude")}, "altitude")],
)
def test_bad_arguments_raise_config_errors(make_db, tmp_path, kwargs, needle):
    db = make_db("one.db", lambda s: add_campaign(s, "c", 10, seed=1))
    with pytest.raises(ConfigError, match=needle):
        build_report(db, tmp_path / "out", pictures=0, **kwargs)


def test_missing_database_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="missing.db"):
        build_report(tmp_path / "missing.db", tmp_path / "out")
    assert not (tmp_path / "missing.db").exists()


def test_cli_report_bad_heatmap_is_one_line_error(make_db, tmp_path, capsys):
    db = make_db("one.db", lambda s: add_campaign(s, "c", 5, seed=1))
    with pytest.raises(SystemExit) as exc:
        main(["report", "--db", str(db), "--out", str(tmp_path / "o"), "--heatmap", "intsit"])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert "--heatmap" in err and "Traceback" not in err


def test_failing_runs_are_drawn_from_a_real_campaign(tmp_path):
    """Top-down pictures: runs without stored traces are re-simulated from situation+seed."""
    from sitcov.campaign import CampaignConfig, run_campaign

    db = tmp_path / "real.db"
    store = open_store(db)
    try:
        config = CampaignConfig(
            name="real",
            generator="random",
            runs=12,
            seed=3,
            fault="f1",
            executor="serial",
            workers=1,
        )
        run_campaign(config, store)
        failing = [r for r in store.runs() if r.status == "fail"]
    finally:
        store.close()
    assert failing, "f1 at seed 3 should give at least one failure in 12 runs"
    html = build_report(db, tmp_path / "out", pictures=2).read_text()
    section = html.split('id="failures"', 1)[1]
    shown = re.findall(r"<b>(real:\d+)</b>", section)
    assert 1 <= len(shown) <= 2
    assert all(f"sitcov replay --db {db} {ref}" in section for ref in shown)
    assert all(
        Path(tmp_path / "out" / "figures" / f"failure_{ref.replace(':', '_')}.png").is_file()
        for ref in shown
    )


def test_the_perception_card_says_what_the_stack_was_shown(built):
    """A PEM campaign's summary names the PEM and, under the cards, its known side bias
    with the way to check it in camera mode; camera, CARLA and mixed campaigns say
    theirs, and only a campaign on the PEM gets the note."""
    from sitcov.report._data import CampaignView
    from sitcov.report._sections import PERCEPTION_DETAIL, _perception_card, headline_section

    assert _cards(built["html"])["perception"] == "pem"
    note = re.findall(r'<p class="note">(Perception was the PEM[^<]+)</p>', built["html"])
    assert len(note) == 1 and "from the left" in note[0] and "--perception camera" in note[0]

    def view(**config):
        return CampaignView(name="c", config=config, tags={}, hyperspace=None)

    camera = view(backend="embedded", backend_options={"perception": "camera"})
    assert _perception_card([camera]) == {
        "key": "perception",
        "value": "camera",
        "detail": PERCEPTION_DETAIL["camera"],
    }
    assert _perception_card([view(backend="carla")])["detail"] == "the simulator's own camera"
    mixed = _perception_card([camera, view(backend="esmini")])
    assert mixed["value"] == "mixed: camera, pem" and "differ" in mixed["detail"]
    hs = load_hyperspace()
    assert headline_section(hs, [camera], [])["perception_note"] == ""
    assert headline_section(hs, [camera, view()], [])["perception_note"].startswith("Percep")


def test_the_pem_note_says_whether_verdicts_are_single_draws_or_majorities():
    """A PEM campaign of single runs is told its verdicts are draws and how to get
    majorities; one run with --perception-draws is told what its verdicts are, on the card
    too; a camera campaign gets neither."""
    from sitcov.report._data import CampaignView
    from sitcov.report._sections import _perception_card, pem_note

    def view(**config):
        return CampaignView(name="c", config=config, tags={}, hyperspace=None)

    single = pem_note([view()])
    assert "--perception-draws" in single and "one draw" in single
    majority = pem_note([view(perception_draws=9)])
    assert "majority of 9 perception draws" in majority and "--perception-draws" not in majority
    assert single.startswith("Perception was the PEM") and majority.startswith("Perception")
    assert "9 perception draws" in _perception_card([view(perception_draws=9)])["detail"]
    assert "draws" not in _perception_card([view()])["detail"]
    assert pem_note([view(backend_options={"perception": "camera"}, perception_draws=3)]) == ""


def test_a_failing_run_of_a_draws_campaign_says_how_many_draws_failed(tmp_path):
    """Under a failure's picture: in how many of its perception draws the world failed
    (the stored run's metrics), so a marginal failure reads apart from a firm one."""
    from sitcov.campaign import CampaignConfig, open_store, run_campaign
    from sitcov.report import build_report

    db = tmp_path / "d.db"
    store = open_store(db)
    try:
        run_campaign(CampaignConfig(runs=12, seed=1, perception_draws=3, executor="serial",
                                    workers=1), store)  # fmt: skip
        failing = [r for r in store.runs() if r.status == "fail"]
    finally:
        store.close()
    assert failing, "12 runs of the default campaign should fail at least once"
    html = build_report(db, tmp_path / "out", pictures=3).read_text()
    section = html.split('id="failures"', 1)[1]
    found = re.findall(r"failed in ([0-9]) of 3 perception draws", section)
    assert found and all(int(k) >= 2 for k in found)  # a stored failure is a majority's
