"""The esmini backend with esmini's library: the ego under the stack, facts, determinism.

Needs esmini (``SITCOV_ESMINI`` or ``SITCOV_ESMINI_LIB``; CI sets it to the shared build):
skipped locally without it, a failure in CI (tests/needs.py).
"""

from __future__ import annotations

import ctypes
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
from needs import missing, need_esmini_library

from sitcov.av import AVStack, Control, Observation, RunInfo, make_stack
from sitcov.errors import ConfigError
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim import Judge, make_backend
from sitcov.sim.embedded._progress import BLOCKED_TIME

need_esmini_library()

ROOT = Path(__file__).resolve().parents[3]
EXAMPLES = ROOT / "examples" / "esmini"
CROSSING = EXAMPLES / "crossing.xosc"
TOWN03 = ROOT.parent / "shared" / "maps" / "Town03.xodr"


def _need_town03() -> None:
    """Skip without CARLA's Town03 next to the repository (a failure in CI)."""
    if not TOWN03.is_file():
        missing(f"{TOWN03} (test data next to the repository, with the esmini build)")


def situation(**values: float) -> Situation:
    return Situation(bins={k: str(v) for k, v in values.items()}, values=values)


class Scripted(AVStack):
    """Drives by a fixed law of time: throttle until ``brake_at`` [s], then full brake;
    constant ``steer``. Records the ego states it was shown."""

    def __init__(self, brake_at: float = math.inf, steer: float = 0.0) -> None:
        self.brake_at, self.steer = brake_at, steer
        self.states: list = []
        self.info: RunInfo | None = None

    def reset(self, info: RunInfo) -> None:
        self.info, self.states = info, []

    def step(self, observation: Observation) -> Control:
        self.states.append(observation.ego)
        if observation.t >= self.brake_at:
            return Control(throttle=0.0, brake=1.0, steer=self.steer)
        return Control(throttle=0.6, brake=0.0, steer=self.steer)


@pytest.fixture(scope="module")
def backend():
    return make_backend("esmini", scenario=str(CROSSING))


def test_the_parameter_reaches_esmini(backend) -> None:
    """The substituted declaration is what esmini evaluates (read back through its API)."""
    from sitcov.sim.esmini._session import Session

    xml = backend.files["crossing"].render({"TriggerDistance": 23.5})
    with Session(xml, 0, (str(EXAMPLES),)) as session:
        value = ctypes.c_double()
        session.lib.SE_GetParameterDouble(b"TriggerDistance", ctypes.byref(value))
        assert value.value == 23.5


def test_the_stack_drives_the_ego_not_the_storyboard(backend) -> None:
    """A stack that never moves keeps the ego at its start: esmini does not move it, and
    the verdict does not pass it: it stood BLOCKED_TIME with its path clear (`blocked`)."""
    still = Scripted(brake_at=0.0)
    out = backend.run(situation(TriggerDistance=30.0), still, 1, record=True)
    assert out.end_reason == "stopped" and not out.collision
    assert out.metrics["blocked_time"] == pytest.approx(BLOCKED_TIME, abs=0.06)
    assert out.metrics["time_to_goal"] is None and out.metrics["route_incomplete_time"] is None
    assert Judge.from_spec("default")(out).kind == "blocked"
    assert Judge.from_spec("paper")(out).status == "pass"  # collisions only
    xs = {round(row[1], 9) for row in out.trace.ego}
    assert len(xs) == 1 and out.metrics["route_completion"] == 0.0
    assert out.trace.ego[0][1] == pytest.approx(20.0 + 1.4, abs=1e-6)  # s = 20 + box offset
    assert still.info.route[0][0] == pytest.approx(20.0, abs=0.1)
    assert still.info.goal[0] == pytest.approx(160.0, abs=0.5)  # the file's route end


def test_friction_acts_through_sitcov_s_dynamics(backend) -> None:
    """The same throttle-then-brake law decelerates about mu * g: far less on ice."""
    decel = {}
    for mu in (1.0, 0.2):
        stack = Scripted(brake_at=8.0)
        out = backend.run(situation(TriggerDistance=0.0, friction=mu), stack, 1, record=True)
        assert out.metrics["mu"] == mu
        at_brake = next(r for r in out.trace.ego if r[0] >= 8.0)
        distance = out.trace.ego[-1][1] - at_brake[1]
        decel[mu] = at_brake[4] ** 2 / (2.0 * distance)  # v^2 / (2 d) [m/s^2]
    assert 0.6 * 9.81 < decel[1.0] < 1.05 * 9.81
    assert 0.6 * 0.2 * 9.81 < decel[0.2] < 1.05 * 0.2 * 9.81


def test_trigger_distance_decides_a_collision(backend) -> None:
    """The crossing car hits the reference stack's ego when it starts late enough to be
    unseen and early enough to reach the lane; far out it has long crossed."""
    stack = make_stack("reference")
    hit = backend.run(situation(TriggerDistance=17.0, CrossingSpeed=8.0), stack, 3)
    assert hit.status == "fail" and hit.end_reason == "collision"
    assert hit.metrics["collision_actor"] == "CrossingCar" and hit.collision_speed > 0
    # where and how: the contact point near the ego (its last recorded row is the step
    # before contact), its heading; a closing DRAC; the same facts when recorded
    m = hit.metrics
    traced = backend.run(situation(TriggerDistance=17.0, CrossingSpeed=8.0), stack, 3, record=True)
    x, y = m["collision_point"]
    last = traced.trace.ego[-1]
    assert math.hypot(x - last[1], y - last[2]) < 4.0  # within reach of the ego's box
    assert m["collision_heading"] == pytest.approx(last[3], abs=0.05)
    assert m["collision_kind"] == "car" and m["max_drac"] > 0
    assert traced.metrics["collision_point"] == m["collision_point"]
    early = backend.run(situation(TriggerDistance=45.0, CrossingSpeed=8.0), stack, 3)
    assert early.status == "pass" and early.min_distance > 0
    assert early.metrics["collision_point"] is None and early.metrics["collision_heading"] is None


def test_road_departure_is_a_fact_for_the_judge(backend) -> None:
    out = backend.run(situation(TriggerDistance=0.0), Scripted(steer=-0.4), 2)
    t = out.metrics["road_departure_time"]
    assert t is not None and 0 < t < out.sim_time + 1e-9
    assert Judge.from_spec("default")(out).failure_kind == "road_departure"
    straight = backend.run(situation(TriggerDistance=0.0), Scripted(brake_at=6.0), 2)
    assert straight.metrics["road_departure_time"] is None


def test_same_seed_same_outcome(backend) -> None:
    s = situation(TriggerDistance=19.0, CrossingSpeed=8.0, OncomingSpeed=5.0, fog_density=50.0)
    stack = make_stack("reference")
    a = backend.run(s, stack, 11)
    b = backend.run(s, stack, 11)
    assert a == b and a.metrics == b.metrics


def test_a_folder_is_an_element(tmp_path: Path) -> None:
    for name in ("near", "far"):
        shutil.copy(CROSSING, tmp_path / f"{name}.xosc")
    shutil.copy(EXAMPLES / "straight.xodr", tmp_path)
    folder = make_backend("esmini", scenario=str(tmp_path))
    hs = load_hyperspace(
        {
            "name": "catalogue",
            "axes": [
                {
                    "name": "files",
                    "elements": [
                        {"name": "scenario", "bins": [{"value": "near"}, {"value": "far"}]},
                        {"name": "TriggerDistance", "bins": [{"value": 17}, {"value": 45}]},
                    ],
                }
            ],
        }
    )
    folder.check_hyperspace(hs)
    assert "scenario" in folder.effects()
    out = folder.run(situation(scenario="far", TriggerDistance=45.0), Scripted(0.0), 0)
    assert out.metrics["scenario"] == "far"
    bad = hs.to_dict()
    bad["axes"][0]["elements"][0]["bins"][1] = {"value": "nowhere"}
    with pytest.raises(ConfigError, match="'nowhere'"):
        folder.check_hyperspace(load_hyperspace(bad))


def test_an_exported_paper_situation_plays_on_town03() -> None:
    """IntSit-3 of the paper's hyperspace through the OpenSCENARIO exporter: the ego follows
    its exported route on Town03 to the goal, on the road all the way."""
    _need_town03()
    hs = load_hyperspace()
    labels = {e: hs.labels(e)[0] for e in hs.element_names}
    labels.update(intsit="IntSit-3", friction="1.0")
    s = hs.situation_from_bins(labels, np.random.default_rng(0))
    b = make_backend("esmini", road=str(TOWN03))
    out = b.run(s, make_stack("reference"), 5)
    assert out.end_reason == "goal" and out.metrics["route_completion"] > 0.98
    assert out.metrics["road_departure_time"] is None and out.metrics["road"] == "Town03.xodr"


def _paper_situation(intsit: str, friction: str = "1.0") -> Situation:
    _need_town03()
    hs = load_hyperspace()
    labels = {e: hs.labels(e)[0] for e in hs.element_names}
    labels.update(intsit=intsit, friction=friction)
    return hs.situation_from_bins(labels, np.random.default_rng(0))


class SpeedCapped(AVStack):
    """The reference stack, coasting whenever the ego is faster than ``cap`` [m/s]."""

    def __init__(self, cap: float) -> None:
        self.inner, self.cap = make_stack("reference"), cap

    def reset(self, info: RunInfo) -> None:
        self.inner.reset(info)

    def step(self, observation: Observation) -> Control:
        c = self.inner.step(observation)
        if observation.ego.speed > self.cap:
            return Control(throttle=0.0, brake=c.brake, steer=c.steer)
        return c


def _arrival(rows: list, point: list[float]) -> float:
    """When a trace passes nearest to ``point`` [s]."""
    return min(rows, key=lambda r: math.dist(r[1:3], point))[0]


def test_the_exported_ov_times_its_arrival_against_the_ego() -> None:
    """Closed loop: an ego held to 3 m/s reaches the conflict ~18 s later than one at the
    reference's 25 km/h, and the OV, timed by the paper's law on the ego as it drives,
    comes that much later too (an open-loop OV would come at the same time)."""
    s = _paper_situation("IntSit-3")
    b = make_backend("esmini", road=str(TOWN03))
    free = b.run(s, SpeedCapped(math.inf), 5, record=True)
    slow = b.run(s, SpeedCapped(3.0), 5, record=True)
    point = free.metrics["ov_conflict"]
    assert slow.metrics["ov_conflict"] == point
    assert free.metrics["ov_timing"].startswith("timing law")
    ego_delay = _arrival(slow.trace.ego, point) - _arrival(free.trace.ego, point)
    ov_delay = _arrival(slow.trace.actors["adversary"], point) - _arrival(
        free.trace.actors["adversary"], point
    )
    assert ego_delay > 10.0
    assert ov_delay > 0.6 * ego_delay
    assert slow.metrics["ov_switch_time"] - free.metrics["ov_switch_time"] > 0.6 * ego_delay


def test_an_ego_that_never_moves_keeps_the_ov_waiting() -> None:
    """The law's first phase: the OV stands until the ego starts."""
    s = _paper_situation("IntSit-1")
    b = make_backend("esmini", road=str(TOWN03), sim_timeout=5.0)
    out = b.run(s, Scripted(brake_at=0.0), 1, record=True)
    ov = out.trace.actors["adversary"]
    assert max(r[4] for r in ov) == 0.0
    assert math.dist(ov[0][1:3], ov[-1][1:3]) < 1e-6


def test_a_cropped_road_gives_the_same_outcomes() -> None:
    """esmini on the part of Town03 the run's paths come near plays exactly as on the whole
    file (the speed-up of docs/esmini.md changes no outcome)."""
    _need_town03()
    stack = make_stack("reference")
    whole = make_backend("esmini", road=str(TOWN03), crop_road=False)
    part = make_backend("esmini", road=str(TOWN03))
    for intsit, friction in (("IntSit-1", "1.0"), ("IntSit-6", "0.2"), ("IntSit-10", "0.6")):
        s = _paper_situation(intsit, friction)
        a, b = whole.run(s, stack, 3), part.run(s, stack, 3)
        assert (a.status, a.end_reason, a.sim_time, a.min_distance, a.aeb_time) == (
            b.status, b.end_reason, b.sim_time, b.min_distance, b.aeb_time
        )  # fmt: skip
        assert a.metrics["road"] == b.metrics["road"] == "Town03.xodr"


class ObjectRecorder(AVStack):
    """Wants object lists; drives slowly along +x of its own frame, keeps what it gets."""

    wants = "objects"

    def __init__(self) -> None:
        self.lists: list = []
        self.other: list = []

    def reset(self, info: RunInfo) -> None:
        self.lists.clear()

    def step(self, observation: Observation) -> Control:
        if observation.objects is not None:
            self.lists.append((observation.t, observation.objects))
        if observation.detections is not None or observation.image is not None:
            self.other.append(observation)
        return Control(throttle=0.2)


def test_a_stack_that_wants_objects_gets_esmini_s_objects(backend) -> None:
    """Object lists at the sensor rate (10 Hz), built from esmini's object states by the
    same code as the embedded backend's; no detections instead."""
    stack = ObjectRecorder()
    backend.run(situation(TriggerDistance=15.0), stack, 2)
    assert stack.lists and not stack.other
    times = [t for t, _ in stack.lists]
    assert times[:3] == pytest.approx([0.0, 0.1, 0.2])
    labels = {o.label for _, objs in stack.lists for o in objs}
    assert labels and labels <= {"car", "truck", "cyclist", "pedestrian"}


def test_esmini_s_noisy_object_lists_miss_in_runs_and_are_seeded() -> None:
    """The same miss model as the embedded backend's (one ``EgoDriver``): the same seed
    gives the same lists; with the misses correlated (``miss_tau`` 0.5 s) they come in
    longer runs than independent ones at the same per-frame probability."""
    from sitcov.perception import ObjectNoise

    def runs(tau: float, seed: int) -> tuple[list, list[int]]:
        noise = ObjectNoise(miss_tau=tau, detection_probability=lambda *a: 0.6)
        stack = ObjectRecorder()
        make_backend("esmini", scenario=str(CROSSING), object_noise=noise).run(
            situation(TriggerDistance=15.0), stack, seed
        )
        lengths, n = [], 0
        for _, objs in stack.lists:
            if 1 in {o.id for o in objs}:
                lengths, n = lengths + [n] * bool(n), 0
            else:
                n += 1
        return stack.lists, lengths + [n] * bool(n)

    a, ra = runs(0.5, 2)
    assert a == runs(0.5, 2)[0] and ra
    correlated = [n for seed in range(2, 8) for n in runs(0.5, seed)[1]]
    independent = [n for seed in range(2, 8) for n in runs(0.0, seed)[1]]
    assert sum(correlated) / len(correlated) > 1.3 * sum(independent) / len(independent)


def test_lane_departure_is_the_embedded_world_s_test(backend) -> None:
    """Straight on: no lane departure. Drifting left into the oncoming lane: the lane is
    left (centre more than (lane - ego width) / 2 + 0.5 m off the route) before the road
    (the far sidewalk)."""
    s = situation(TriggerDistance=60.0)
    straight = backend.run(s, Scripted(steer=0.0), 1)
    assert straight.metrics["lane_departure_time"] is None
    drift = backend.run(s, Scripted(steer=0.02), 1)
    lane, road = drift.metrics["lane_departure_time"], drift.metrics["road_departure_time"]
    assert lane is not None and road is not None and lane < road


def test_camera_mode_and_image_stacks_are_one_clear_error() -> None:
    from sitcov.errors import SetupError

    with pytest.raises(ConfigError, match="renders no camera frames"):
        make_backend("esmini", scenario=str(CROSSING), perception="camera")

    class WantsImages(Scripted):
        wants = "image"

    b = make_backend("esmini", scenario=str(CROSSING))
    with pytest.raises(SetupError, match="wants camera images, which the esmini backend"):
        b.run(situation(TriggerDistance=15.0), WantsImages(), 1)


def test_pet_at_the_timed_ov_s_conflict_zone() -> None:
    """PET is measured at the conflict zone of the exported situation's OV: 0 after a
    collision with it or while both were in the zone at once (docs/metrics.md), the gap
    between one leaving and the other entering otherwise."""
    _need_town03()
    b = make_backend("esmini", road=str(TOWN03))
    stack = make_stack("reference")
    seen = []
    for intsit, friction, seed in (("IntSit-3", "1.0", 5), ("IntSit-8", "0.1", 1)):
        out = b.run(_paper_situation(intsit, friction), stack, seed)
        seen.append(out)
        if out.collision and out.metrics["collision_actor"] == "adversary":
            assert out.pet == 0.0
        elif out.pet is not None:
            assert out.pet >= 0.0
    assert any(o.pet is not None and o.pet > 0.0 for o in seen)


def test_a_carla_map_file_s_situations_need_its_road() -> None:
    with pytest.raises(ConfigError, match="--road"):
        make_backend("esmini", map="Town03")


@pytest.mark.parametrize("name", ["t-junction", "crossroads"])
def test_without_a_road_a_shipped_map_runs_on_its_own_opendrive_export(name: str) -> None:
    """No --road: the situation is placed on the embedded map's own export (the file
    ``sitcov export-xodr`` writes), the OV timed on it, the ego at its goal."""
    from sitcov.roads._writer import xodr_text
    from sitcov.sim.embedded import load_map
    from sitcov.sim.embedded._odr import road_network

    b = make_backend("esmini", map=name)
    assert b.road.name == f"{name}.xodr"
    assert b.road.read_text(encoding="utf-8") == xodr_text(road_network(load_map(name))[0])
    hs = load_hyperspace()
    labels = {e: hs.labels(e)[0] for e in hs.element_names}
    labels.update(intsit="IntSit-3", friction="1.0")
    s = hs.situation_from_bins(labels, np.random.default_rng(0))
    out = b.run(s, make_stack("reference"), 5)
    assert out.metrics["road"] == f"{name}.xodr"
    assert out.metrics["ov_timing"].startswith("timing law")
    assert out.metrics["road_departure_time"] is None and out.status == "pass"
    if name == "t-junction":  # on crossroads the two meet and stand (a standoff)
        assert out.end_reason == "goal" and out.metrics["route_completion"] > 0.98
        assert out.pet is not None
        assert make_backend("esmini").road.name == "t-junction.xodr"  # the default map


def test_a_campaign_on_a_user_scenario_is_deterministic(tmp_path: Path) -> None:
    """Same seed, same rows: two campaigns of the example, in worker processes."""
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    rows = []
    for name in ("a", "b"):
        config = CampaignConfig(
            name="c",
            hyperspace=str(EXAMPLES / "crossing.yaml"),
            backend="esmini",
            backend_options={"scenario": str(CROSSING)},
            runs=12,
            seed=4,
            workers=1,
            executor="processes",
        )
        with open_store(tmp_path / f"{name}.db") as store:
            run_campaign(config, store)
            rows.append([(r.situation, r.seed, r.outcome) for r in store.iter_runs("c")])
    assert len(rows[0]) == 12 and rows[0] == rows[1]
    assert all(o.metrics["parameters"]["TriggerDistance"] for _, _, o in rows[0])


def test_a_campaign_of_sitcov_s_own_situations_is_deterministic(tmp_path: Path) -> None:
    """Same seed, same rows for exported situations too (dry runs, timed OV, crop, PET):
    the paper's hyperspace on the t-junction's own export, in worker processes."""
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    rows = []
    for name in ("a", "b"):
        config = CampaignConfig(
            name="c", backend="esmini", runs=8, seed=2, workers=1, executor="processes"
        )
        with open_store(tmp_path / f"{name}.db") as store:
            run_campaign(config, store)
            rows.append([(r.situation, r.seed, r.outcome) for r in store.iter_runs("c")])
    assert len(rows[0]) == 8 and rows[0] == rows[1]
    assert all(o.metrics["road"] == "t-junction.xodr" for _, _, o in rows[0])


def test_unknown_element_stops_the_campaign_before_the_database(tmp_path: Path) -> None:
    from sitcov.campaign import CampaignConfig
    from sitcov.campaign._build import check_parts

    bad = tmp_path / "bad.yaml"
    bad.write_text((EXAMPLES / "crossing.yaml").read_text().replace("OncomingSpeed", "Oncoming"))
    config = CampaignConfig(
        hyperspace=str(bad), backend="esmini", backend_options={"scenario": str(CROSSING)}
    )
    with pytest.raises(ConfigError, match="'Oncoming'"):
        check_parts(config)


def test_a_scenario_esmini_refuses_is_an_error_with_esmini_s_reason(tmp_path: Path) -> None:
    """The run raises (the campaign stores it as ``error``) with esmini's own reason; the
    next run in the same process plays normally (the failed scenario was closed)."""
    from sitcov.sim.esmini._session import EsminiError

    broken = tmp_path / "broken.xosc"
    broken.write_text(CROSSING.read_text().replace("straight.xodr", "missing.xodr"))
    with pytest.raises(EsminiError, match="missing.xodr"):
        make_backend("esmini", scenario=str(broken)).run(situation(), Scripted(0.0), 0)
    ok = make_backend("esmini", scenario=str(CROSSING)).run(situation(), Scripted(0.0), 0)
    assert ok.status == "pass"


def test_a_wall_time_out_is_stored_and_leaves_esmini_usable(tmp_path: Path) -> None:
    """The serial executor's alarm interrupts a run mid-scenario: stored as ``timeout``;
    the scenario was closed and the lock released, so the next run plays."""
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    config = CampaignConfig(
        hyperspace=str(EXAMPLES / "crossing.yaml"),
        backend="esmini",
        backend_options={"scenario": str(CROSSING)},
        runs=2,
        executor="serial",
        run_timeout=0.001,
    )
    with open_store(tmp_path / "t.db") as store:
        run_campaign(config, store)
        assert store.status_counts()["timeout"] == 2
    again = make_backend("esmini", scenario=str(CROSSING))
    assert again.run(situation(), Scripted(0.0), 0).status == "pass"


def test_without_a_route_the_ego_follows_its_lane_ahead(tmp_path: Path) -> None:
    text = CROSSING.read_text()
    routing = text.index("<RoutingAction>")
    start = text.rindex("<PrivateAction>", 0, routing)
    end = text.index("</PrivateAction>", routing) + len("</PrivateAction>")
    free = tmp_path / "free.xosc"
    free.write_text(text[:start] + text[end:])
    shutil.copy(EXAMPLES / "straight.xodr", tmp_path)
    stack = Scripted(0.0)
    make_backend("esmini", scenario=str(free), route_length=120.0).run(situation(), stack, 0)
    route = stack.info.route
    assert route[0][0] == pytest.approx(20.0, abs=0.1) and stack.info.goal[0] == pytest.approx(
        140.0, abs=1.0
    )
    assert all(y == pytest.approx(-1.75, abs=1e-6) for _, y in route)  # lane -1's centre


def test_a_driving_ego_reaches_its_goal_with_the_embedded_facts(backend) -> None:
    """A stack that drives and reaches its goal: completion 1, the time to goal is the
    end, never blocked; a run that ends at the budget before the goal is route_incomplete."""
    drive = Scripted()
    out = backend.run(situation(TriggerDistance=10.0), drive, 1)
    if out.end_reason == "goal":
        m = out.metrics
        assert m["route_completion"] == 1.0 and m["time_to_goal"] == out.sim_time
        assert m["blocked_time"] is None and m["route_incomplete_time"] is None
    short = make_backend("esmini", scenario=str(CROSSING), sim_timeout=3.0)
    cut = short.run(situation(TriggerDistance=10.0), Scripted(), 1)
    assert cut.end_reason == "sim_timeout" and cut.metrics["time_to_goal"] is None
    assert cut.metrics["route_incomplete_time"] == pytest.approx(cut.sim_time)
    assert Judge.from_spec("default")(cut).kind in ("route_incomplete", "collision")


@pytest.mark.parametrize(
    ("s_ego", "s_ov", "speed", "due"),
    [
        (50.0, 10.0, 8.0, True),  # the OV 28.5 m before the zone at 8 m/s: due in 3.6 s
        (50.0, 10.0, 5.0, False),  # at 5 m/s: 5.7 s, not due within ARRIVAL_TIME
        (50.0, 40.0, 0.0, True),  # standing inside the zone
        (50.0, 30.0, 0.1, False),  # standing before it (below STILL_SPEED)
        (20.0, 10.0, 8.0, False),  # the zone more than PATH_AHEAD ahead of the ego's front
        (50.0, 60.0, 8.0, False),  # the OV has left the zone
    ],
)
def test_the_timed_ov_holds_the_ego_as_the_embedded_conflict_test_says(s_ego, s_ov, speed, due):
    """``_TimedOV.due``: the embedded world's path test (b) with the OV's conflict zone
    (ego zone 60-65 m, OV zone 40-45 m on their routes, half lengths 2.4 and 2.25 m)."""
    from types import SimpleNamespace

    from sitcov.sim.esmini._backend import _TimedOV

    ov = object.__new__(_TimedOV)
    ov.zone, ov.s_now, ov.halves = (60.0, 65.0, 40.0, 45.0), (s_ego, s_ov), (2.4, 2.25)
    ov.actor = SimpleNamespace(speed=speed)
    assert ov.due() is due
