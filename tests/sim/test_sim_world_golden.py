"""Golden equality: the world of actors reproduces the two-car runs exactly.

``data/golden_world_two_cars.json`` holds ``Outcome.to_dict()`` of 960 two-car runs
recorded with the single-loop backend before the redesign (see ``_golden_world.py``).
Floats are compared for exact equality: the redesign keeps the floating-point operations
of the two-car case in the same order.
"""

from __future__ import annotations

import json

import pytest
from _golden_world import GOLDEN, assert_reproduced, run_all


@pytest.fixture(scope="module")
def golden() -> dict:
    return json.loads(GOLDEN.read_text(encoding="utf-8"))


def _check(golden: dict, every: int) -> None:
    assert_reproduced(golden, run_all(golden["situations"], every=every))


def test_every_seventh_golden_run_is_reproduced_exactly(golden) -> None:
    _check(golden, every=7)


@pytest.mark.slow
def test_all_golden_runs_are_reproduced_exactly(golden) -> None:
    _check(golden, every=1)
