"""Pooling agreement rows files: per stack, and split by a hyperspace element's bins."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from scipy.stats import binomtest

from sitcov.campaign import _agreement as ag
from sitcov.cli import main
from sitcov.errors import ConfigError
from sitcov.sim import WORLD_MODEL_VERSION

DATA = Path(__file__).parents[2] / "docs" / "data"
THRESHOLD07 = "examples.aeb_stacks:Threshold07"


def row(seed: int, index: int, perception: str, failed: bool, stack: str) -> dict:
    """A judged rows-file row of stream A."""
    return {
        "seed": seed, "index": index, "situation_id": f"s{seed}-{index}",
        "perception": perception, "stream": "A", "run_seed": 1000 * seed + index,
        "status": "fail" if failed else "pass", "failed": failed, "aeb_time": None,
        "cpu_s": 0.1, "wall_s": 0.1, "stack": stack, "world_model": WORLD_MODEL_VERSION,
        "judge": ag.DEFAULT_JUDGE,
    }  # fmt: skip


def test_pool_keeps_each_stacks_pairs_apart(tmp_path: Path) -> None:
    """Two stacks in one file: the reference agrees everywhere, the other nowhere. Pooled
    per stack, each keeps its own agreement (mixed, a stack's rows would stand in for
    the other's)."""
    rows = [row(3, i, p, p == "camera", "reference") for i in range(20) for p in ("camera", "pem")]
    rows = [{**r, "failed": True, "status": "fail"} for r in rows]
    rows += [row(3, i, p, p == "camera", "other") for i in range(20) for p in ("camera", "pem")]
    ag.write_rows(tmp_path / "rows.csv", rows)
    pooled = ag.pool_rows_files([tmp_path / "rows.csv"], ["pem-camera-shared-seed"])
    got = {name: e["pairs"]["pem-camera-shared-seed"] for name, e in pooled["stacks"].items()}
    assert got["reference"]["agreement"] == 1.0 and got["reference"]["n"] == 20
    assert got["other"]["agreement"] == 0.0 and got["other"]["a_fails_b_passes"] == 20
    assert pooled["pairs"] == pooled["stacks"]["reference"]["pairs"]  # the first stack's
    pair = ["pem-camera-shared-seed"]
    only = ag.pool_rows_files([tmp_path / "rows.csv"], pair, stacks=["other"])
    assert list(only["stacks"]) == ["other"] and only["pairs"][pair[0]]["agree"] == 0
    with pytest.raises(ConfigError, match="--stack: expected a stack of the rows files"):
        ag.pool_rows_files([tmp_path / "rows.csv"], ["pem-pem"], stacks=["nowhere"])
    # the same run twice is refused per stack: one stack's rows in two files
    ag.write_rows(tmp_path / "again.csv", [r for r in rows if r["stack"] == "other"])
    with pytest.raises(ConfigError, match="the same run twice"):
        ag.pool_rows_files([tmp_path / "rows.csv", tmp_path / "again.csv"], ["pem-pem"])


def test_split_by_a_bin_counts_each_situation_once_and_tests_its_disagreements(
    tmp_path: Path,
) -> None:
    """The camera fails every situation, the PEM only those of one route: that route
    agrees fully (McNemar p 1), every other route's disagreements all go one way."""
    keys = [(3, i) for i in range(60)]
    groups = ag.situation_groups(keys, "intsit")
    chosen = groups[3, 0]
    rows = [row(s, i, "camera", True, "reference") for s, i in keys]
    rows += [row(s, i, "pem", groups[s, i] == chosen, "reference") for s, i in keys]
    cells = ag.split_agreement(rows, "pem-camera-shared-seed", groups)
    assert sum(c["n"] for c in cells.values()) == 60
    assert set(cells) == set(groups.values())
    assert cells[chosen]["agreement"] == 1.0 and cells[chosen]["p"] == 1.0
    for label, cell in cells.items():
        if label != chosen:
            assert cell["a_fails_b_passes"] == cell["n"] and cell["b_fails_a_passes"] == 0
            assert cell["p"] == pytest.approx(binomtest(cell["n"], cell["n"]).pvalue, abs=1e-6)
        assert cell["p"] <= cell["q"] <= 1.0  # Benjamini-Hochberg never lowers a p-value
    labels = list(cells)
    assert labels == sorted(labels, key=lambda x: int(x.split("-")[1]))  # IntSit-2 before -10
    sides = ag.situation_groups(keys, "approach")
    assert set(sides.values()) <= {"left", "right", "ahead"}
    with pytest.raises(ConfigError, match="--by: expected approach or an element"):
        ag.situation_groups(keys, "colour")


def test_the_threshold07_stacks_held_out_routes(capsys) -> None:
    """docs/pem.md's route table: the threshold-0.7 stack on seeds 11-13 (750 held-out
    situations) agrees on 629; the PEM fails IntSit-1 alone in 21 situations, the camera
    IntSit-3 alone in 17, both significant after the adjustment."""
    files = [str(DATA / "agreement-stacks-seed11-250-default-judge.csv"),
             str(DATA / "agreement-threshold07-seeds12-13-250-default-judge.csv")]  # fmt: skip
    main(["experiment", "agreement-pool", *files, "--pairs", "pem-camera-shared-seed",
          "--stack", THRESHOLD07, "--by", "intsit", "--json"])  # fmt: skip
    pooled = json.loads(capsys.readouterr().out)
    assert list(pooled["stacks"]) == [THRESHOLD07]
    whole = pooled["pairs"]["pem-camera-shared-seed"]
    assert (whole["n"], whole["agree"]) == (750, 629)
    routes = pooled["stacks"][THRESHOLD07]["by"]["pem-camera-shared-seed"]
    assert sum(c["agree"] for c in routes.values()) == 629
    one, three = routes["IntSit-1"], routes["IntSit-3"]
    assert (one["n"], one["a_fails_b_passes"], one["b_fails_a_passes"]) == (72, 1, 21)
    assert (three["n"], three["a_fails_b_passes"], three["b_fails_a_passes"]) == (70, 17, 1)
    assert one["q"] < 0.05 and three["q"] < 0.05
    flagged = sorted(label for label, c in routes.items() if c["q"] < 0.05)
    assert flagged == ["IntSit-1", "IntSit-10", "IntSit-3", "IntSit-8"]
    main(["experiment", "agreement-pool", *files, "--pairs", "pem-camera-shared-seed",
          "--stack", THRESHOLD07, "--by", "intsit"])  # fmt: skip
    out = capsys.readouterr().out
    assert f"== stack {THRESHOLD07}" in out and "intsit IntSit-1 " in out and "McNemar p" in out
