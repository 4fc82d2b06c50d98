"""The embedded world of actors: pedestrians, cyclists, extra cars, monitors, traces."""

from __future__ import annotations

import math
import sys
from typing import Any

import numpy as np
import pytest

from sitcov.av import AVStack, Control, NoPerceptionStack, Observation, ReferenceStack, RunInfo
from sitcov.errors import ConfigError
from sitcov.hyperspace import Situation
from sitcov.perception import PEMSensor
from sitcov.sim.embedded import EmbeddedBackend
from sitcov.sim.embedded import _backend as backend_module
from sitcov.sim.embedded import _scene as scene_module
from sitcov.sim.embedded._bodies import body_spec, make_body

CAR_OV = {"ego": "L-B", "ov": "B-R", "conflict": "none"}  # the OV's route never meets the ego's


def situation(**values: Any) -> Situation:
    return Situation(bins={k: str(v) for k, v in values.items()}, values=values)


class StandStill(AVStack):
    """Never moves."""

    name = "stand-still"

    def reset(self, info: RunInfo) -> None:
        self.info = info

    def step(self, observation: Observation) -> Control:
        return Control(0.0, 1.0, 0.0)


@pytest.fixture(scope="module")
def backend() -> EmbeddedBackend:
    return EmbeddedBackend()


@pytest.mark.parametrize("behaviour", ["cross", "hesitate"])
def test_a_pedestrian_crossing_in_front_of_a_blind_ego_is_hit_and_reported(
    backend, behaviour
) -> None:
    s = situation(
        intsit=CAR_OV, actor2={"kind": "pedestrian", "route": "XBL", "behaviour": behaviour}
    )
    o = backend.run(s, NoPerceptionStack(), seed=1)
    assert o.collision and o.end_reason == "collision" and o.status == "fail"
    assert o.metrics["collision_actor"] == "actor2"
    assert o.metrics["collision_kind"] == "pedestrian"
    ped = o.metrics["actors"]["actor2"]
    assert ped["kind"] == "pedestrian" and ped["collided"] and ped["min_distance"] == 0.0
    assert ped["behaviour"] == behaviour and ped["pet"] in (0.0, None)  # None: hit before
    # its front reached the swept-path overlap (PET needs both in the zone, docs/metrics.md)
    assert not o.metrics["actors"]["ov"]["collided"]


@pytest.mark.parametrize("route", ["XBL", "XBR"])
def test_a_pedestrian_stopping_at_the_kerb_is_not_hit(backend, route) -> None:
    s = situation(intsit=CAR_OV, actor2={"kind": "pedestrian", "route": route, "behaviour": "kerb"})
    o = backend.run(s, NoPerceptionStack(), seed=1, record=True)
    assert not o.collision and o.end_reason == "goal"
    ped = o.metrics["actors"]["actor2"]
    assert ped["min_distance"] > 0.0 and not ped["collided"]
    # it did walk up to the kerb and stopped there (it stood still at the end)
    rows = o.trace.actors["actor2"]
    assert max(r[4] for r in rows) > 1.0 and rows[-1][4] < 0.05


def test_the_pedestrian_as_the_situations_ov_follows_the_timing_law(backend) -> None:
    s = situation(intsit={"ego": "L-B", "ov": "XBL", "conflict": "p1", "kind": "pedestrian"})
    o = backend.run(s, NoPerceptionStack(), seed=2)
    assert o.collision and o.metrics["collision_kind"] == "pedestrian"
    # a pedestrian synchronises up to the conflict (no early switch): the law still
    # regulated when it was hit
    assert o.metrics["ov_switch_distance"] == 0.0 and o.metrics["ov_switch_time"] is None
    assert o.metrics["actors"]["ov"]["kind"] == "pedestrian"
    # it met the ego by when it started, at a walking speed (issue 23: not by creeping)
    walked = backend.run(s, NoPerceptionStack(), seed=2, record=True)
    assert 1.0 <= max(r[4] for r in walked.trace.ov) <= 1.8


def test_a_cyclist_ov_meets_a_blind_ego(backend) -> None:
    s = situation(intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4", "kind": "cyclist"})
    o = backend.run(s, NoPerceptionStack(), seed=1, record=True)
    assert o.collision and o.metrics["collision_kind"] == "cyclist"
    assert max(r[4] for r in o.trace.ov) <= body_spec("cyclist").v_max + 1e-9


def test_actor_actor_collisions_are_recorded_and_do_not_end_the_run(backend, monkeypatch) -> None:
    # a second car on the OV's route also times its arrival to the ego's: if neither looked
    # (no watchers), it would run into the OV
    s = situation(
        intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"},
        actor2={"kind": "car", "route": "L-R"},
    )
    assert backend.run(s, NoPerceptionStack(), seed=1).metrics["actor_collisions"] == []
    monkeypatch.setattr(scene_module, "watch", lambda actors, ego: None)
    o = backend.run(s, NoPerceptionStack(), seed=1)
    events = o.metrics["actor_collisions"]
    assert len(events) == 1
    assert events[0]["actors"] == ["ov", "actor2"] and events[0]["kinds"] == ["car", "car"]
    assert events[0]["speed"] > 0.0 and events[0]["time"] < o.sim_time
    assert o.end_reason != "collision"  # the ego was not involved: the run went on


def test_three_actors_same_seed_same_outcome_other_seed_differs(backend) -> None:
    s = situation(
        intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"},
        actor2={"kind": "pedestrian", "route": "XBR", "behaviour": "hesitate"},
        wind_intensity=60.0,
        fog_density=30.0,
    )
    first = backend.run(s, ReferenceStack(), seed=11)
    assert first == backend.run(s, ReferenceStack(), seed=11)
    assert first.metrics["actors"] == backend.run(s, ReferenceStack(), seed=11).metrics["actors"]
    others = {backend.run(s, ReferenceStack(), seed=k).metrics["wind_direction"] for k in (1, 2)}
    assert first.metrics["wind_direction"] not in others


def test_the_trace_records_every_actor_with_kind_and_size(backend) -> None:
    s = situation(
        intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"},
        actor2={"kind": "pedestrian", "route": "XBL"},
        actor3={"kind": "cyclist", "route": "B-L", "behaviour": "cruise"},
    )
    o = backend.run(s, NoPerceptionStack(), seed=3, record=True)
    tr = o.trace
    assert set(tr.actors) == {"ov", "actor2", "actor3"}
    assert tr.actors["ov"] == tr.ov  # the primary OV is kept under its old name
    assert len(tr.ego) == o.metrics["steps"] + 1
    kinds = {n: m["kind"] for n, m in tr.meta["actors"].items()}
    assert kinds == {"ov": "car", "actor2": "pedestrian", "actor3": "cyclist"}
    assert tr.meta["actors"]["actor2"]["height"] == pytest.approx(1.75)


def test_the_sensor_sees_every_actor_with_its_kind() -> None:
    seen: list[tuple[str, ...]] = []

    class Spy:
        camera = ReferenceStack().camera

        def reset(self, frame_dt: float) -> None:
            pass

        def detect(self, ego, actors, conditions, rng):
            seen.append(tuple(a.kind for a in actors))
            return ()

    s = situation(
        intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4", "kind": "cyclist"},
        actor2={"kind": "pedestrian", "route": "XBL"},
    )
    EmbeddedBackend(sensor=Spy()).run(s, NoPerceptionStack(), seed=1)
    assert seen[0] == ("cyclist", "pedestrian")


def test_the_built_in_pems_prepared_path_sees_what_detect_sees() -> None:
    """The ego's driver shows the built-in PEM each actor prepared once per run (no
    ActorView per frame); a PEM subclass with its own ``detect`` gets ActorViews every
    frame: the same outcomes, three-actor scenes and the paper's two cars alike."""

    class OwnDetect(PEMSensor):
        def detect(self, ego, actors, conditions, rng):
            return super().detect(ego, actors, conditions, rng)

    scenes = [
        situation(intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"}, actor2="none"),
        situation(
            intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4", "kind": "cyclist"},
            actor2={"kind": "pedestrian", "route": "XBL"},
        ),
    ]
    fired = 0
    for s in scenes:
        for seed in range(6):
            want = EmbeddedBackend(sensor=OwnDetect()).run(s, ReferenceStack(), seed=seed)
            got = EmbeddedBackend(sensor=PEMSensor()).run(s, ReferenceStack(), seed=seed)
            assert got == want, seed
            fired += got.aeb_fired
    assert fired >= 3  # detections reached the stack


class _Recorded:
    """A run's generator that notes which file asks for each draw."""

    def __init__(self, rng: np.random.Generator, callers: list[str]) -> None:
        self._rng, self._callers = rng, callers

    def __getattr__(self, name: str) -> Any:
        method = getattr(self._rng, name)

        def draw(*args: Any, **kwargs: Any) -> Any:
            self._callers.append(sys._getframe(1).f_code.co_filename)
            return method(*args, **kwargs)

        return draw


def test_the_pems_noise_is_the_run_generators_last_consumer(monkeypatch) -> None:
    """The embedded backend lets the PEM draw its normals ahead in blocks (``NormalStream``),
    which changes no value only if nothing draws from the run's generator after the
    sensor's first draw: in two-car and three-actor runs, in rain (misses drawn too) and
    with wind, every draw after the sensor's first is the sensor's."""
    callers: list[str] = []
    make = np.random.default_rng

    def default_rng(seed: Any) -> Any:  # only the run's generator (the backend makes it)
        rng = make(seed)
        made_by = sys._getframe(1).f_code.co_filename
        return _Recorded(rng, callers) if made_by.endswith("_backend.py") else rng

    monkeypatch.setattr(np.random, "default_rng", default_rng)
    scenes = [
        situation(intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"}, precipitation=80.0),
        situation(
            intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4", "kind": "cyclist"},
            actor2={"kind": "pedestrian", "route": "XBL"},
            wind_intensity=60.0,
        ),
        situation(  # every other behaviour: scripted cars and cyclists, kerb and hesitate
            intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"},
            actor2={"kind": "pedestrian", "route": "XBR", "behaviour": "hesitate"},
            actor3={"kind": "pedestrian", "route": "XLL", "behaviour": "kerb"},
            actor4={"kind": "car", "route": "R-L", "behaviour": "stop-go"},
            actor5={"kind": "cyclist", "route": "B-L", "behaviour": "cruise"},
            actor6={"kind": "car", "route": "B-R", "behaviour": "stop"},
            actor7={"kind": "cyclist", "route": "L-R", "behaviour": "timed"},
            precipitation=60.0,
        ),
    ]
    for s in scenes:
        for seed in range(4):
            callers.clear()
            EmbeddedBackend(physics="physical").run(s, ReferenceStack(), seed=seed)
            pem = [c.endswith("_pem.py") for c in callers]
            assert True in pem and not pem[0]  # the wind's draws came first
            assert all(pem[pem.index(True) :]), callers


def test_two_car_runs_keep_their_old_metrics(backend) -> None:
    s = situation(intsit={"ego": "L-B", "ov": "R-B", "conflict": "c4"}, actor2="none")
    o = backend.run(s, ReferenceStack(), seed=1)
    assert "actors" not in o.metrics and "actor_collisions" not in o.metrics
    # schema 5: every run stores the kind it hit (a two-car run can only hit the OV's car)
    assert o.metrics["collision_kind"] == ("car" if o.collision else None)


def test_a_new_monitor_ends_runs_without_touching_the_loop(backend, monkeypatch) -> None:
    class TenSteps:
        def update(self, world):
            return "ten" if world.k == 10 else None

        def report(self, run, actors, world):
            run["ten_seen"] = True

    original = backend_module.default_monitors

    def with_ten(*args, **kwargs):
        return [*original(*args, **kwargs), TenSteps()]

    monkeypatch.setattr(backend_module, "default_monitors", with_ten)
    o = backend.run(situation(intsit=CAR_OV), StandStill(), seed=1)
    assert o.end_reason == "ten" and o.metrics["steps"] == 10 and o.metrics["ten_seen"]


@pytest.mark.parametrize(
    ("values", "field"),
    [
        ({"actor2": {"kind": "horse", "route": "L-B"}}, "actor2.kind"),
        ({"actor2": {"kind": "pedestrian"}}, "actor2"),
        ({"actor2": {"kind": "car", "route": "L-B", "behaviour": "kerb"}}, "actor2.behaviour"),
        ({"actor3": {"kind": "pedestrian", "route": "XQL"}}, "route"),
        ({"actor2": {"kind": "car", "route": "L-B", "colour": 1}}, "actor2.colour"),
        (
            {"actor2": {"kind": "car", "route": "L-B", "behaviour": {"name": "cruise", "x": 1}}},
            "actor2.behaviour",
        ),
        ({"intsit": {"ego": "L-B", "ov": "R-B", "kind": "tram"}}, "intsit.kind"),
    ],
)
def test_bad_scene_values_raise_one_line_config_errors(backend, values, field) -> None:
    values = {"intsit": CAR_OV, **values}
    with pytest.raises(ConfigError) as err:
        backend.run(situation(**values), StandStill(), seed=1)
    assert field in str(err.value) and "\n" not in str(err.value)


# --- bodies ------------------------------------------------------------------------------


def test_a_pedestrian_runs_at_most_3_m_s_and_accelerates_within_its_limit() -> None:
    spec = body_spec("pedestrian")
    walker = make_body("pedestrian", 0.0, 0.0, 0.0)
    speeds = []
    for _ in range(100):
        walker.step(1.0, 0.0, 0.0, 1.0, 0.0, 0.05)
        speeds.append(walker.speed)
    assert max(speeds) == pytest.approx(3.0) and 0.8 <= spec.walk_speed <= 1.8
    steps = zip([0.0, *speeds[:-1]], speeds, strict=True)
    assert all(b - a <= spec.a_max * 0.05 + 1e-12 for a, b in steps)
    assert walker.x == pytest.approx(sum(speeds) * 0.05, rel=0.05)
    assert (spec.length, spec.width, spec.height) == (0.5, 0.5, 1.75)


def test_a_cyclist_tops_out_at_8_m_s_and_brakes_within_mu_g() -> None:
    bike = make_body("cyclist", 0.0, 0.0, 0.0)
    for _ in range(200):
        bike.step(1.0, 0.0, 0.0, 1.0, 0.0, 0.05)
    assert bike.speed == pytest.approx(8.0)
    before = bike.speed
    bike.step(0.0, 1.0, 0.0, 0.1, 0.0, 0.05)  # icy road: mu g = 0.98 m/s^2
    assert before - bike.speed == pytest.approx(0.1 * 9.81 * 0.05)


def test_a_cyclist_turns_on_a_circle_of_the_bicycle_radius() -> None:
    spec = body_spec("cyclist")
    bike = make_body("cyclist", 0.0, 0.0, 0.0)
    bike.vx = 3.0
    steer = 0.5
    for _ in range(400):
        bike.step(0.0, 0.0, steer, 1.0, 0.0, 0.01)
    radius = spec.wheelbase / math.tan(steer * spec.steer_max)
    # after 4 s at 3 m/s on a circle through the origin centred at (0, radius)
    assert math.hypot(bike.x, bike.y - radius) == pytest.approx(radius, rel=0.01)
