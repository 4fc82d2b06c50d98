"""Golden equality: the world of actors reproduces the two-car runs exactly.

``data/golden_world_two_cars.json`` holds ``Outcome.to_dict()`` of 960 two-car runs
recorded with the single-loop backend before the redesign (see ``_golden_world.py``).
Floats are compared for exact equality: the redesign keeps the floating-point operations
of the two-car case in the same order.
"""

from __future__ import annotations

import json

import pytest
from _golden_world import GOLDEN, run_all


@pytest.fixture(scope="module")
def golden() -> dict:
    return json.loads(GOLDEN.read_text(encoding="utf-8"))


def _diff(expected: dict, actual: dict) -> list[str]:
    return [
        f"{k}: {expected.get(k)!r} != {actual.get(k)!r}"
        for k in sorted(set(expected) | set(actual))
        if expected.get(k) != actual.get(k)
    ]


def _check(golden: dict, every: int) -> None:
    actual = run_all(golden["situations"], every=every)
    assert actual, "no golden case ran"
    bad = {key: _diff(golden["outcomes"][key], out) for key, out in actual.items()}
    bad = {key: d for key, d in bad.items() if d}
    assert not bad, f"{len(bad)} of {len(actual)} runs differ, e.g. {next(iter(bad.items()))}"


def test_every_seventh_golden_run_is_reproduced_exactly(golden) -> None:
    _check(golden, every=7)


@pytest.mark.slow
def test_all_golden_runs_are_reproduced_exactly(golden) -> None:
    _check(golden, every=1)
