"""Non-finite numbers survive the store (issue 26): stored as the strings of
``sitcov.campaign._json``, read back as floats, and every stored cell is JSON that SQLite's
JSON functions accept; files written before with bare ``Infinity`` tokens are repaired."""

from __future__ import annotations

import math
import sqlite3
from contextlib import closing
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from sitcov.campaign import CampaignInfo, PlannedRun, StoreError, _json, open_store
from sitcov.campaign._sqlite import SCHEMA_VERSION
from sitcov.campaign._summary import summarize_store
from sitcov.generation import make_generator
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim import Outcome

JSON_CELLS = {
    "campaigns": ("config", "hyperspace", "generator_state", "tags"),
    "runs": ("bins", "vals", "outcome", "trace"),
}


def _info(name: str = "c") -> CampaignInfo:
    return CampaignInfo(
        name=name,
        config={"name": name, "runs": 4, "generator": "random", "limit": math.inf},
        hyperspace=load_hyperspace().to_dict(),
        sitcov_version="0.1.0",
        created="2026-01-01T00:00:00+00:00",
        generator="random",
        generator_state={"best": -math.inf, "counts": [1, 2]},
    )


def _sit(i: int) -> Situation:
    """A situation of the shipped hyperspace (the summary bins by it)."""
    return make_generator("random", load_hyperspace()).ask(np.random.default_rng(i))


def _never_conflicts(i: int) -> Outcome:
    """What the embedded world reports for a pair that never conflicts."""
    return Outcome(
        status="pass",
        end_reason="goal",
        sim_time=10.0,
        min_distance=3.0,
        min_ttc=math.inf,
        metrics={"ego_gap_at_switch": math.inf, "spread": math.nan, "gaps": [1.0, -math.inf]},
    )


def _same(a: object, b: object) -> bool:
    """Equality where NaN equals NaN (nested dicts and lists)."""
    if isinstance(a, float) and isinstance(b, float):
        return (math.isnan(a) and math.isnan(b)) or a == b
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    if isinstance(a, list | tuple) and isinstance(b, list | tuple):
        return len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b, strict=True))
    return a == b


def _all_cells_valid(db: Path) -> None:
    with closing(sqlite3.connect(db)) as con, con:
        for table, columns in JSON_CELLS.items():
            for column in columns:
                bad = con.execute(
                    f"SELECT count(*) FROM {table} WHERE {column} IS NOT NULL "
                    f"AND NOT json_valid({column})"
                ).fetchone()[0]
                assert bad == 0, f"{table}.{column}: {bad} cells SQLite cannot read"


@pytest.mark.parametrize("kind", ["sqlite", "memory"])
def test_inf_and_nan_round_trip(tmp_path: Path, kind: str) -> None:
    db = tmp_path / "c.db"
    store = open_store(db if kind == "sqlite" else None)
    store.create_campaign(_info(), [PlannedRun(i, _sit(i), 10 + i) for i in range(3)])
    for i in range(3):
        store.record_result("c", i, _never_conflicts(i), 0.5)
    back = store.get_run("c", 1).outcome
    assert back == _never_conflicts(1) or _same(back.to_dict(), _never_conflicts(1).to_dict())
    assert back.metrics["ego_gap_at_switch"] == math.inf and math.isnan(back.metrics["spread"])
    assert back.min_ttc == math.inf and back.metrics["gaps"] == [1.0, -math.inf]
    info = store.campaign("c")
    assert info.config["limit"] == math.inf and info.generator_state["best"] == -math.inf
    summary = summarize_store(store, "c")  # the SQL of the summary reads every cell
    assert summary["runs"] == 3
    store.close()
    if kind == "sqlite":
        _all_cells_valid(db)
        with closing(sqlite3.connect(db)) as con, con:
            gap = con.execute(
                "SELECT json_extract(outcome, '$.metrics.ego_gap_at_switch') FROM runs"
            ).fetchall()
        assert gap == [("Infinity",)] * 3  # the documented stored form


def test_the_stored_form_is_strict_json_and_finite_values_are_written_as_before() -> None:
    value = {"a": [1.5, math.inf, -math.inf, math.nan], "b": "text", "c": None}
    text = _json.dumps(value)
    assert _json.is_strict(text) and "Infinity" in text
    assert _same(_json.loads(text), value)
    finite = {"a": [1.5, 2], "b": {"c": 0.1 + 0.2}}
    import json

    assert _json.dumps(finite) == json.dumps(finite)
    assert _json.loads('{"a": Infinity, "b": NaN}')["a"] == math.inf  # old bare tokens read


_FLOATS = st.one_of(
    st.none(),
    st.sampled_from([math.inf, -math.inf, math.nan]),
    st.floats(allow_nan=True, allow_infinity=True),
)
_METRIC = st.recursive(
    _FLOATS | st.integers(-(2**53), 2**53) | st.booleans() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=5), inner, max_size=3)
    ),
    max_leaves=8,
)
_OUTCOMES = st.builds(
    Outcome,
    status=st.sampled_from(["pass", "fail", "error", "timeout"]),
    end_reason=st.sampled_from(["goal", "collision", "stopped", "error", "wall_timeout"]),
    sim_time=st.floats(allow_nan=True, allow_infinity=True),
    collision=st.booleans(),
    collision_time=_FLOATS,
    collision_speed=_FLOATS,
    min_distance=_FLOATS,
    min_ttc=_FLOATS,
    pet=_FLOATS,
    aeb_fired=st.booleans(),
    aeb_time=_FLOATS,
    message=st.none() | st.text(max_size=20).filter(lambda t: t not in _json.NON_FINITE),
    metrics=st.dictionaries(st.text(max_size=6), _METRIC, max_size=4),
)


@settings(
    max_examples=60, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(outcomes=st.lists(_OUTCOMES, min_size=1, max_size=4))
def test_every_outcome_survives_the_store(tmp_path_factory, outcomes: list[Outcome]) -> None:
    """Property: any outcome of the schema, non-finite values anywhere, reads back equal
    (NaN equal to NaN; a metric text equal to a non-finite marker is the documented
    exception), and SQLite's JSON functions accept every stored cell."""
    db = tmp_path_factory.mktemp("prop") / "c.db"
    store = open_store(db)
    store.create_campaign(_info(), [PlannedRun(i, _sit(i), i) for i in range(len(outcomes))])
    for i, out in enumerate(outcomes):
        store.record_result("c", i, out, 0.1)
    for i, out in enumerate(outcomes):
        back = store.get_run("c", i).outcome
        want = _json.loads(_json.dumps(out.to_dict()))  # marker texts read as floats
        assert _same(back.to_dict(), want)
        assert _same(want["metrics"], out.metrics) or _has_marker_text(out.metrics)
    summarize_store(store, "c")
    store.close()
    _all_cells_valid(db)


def _has_marker_text(obj: object) -> bool:
    if isinstance(obj, str):
        return obj in _json.NON_FINITE
    if isinstance(obj, dict):
        return any(_has_marker_text(k) or _has_marker_text(v) for k, v in obj.items())
    if isinstance(obj, list):
        return any(_has_marker_text(v) for v in obj)
    return False


def _old_file(db: Path) -> None:
    """A version-3 file as sitcov wrote it before: bare ``Infinity``/``NaN`` tokens."""
    store = open_store(db)
    store.create_campaign(_info(), [PlannedRun(i, _sit(i), i) for i in range(3)])
    for i in range(3):
        store.record_result("c", i, _never_conflicts(i), 0.5)
    store.close()
    with closing(sqlite3.connect(db)) as con, con:
        for table, columns in JSON_CELLS.items():
            for column in columns:
                con.execute(
                    f"UPDATE {table} SET {column} = replace(replace(replace({column}, "
                    "'\"-Infinity\"', '-Infinity'), '\"Infinity\"', 'Infinity'), "
                    "'\"NaN\"', 'NaN')"
                )
        con.execute("UPDATE schema_version SET version = 3")
        assert (
            con.execute("SELECT count(*) FROM runs WHERE NOT json_valid(outcome)").fetchone()[0]
            == 3
        )


def test_an_old_file_with_bare_infinity_is_repaired_when_opened(tmp_path: Path) -> None:
    db = tmp_path / "old.db"
    _old_file(db)
    store = open_store(db)
    assert store.schema_version() == SCHEMA_VERSION == 5
    assert store.get_run("c", 0).outcome.metrics["ego_gap_at_switch"] == math.inf
    assert summarize_store(store, "c")["runs"] == 3
    store.close()
    _all_cells_valid(db)


def test_a_damaged_old_file_is_refused_unchanged(tmp_path: Path) -> None:
    db = tmp_path / "old.db"
    _old_file(db)
    with closing(sqlite3.connect(db)) as con:  # a WAL file, as sitcov writes them
        root = con.execute("SELECT rootpage FROM sqlite_master WHERE name = 'runs'").fetchone()[0]
    assert not Path(f"{db}-wal").exists()  # the last close checkpointed: the file is all
    raw = bytearray(db.read_bytes())
    page = 4096
    start = (root - 1) * page
    raw[start : start + 100] = b"\xff" * 100  # scribble over the runs table's b-tree page
    db.write_bytes(bytes(raw))
    before = db.read_bytes()
    with pytest.raises(StoreError, match="damaged database|not a sitcov database"):
        open_store(db)
    assert db.read_bytes() == before


def test_json_export_of_non_finite_values_is_strict_json(tmp_path: Path) -> None:
    import io
    import json

    from sitcov.campaign._export import export

    store = open_store(tmp_path / "c.db")
    store.create_campaign(_info(), [PlannedRun(0, _sit(0), 1)])
    store.record_result("c", 0, _never_conflicts(0), 0.5)
    out = io.StringIO()
    export(store, "json", out)
    data = json.loads(out.getvalue(), parse_constant=lambda token: pytest.fail(token))
    assert data["runs"][0]["outcome"]["metrics"]["ego_gap_at_switch"] == "Infinity"


def test_a_read_only_old_file_is_read_without_repair(tmp_path: Path) -> None:
    """A version-3 file that cannot be written is read as it is (the repair is data only):
    every run decodes, bare tokens included; it is repaired when next opened writable."""
    from test_reliability_store import read_only_copy

    source = tmp_path / "old.db"
    _old_file(source)
    with read_only_copy(source, tmp_path / "ro") as path:
        store = open_store(path)
        assert store.schema_version() == 3
        assert store.get_run("c", 0).outcome.metrics["ego_gap_at_switch"] == math.inf
        store.close()
