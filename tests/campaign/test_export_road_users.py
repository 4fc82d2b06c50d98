"""Exports per road user, typed Parquet with campaign metadata, and JUnit that a parser and
a CI read: names stable across builds, messages saying what failed and what was hit, replay
lines that run as printed (issue 28)."""

from __future__ import annotations

import csv
import io
import json
import re
import shlex

import pytest
from campaign_fakes import BACKEND, GENERATOR, STACK
from cli_helpers import run_cli as sitcov
from needs import need_module
from test_breakdown_map import derived_db  # noqa: F401 - the fixture
from test_failure_kinds import judged_db  # noqa: F401 - the fixture

from sitcov.campaign import open_store
from sitcov.campaign._export import export, failure_message
from sitcov.campaign._export_actors import ACTOR_COLUMNS, RUN_COLUMNS

FAKE = ["--generator", GENERATOR, "--backend", BACKEND, "--av", STACK, "--executor", "serial"]
#: A JUnit failure message: the kind, for a collision what was hit, and when.
MESSAGE = re.compile(
    r"^(collision with \w+ \((car|truck|cyclist|pedestrian)\)( while the ego stood still)?"
    r"|road_departure|lane_departure|blocked|route_incomplete) at \d+\.\d s$"
)


def _csv(store, **kw) -> list[dict[str, str]]:
    out = io.StringIO()
    export(store, "csv", out, **kw)
    return list(csv.DictReader(io.StringIO(out.getvalue())))


def _num(text: str) -> float | None:
    return None if text == "" else float(text)


@pytest.fixture
def fake_dbs(tmp_path, capsys):
    """Two builds of the same campaign (same seed) in two databases."""
    paths = []
    for name in ("a", "b"):
        path = tmp_path / name / "c.db"
        path.parent.mkdir()
        args = ["run", "--db", str(path), *FAKE, "--runs", "40", "--seed", "3"]
        code, _, err = sitcov(capsys, *args)
        assert code == 0, err
        paths.append(path)
    return paths


# --- per road user ------------------------------------------------------------------------------


def test_run_columns_name_the_closest_and_the_hit_road_user(derived_db):  # noqa: F811
    with open_store(derived_db) as store:
        rows = _csv(store)
        runs = {r.index: r for r in store.iter_runs("d")}
    assert set(RUN_COLUMNS) <= set(rows[0])
    other_hit = 0
    for row in rows:
        run = runs[int(row["index"])]
        actors = run.outcome.metrics.get("actors") or {}
        if not actors:  # the paper's two-car scene: its one road user, the run's values
            assert row["closest_actor"] == "ov"
            assert _num(row["closest_min_distance"]) == pytest.approx(run.outcome.min_distance)
            continue
        measured = {
            n: a["min_distance"] for n, a in actors.items() if a["min_distance"] is not None
        }
        closest = row["closest_actor"]
        assert _num(row["closest_min_distance"]) == pytest.approx(min(measured.values()))
        assert measured[closest] == min(measured.values())
        assert row["closest_kind"] == actors[closest]["kind"]
        assert _num(row["closest_min_ttc"]) == actors[closest]["min_ttc"]
        if row["collision"] == "True":
            hit = row["hit_actor"]
            assert hit == run.outcome.metrics["collision_actor"] and actors[hit]["collided"]
            assert row["hit_kind"] == actors[hit]["kind"]
            assert _num(row["hit_min_ttc"]) == actors[hit]["min_ttc"]
            assert _num(row["hit_pet"]) == actors[hit]["pet"]
            # the hit road user was touched, whatever the primary's min_distance says
            assert _num(row["hit_min_distance"]) < 0.5
            other_hit += hit != "ov"
        else:
            assert row["hit_actor"] == "" and row["hit_min_distance"] == ""
    assert sum(r["collision"] == "True" for r in rows) > 0
    assert other_hit > 0, "the campaign should have a collision with a road user besides ov"


def test_run_columns_without_actors_are_the_primary_ones(fake_dbs):
    with open_store(fake_dbs[0]) as store:
        rows = _csv(store)
    for row in rows:
        assert row["closest_actor"] == "ov" and row["closest_kind"] == "car"
        assert row["closest_min_distance"] == row["min_distance"]
        assert row["closest_pet"] == row["pet"]
        assert row["hit_actor"] == ("ov" if row["collision"] == "True" else "")


def test_per_actor_table_has_one_row_per_run_and_road_user(derived_db, capsys):  # noqa: F811
    code, out, err = sitcov(
        capsys, "export", "--db", str(derived_db), "--format", "csv", "--per-actor"
    )
    assert code == 0, err
    table = list(csv.DictReader(io.StringIO(out)))
    assert list(table[0]) == list(ACTOR_COLUMNS)
    with open_store(derived_db) as store:
        runs = _csv(store)
        records = {r.index: r for r in store.iter_runs("d")}
    expected = sum(len(r.outcome.metrics.get("actors") or {"ov": 0}) for r in records.values())
    assert len(table) == expected
    for run in runs:
        mine = [t for t in table if t["index"] == run["index"]]
        assert [t["actor"] for t in mine if t["closest"] == "True"] == [run["closest_actor"]]
        hit = [t["actor"] for t in mine if t["collided"] == "True"]
        assert hit == ([run["hit_actor"]] if run["hit_actor"] else [])
        for t in mine:
            stored = (records[int(t["index"])].outcome.metrics.get("actors") or {}).get(t["actor"])
            if stored:
                assert t["kind"] == stored["kind"] and _num(t["pet"]) == stored["pet"]
    code, _, err = sitcov(
        capsys, "export", "--db", str(derived_db), "--format", "junit", "--per-actor"
    )
    assert code == 2 and "--per-actor" in err and len(err.strip().splitlines()) == 1


# --- Parquet ------------------------------------------------------------------------------------


def test_parquet_is_typed_and_names_the_campaign_setup(judged_db, derived_db, tmp_path):  # noqa: F811
    pd = need_module("pandas", "test")
    pq = need_module("pyarrow.parquet", "parquet")
    path = tmp_path / "k.parquet"
    with open_store(judged_db) as store:
        export(store, "parquet", str(path))
        info = store.campaign("k")
        rows = _csv(store)
    frame = pd.read_parquet(path)
    dtypes = frame.dtypes.astype(str).to_dict()
    for column in ("value.friction", "value.cloudiness", "min_distance", "closest_min_ttc"):
        assert dtypes[column] == "float64", column
    for column in ("collision", "aeb_fired"):
        assert dtypes[column] == "bool", column
    assert dtypes["index"] == dtypes["seed"] == "int64"
    assert frame["value.friction"].tolist() == [float(r["value.friction"]) for r in rows]
    meta = {k.decode(): v.decode() for k, v in pq.read_schema(path).metadata.items()}
    assert meta["sitcov.generator"] == info.generator
    assert meta["sitcov.judge"] == "strict" and meta["sitcov.physics"] == "carla"
    assert meta["sitcov.world_model"] == str(info.world_version)
    assert meta["sitcov.version"] == info.sitcov_version
    (campaign,) = json.loads(meta["sitcov.campaigns"])
    assert campaign["name"] == "k" and campaign["seed"] == info.config["seed"]

    actors = tmp_path / "a.parquet"
    with open_store(derived_db) as store:
        export(store, "parquet", str(actors), per_actor=True)
        export(store, "parquet", str(tmp_path / "d.parquet"))
    table = pd.read_parquet(actors).dtypes.astype(str).to_dict()
    assert table["collided"] == table["closest"] == "bool"
    assert table["min_distance"] == table["min_ttc"] == table["pet"] == "float64"
    derived = pd.read_parquet(tmp_path / "d.parquet")
    assert derived["value.friction"].dtype == "float64"
    assert isinstance(json.loads(derived["value.intsit"].iloc[0]), dict)  # a mapping: JSON


# --- JUnit --------------------------------------------------------------------------------------


def _suite(path):
    junitparser = need_module("junitparser", "test")
    xml = junitparser.JUnitXml.fromfile(str(path))
    (suite,) = list(xml)
    return suite


def _props(case) -> dict[str, str]:
    junitparser = need_module("junitparser", "test")
    (props,) = case.iterchildren(junitparser.Properties)
    return {p.name: p.value for p in props}


def test_junit_names_are_stable_and_messages_say_what_failed(fake_dbs, tmp_path, capsys):
    junitparser = need_module("junitparser", "test")
    suites = []
    for i, db in enumerate(fake_dbs):
        out = tmp_path / f"runs{i}.xml"
        code, _, err = sitcov(
            capsys, "export", "--db", str(db), "--format", "junit", "--out", str(out)
        )
        assert code == 0, err
        suites.append(_suite(out))
    names = [[(c.classname, c.name) for c in s] for s in suites]
    assert names[0] == names[1] and len(set(names[0])) == len(names[0]) == 40
    failed = 0
    for case in suites[0]:
        props = _props(case)
        assert case.name.split(" #")[0] == props["situation_id"]
        assert len(case.name) <= 24
        results = case.result
        if any(isinstance(r, junitparser.Failure) for r in results):
            (failure,) = results
            assert MESSAGE.match(failure.message), failure.message
            assert failure.message.startswith(failure.type)
            failed += 1
    assert failed == int(suites[0].failures) > 0
    # the replay line runs as printed, from anywhere: it names the database
    case = next(c for c in suites[1] if c.result)
    argv = shlex.split(_props(case)["replay"])
    assert argv[:3] == ["sitcov", "replay", "--db"] and argv[3] == str(fake_dbs[1])
    code, out, err = sitcov(capsys, *argv[1:])
    assert code == 0 and "reproduced" in out, err


def test_junit_messages_name_the_road_user_hit_and_the_departure(derived_db, judged_db, tmp_path):  # noqa: F811
    junitparser = need_module("junitparser", "test")
    seen = set()
    for db in (derived_db, judged_db):
        path = tmp_path / f"{db.stem}.xml"
        with open_store(db) as store:
            export(store, "junit", str(path))
            runs = {r.situation.id: r for r in store.iter_runs() if r.status == "fail"}
        for case in _suite(path):
            failures = [r for r in case.result if isinstance(r, junitparser.Failure)]
            if not failures:
                continue
            run = runs[_props(case)["situation_id"]]
            message = failures[0].message
            assert message == failure_message(run) and MESSAGE.match(message), message
            kind = run.failure_kind
            seen.add(kind)
            if kind in ("collision", "ego_stationary"):
                actor = run.outcome.metrics.get("collision_actor") or "ov"
                assert message.startswith(f"collision with {actor} (")
                assert message.endswith(f" at {run.outcome.collision_time:.1f} s")
            else:
                assert message == f"{kind} at {run.outcome.metrics[kind + '_time']:.1f} s"
    assert {"collision", "road_departure", "lane_departure"} <= seen


# --- flakiness ----------------------------------------------------------------------------------


def test_flakiness_replay_lines_run_as_printed(tmp_path, capsys):
    db = tmp_path / "f.db"
    args = ("experiment", "flakiness", "--db", str(db), "--situations", "20", "--repeats", "2",
            "--backend", BACKEND, "--av", STACK, "--executor", "serial")  # fmt: skip
    code, out, err = sitcov(capsys, *args)
    assert code == 0, err
    lines = [ln.split(None, 1)[1] for ln in out.splitlines() if "sitcov replay" in ln]
    assert lines, out
    argv = shlex.split(lines[0])
    assert argv[:4] == ["sitcov", "replay", "--db", str(db)]
    code, out, err = sitcov(capsys, *argv[1:])
    assert code == 0 and "reproduced" in out, err
