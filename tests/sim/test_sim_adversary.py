"""The paper's OV timing law, as a unit, and where each situation's synchronisation ends."""

from __future__ import annotations

import math
import statistics

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from sitcov.av import NoPerceptionStack
from sitcov.errors import ConfigError
from sitcov.sim import AdversaryController, AdversaryParams, arrival_time, pure_pursuit
from sitcov.sim._adversary import (
    FALLBACK_SWITCH_DISTANCE,
    TOWN03_INBOUND_LANES,
    TOWN03_SWITCH_DISTANCES,
    TOWN03_SYNC_END_BOXES,
    box_entry,
    intsit_key,
    with_switch_distance,
)
from sitcov.sim.carla._mapfile import load_carla_map
from sitcov.sim.carla._ovdriver import OVDriver
from sitcov.sim.embedded import EmbeddedBackend
from sitcov.sim.embedded._map import MAPS_DIR, JunctionMap, load_map
from tests.sim._sim_helpers import INTSITS, make_situation


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


# --- where the synchronisation ends: per intersection situation ---------------------------


def test_town03_trigger_boxes_give_the_papers_distances() -> None:
    """Box entries lie on the box edge and on the inbound lane; the distances span the
    13.5-29 m the paper's boxes imply (short for the near conflict points, ~28-29 m when
    the conflict point is on the far side of Town03's wide junction)."""
    for leg, (x0, x1, y0, y1) in TOWN03_SYNC_END_BOXES.items():
        ex, ey = box_entry(leg)
        px, py, yaw = TOWN03_INBOUND_LANES[leg]
        assert x0 - 1e-9 <= ex <= x1 + 1e-9 and y0 - 1e-9 <= ey <= y1 + 1e-9
        on_edge = min(abs(ex - x0), abs(ex - x1), abs(ey - y0), abs(ey - y1))
        assert on_edge < 1e-9
        # on the lane: the entry is straight ahead of the lane point
        ahead = math.atan2(ey - py, ex - px)
        assert math.cos(ahead - math.radians(yaw)) > 0.999
    assert set(TOWN03_SWITCH_DISTANCES) == {intsit_key(e, o) for e, o, _ in INTSITS}
    values = sorted(TOWN03_SWITCH_DISTANCES.values())
    assert values[0] > 13.0 and values[-1] < 30.0
    assert statistics.median(values) == pytest.approx(FALLBACK_SWITCH_DISTANCE)


@pytest.mark.parametrize("name", ["t-junction", "skewed-cross"])
def test_shipped_maps_carry_the_derived_distances(name: str) -> None:
    assert load_map(name).switch_distances == TOWN03_SWITCH_DISTANCES
    assert load_carla_map("town03").switch_distances == TOWN03_SWITCH_DISTANCES


def test_map_without_an_entry_switches_at_its_leg_mouth() -> None:
    jm = load_map("skewed-cross")
    scen = jm.scenario("T-B", "L-R")
    assert scen.conflict is not None
    expected = scen.conflict.s_ego - (jm.spawns["ego"]["T"] - jm.legs["T"].mouth)
    assert jm.switch_distance(scen) == pytest.approx(expected)
    assert 0.0 < jm.switch_distance(scen) < scen.conflict.s_ego


@pytest.mark.parametrize(
    ("table", "field"),
    [
        ({"L-B": 10.0}, "switch_distances.L-B"),
        ({"L-B/X-R": 10.0}, "switch_distances.L-B/X-R"),
        ({"L-B/R-B": -1.0}, "switch_distances.L-B/R-B"),
        ([1, 2], "switch_distances"),
    ],
)
def test_bad_switch_distances_are_one_line_errors(table: object, field: str) -> None:
    data = yaml.safe_load((MAPS_DIR / "t-junction.yaml").read_text())
    data["switch_distances"] = table
    with pytest.raises(ConfigError) as info:
        JunctionMap(data, "bad.yaml")
    assert info.value.field == field and "\n" not in str(info.value)


@settings(max_examples=100, deadline=None)
@given(
    switch=st.floats(1.0, 40.0),
    start=st.floats(45.0, 80.0),
    steps=st.lists(st.floats(0.05, 0.6), min_size=10, max_size=200),
)
def test_phase_turns_to_cruise_when_the_gap_crosses_the_switch(switch, start, steps) -> None:
    """Property: with the OV short of the conflict, the controller regulates while the ego's
    remaining distance is above the situation's switch distance and cruises from the first
    tick at or below it."""
    adv = AdversaryController(with_switch_distance(AdversaryParams(), switch))
    d = start
    for step in steps:
        adv.command(d, 7.0, 30.0, 5.0)
        assert adv.phase == ("regulate" if d > switch else "cruise")
        if adv.phase == "cruise":
            return
        d -= step


def test_fixed_params_win_over_the_situation() -> None:
    assert with_switch_distance(AdversaryParams(switch_distance=8.0), 20.0).switch_distance == 8.0
    assert with_switch_distance(AdversaryParams(), 20.0).switch_distance == 20.0
    assert with_switch_distance(AdversaryParams(), None).switch_distance is None
    adv = AdversaryController()  # no distance at all: the Town03 median
    adv.command(FALLBACK_SWITCH_DISTANCE + 0.1, 7.0, 30.0, 5.0)
    assert adv.phase == "regulate"
    adv.command(FALLBACK_SWITCH_DISTANCE - 0.1, 7.0, 30.0, 5.0)
    assert adv.phase == "cruise"


def test_carla_ov_driver_uses_the_situations_distance() -> None:
    route = [(float(x), 0.0) for x in range(100)]
    ov_route = [(50.0, float(y) - 50.0) for y in range(100)]
    driver = OVDriver(route, ov_route, (50.0, 0.0), switch_distance=21.5)
    assert driver.controller.params.switch_distance == 21.5
    fixed = OVDriver(route, ov_route, (50.0, 0.0), params=AdversaryParams(switch_distance=8.0))
    assert fixed.controller.params.switch_distance == 8.0


@pytest.mark.parametrize("intsit", range(1, 13))
def test_embedded_backend_switches_at_the_situations_distance(intsit: int) -> None:
    """The OV stops synchronising on the first tick at which the ego's remaining distance
    is at most the situation's switch distance (the ego covers < 0.5 m per 0.05 s tick)."""
    backend = EmbeddedBackend(early_end=False)
    ego, ov, _ = INTSITS[intsit - 1]
    outcome = backend.run(make_situation(intsit), NoPerceptionStack(), seed=intsit)
    distance = TOWN03_SWITCH_DISTANCES[intsit_key(ego, ov)]
    assert outcome.metrics["ov_switch_distance"] == distance
    gap = outcome.metrics["ego_gap_at_switch"]
    assert distance - 0.5 < gap <= distance
