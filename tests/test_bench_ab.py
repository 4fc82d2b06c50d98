"""benchmarks/bench_ab.py, whose paired ratios docs/embedded.md quotes: both trees run the
same batches, the order alternates, and a real worker answers CPU times."""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import pytest
from benchmark_modules import load_benchmark

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def bench_ab() -> ModuleType:
    return load_benchmark("bench_ab")


class FakeTree:
    """Records the batches asked of it and the order of the asks; runs at ``speed`` runs/s."""

    calls: list[tuple[str, int, int]] = []

    def __init__(self, name: str, speed: float) -> None:
        self.name, self.speed, self.rates = name, speed, []

    def batch(self, lo: int, hi: int) -> float:
        FakeTree.calls.append((self.name, lo, hi))
        self.rates.append(self.speed)
        return self.speed


def test_both_trees_run_the_same_batches_in_alternating_order(bench_ab) -> None:
    FakeTree.calls = []
    a, b = FakeTree("a", 100.0), FakeTree("b", 150.0)
    ratios = bench_ab.compare(a, b, runs=25, batch=10, rounds=4)
    assert ratios == [1.5] * 4
    assert FakeTree.calls == [
        ("a", 0, 10), ("b", 0, 10),
        ("b", 10, 20), ("a", 10, 20),
        ("a", 20, 25), ("b", 20, 25),  # the last batch stops at --runs
        ("b", 5, 15), ("a", 5, 15),
    ]  # fmt: skip


@pytest.mark.slow
def test_a_worker_on_this_tree_answers_cpu_times(bench_ab) -> None:
    tree = bench_ab.Tree(str(ROOT), runs=6, seed=0)
    try:
        rates = [tree.batch(0, 3), tree.batch(3, 6)]
    finally:
        tree.close()
    assert tree.proc.returncode == 0
    assert all(r > 0.0 for r in rates) and tree.rates == rates
