"""benchmarks/bench_faults.py, whose numbers docs/embedded.md quotes: a derived hyperspace runs
on its own map, F4 changes nothing where no pedestrian exists, the blind-ego check counts."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest
from benchmark_modules import load_benchmark

from sitcov.hyperspace import load_hyperspace

ROOT = Path(__file__).resolve().parents[1]
DERIVED = ROOT / "sitcov/hyperspace/data/derived"


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_benchmark("bench_faults")


def test_a_derived_hyperspace_runs_on_its_map(bench) -> None:
    assert (
        bench.make_backend(load_hyperspace(str(DERIVED / "merge.yaml")), None).map.name == "merge"
    )
    paper = bench.make_backend(load_hyperspace(None), 8.0)
    assert paper.map.name == "t-junction" and paper.adversary.switch_distance == 8.0


def _person_seen(bench, situation) -> bool:
    """Whether a road user of the scene is reported as a ``person`` by the PEM: a
    pedestrian, or a cyclist (its detection is its rider, docs/pem.md)."""
    from sitcov.perception._detector import PEM_LABELS

    kinds = bench.scene_kinds(situation)
    return any(PEM_LABELS.get(kind, ("car",))[0] == "person" for kind in kinds)


def test_f4_fails_like_no_fault_wherever_no_person_is_seen(bench) -> None:
    """Fault f4 (the AEB ignores ``person`` boxes) changes no verdict of a scene in which
    the PEM reports no road user as a person."""
    # 40 situations: three scenes without a pedestrian or a cyclist (12 drew none)
    table, situations = bench.measure(40, 0, hyperspace=str(DERIVED / "t-junction.yaml"))
    assert set(table) == {"NF", "f1", "f1-raw", "f2", "f3", "f4"}
    without = [i for i, s in enumerate(situations) if not _person_seen(bench, s)]
    assert without and len(without) < len(situations)  # both kinds of scene were drawn
    assert [table["f4"][i] for i in without] == [table["NF"][i] for i in without]


def test_the_blind_ego_check_counts_every_bin_and_seed(bench, capsys) -> None:
    bench.blind_check(str(DERIVED / "merge.yaml"), 2, None)
    out = capsys.readouterr().out
    assert out.startswith("blind ego hit in 10 of 10 clear-weather runs (5 situations x 2 seeds)")
