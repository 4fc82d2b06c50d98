"""benchmarks/bench_weather_trends.py, whose trend table docs/weather.md quotes: pairing,
the sign test, pooling of disjoint measurements, and a real (PEM) run of every arm."""

from __future__ import annotations

from types import ModuleType

import pytest
from benchmark_modules import load_benchmark


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_benchmark("bench_weather_trends")


def test_sign_test_is_the_exact_two_sided_binomial(bench) -> None:
    assert bench.sign_test(0, 0) == 1.0
    assert bench.sign_test(5, 0) == pytest.approx(2 / 32)
    assert bench.sign_test(3, 3) == 1.0
    assert bench.sign_test(9, 1) == pytest.approx(2 * 11 / 1024)
    assert bench.sign_test(1, 9) == bench.sign_test(9, 1)


ARMS = ("baseline", "fog_density", "fog_distance", "cloudiness", "precipitation")


def _rows(n: int, fail_high: set[int], fail_base: set[int]) -> list[dict]:
    """``n`` runs: those in ``fail_high`` fail in dense fog, those in ``fail_base`` elsewhere."""
    return [
        {"index": i, **{a: (i in fail_high if a == "fog_density" else i in fail_base)
                        for a in ARMS}}
        for i in range(n)
    ]  # fmt: skip


def test_changes_are_paired_and_pooling_adds_counts(bench) -> None:
    a = bench.summarize(_rows(10, {1, 2, 3}, {3, 4}))
    fog = a["elements"]["fog_density"]
    assert (fog["fail_only_high"], fog["fail_only_low"]) == (2, 1)  # 1, 2 vs 4
    assert fog["change"] == pytest.approx(0.1)
    b = bench.summarize(_rows(20, {0, 5}, set()))
    pooled = bench.merge([{"pem": a}, {"pem": b}])["pem"]
    assert pooled["runs"] == 30
    assert pooled["arms"]["fog_density"]["failures"] == 5
    e = pooled["elements"]["fog_density"]
    assert (e["fail_only_high"], e["fail_only_low"]) == (4, 1)
    assert e["sign_test_p"] == pytest.approx(bench.sign_test(4, 1), abs=1e-4)
    assert "| fog_density (baseline -> fog_density) |" in bench.table({"pem": pooled})


def test_every_arm_runs_on_the_same_situation(bench) -> None:
    row = bench._run(("pem", 7, 0, 1.0))
    assert set(row) == {"mode", "index", *bench.ARMS}
    assert all(isinstance(row[a], bool) for a in bench.ARMS)
    assert tuple(bench.ARMS) == ARMS


def test_the_wind_arms_pair_rain_with_and_without_wind(bench) -> None:
    """--wind: precipitation 100 with wind 0 and 100 on the same situation. On the PEM the
    two runs are the same run (its rain terms have no wind and the carla profile's wind
    no force): the trend table's "flat" for the PEM is this, not sampling."""
    for i in range(6):
        row = bench._run(("pem", 7, i, 0.4, bench.WIND_ARMS))
        assert set(row) == {"mode", "index", "precipitation", "rain_wind"}
        assert row["precipitation"] == row["rain_wind"]
    report = bench.summarize(
        [{"index": 0, "precipitation": True, "rain_wind": False}],
        bench.WIND_ARMS,
        bench.WIND_ELEMENTS,
    )
    e = report["elements"]["wind_intensity"]
    assert (e["low"], e["high"], e["fail_only_low"]) == ("precipitation", "rain_wind", 1)
    assert "| wind_intensity (precipitation -> rain_wind) |" in bench.table({"pem": report})
