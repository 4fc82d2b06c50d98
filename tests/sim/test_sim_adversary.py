"""The paper's OV timing law, as a unit."""

from __future__ import annotations

import pytest

from sitcov.sim import AdversaryController, AdversaryParams, arrival_time, pure_pursuit


def test_waits_for_the_ego() -> None:
    adv = AdversaryController()
    assert adv.command(50.0, 0.0, 20.0, 0.0) == (0.0, 1.0)
    assert adv.phase == "wait"


def test_regulates_with_gain_three() -> None:
    adv = AdversaryController()
    # ego 50 m at 5 m/s -> 10 s; OV 20 m at 4 m/s -> 5 s: early, brake 3*(5-10) -> 1
    assert adv.command(50.0, 5.0, 20.0, 4.0) == (0.0, 1.0)
    assert adv.phase == "regulate"
    # OV 20 m at 2.1 m/s -> 9.52 s vs 10 s: brake 3*0.476 = 1.43 -> capped 1... small case:
    thr, brk = adv.command(50.0, 5.0, 20.0, 2.05)
    assert thr == 0.0 and brk == pytest.approx(min(1.0, 3 * (10 - 20 / 2.05)))
    # late: OV 20 m at 1.9 m/s -> 10.53 s: throttle 3*0.53
    thr, brk = adv.command(50.0, 5.0, 20.0, 1.9)
    assert brk == 0.0 and thr == pytest.approx(min(1.0, 3 * (20 / 1.9 - 10)))
    # standing OV: speed floored, so it is late and drives off
    assert adv.command(50.0, 5.0, 20.0, 0.0) == (1.0, 0.0)


def test_cruises_once_the_ego_is_close() -> None:
    params = AdversaryParams(switch_distance=8.0)
    adv = AdversaryController(params)
    adv.command(50.0, 5.0, 20.0, 4.0)
    thr, brk = adv.command(7.0, 5.0, 20.0, 3.0)  # ego within 8 m: cruise to 15 km/h
    assert adv.phase == "cruise"
    assert thr == pytest.approx(0.5 * (15 / 3.6 - 3.0)) and brk == 0.0
    thr, brk = adv.command(60.0, 0.0, 20.0, 6.0)  # and never goes back, even if the ego stops
    assert adv.phase == "cruise" and brk == pytest.approx(0.5 * (6.0 - 15 / 3.6))


def test_no_conflict_means_cruise() -> None:
    adv = AdversaryController(has_conflict=False)
    adv.command(50.0, 1.0, 20.0, 0.0)
    assert adv.phase == "cruise"


def test_helpers() -> None:
    assert arrival_time(10.0, 0.0, 0.5) == pytest.approx(20.0)
    assert arrival_time(-3.0, 5.0, 0.5) == 0.0
    assert pure_pursuit(0.0, 0.0, 0.0, 10.0, 0.0, 2.6) == pytest.approx(0.0)
    assert pure_pursuit(0.0, 0.0, 0.0, 5.0, 5.0, 2.6) > 0  # target on the left: steer left
