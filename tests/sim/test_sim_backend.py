"""The embedded backend end to end: adversary, outcomes, determinism, recording, errors."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from _sim_helpers import INTSITS, make_situation

from sitcov.av import AVStack, Control, NoPerceptionStack, Observation, ReferenceStack, RunInfo
from sitcov.errors import ConfigError, UnknownPluginError
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import Judge, make_backend
from sitcov.sim.embedded import EmbeddedBackend, render_topdown


class StandStill(AVStack):
    """Never moves; optionally claims its emergency brake fired."""

    name = "stand-still"

    def __init__(self, aeb: bool = False) -> None:
        self.aeb = aeb
        self.infos: list[RunInfo] = []

    def reset(self, info: RunInfo) -> None:
        self.infos.append(info)

    def step(self, observation: Observation) -> Control:
        return Control(0.0, 1.0, 0.0, {"aeb": True} if self.aeb else {})


@pytest.fixture(scope="module")
def backend() -> EmbeddedBackend:
    return make_backend("embedded")


def test_blind_ego_is_hit_in_at_least_90_percent(backend) -> None:
    stack = NoPerceptionStack()
    outcomes = [backend.run(make_situation(i), stack, seed=i) for i in range(1, 13)]
    collisions = sum(o.collision for o in outcomes)
    assert collisions >= 0.9 * len(INTSITS)
    for o in outcomes:
        if o.collision:
            assert o.status == "fail" and o.end_reason == "collision"
            assert o.collision_time == pytest.approx(o.sim_time)
            assert o.collision_speed > 0 and o.min_distance == 0.0 and o.pet == 0.0
            assert o.min_ttc is not None and o.min_ttc < 1.0
            assert not o.aeb_fired


def test_same_seed_same_outcome_here_and_in_a_subprocess(backend) -> None:
    situation = make_situation(
        5, fog_density=60.0, wind_intensity=80.0, friction=0.4, precipitation=40.0
    )
    first = backend.run(situation, ReferenceStack(), seed=99)
    second = backend.run(situation, ReferenceStack(), seed=99)
    assert first == second
    code = (
        "import json, sys; sys.path.insert(0, 'tests/sim');"
        "from _sim_helpers import make_situation;"
        "from sitcov.av import ReferenceStack; from sitcov.sim import make_backend;"
        "s = make_situation(5, fog_density=60.0, wind_intensity=80.0, friction=0.4,"
        " precipitation=40.0);"
        "print(json.dumps(make_backend().run(s, ReferenceStack(), seed=99).to_dict()))"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert json.loads(out.stdout) == json.loads(json.dumps(first.to_dict()))


def test_different_seeds_can_differ(backend) -> None:
    situation = make_situation(2, wind_intensity=100.0)
    a = backend.run(situation, NoPerceptionStack(), seed=1)
    b = backend.run(situation, NoPerceptionStack(), seed=2)
    assert a.metrics["wind_direction"] != b.metrics["wind_direction"]


def test_record_and_render(backend, tmp_path) -> None:
    outcome = backend.run(make_situation(3), NoPerceptionStack(), seed=3, record=True)
    trace = outcome.trace
    assert trace is not None and len(trace.ego) == outcome.metrics["steps"] + 1
    assert trace.ego[0][0] == 0.0 and trace.ego[-1][0] == pytest.approx(outcome.sim_time)
    assert backend.run(make_situation(3), NoPerceptionStack(), seed=3).trace is None
    path = render_topdown(outcome, tmp_path / "run.png")
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000
    with pytest.raises(ConfigError, match="record=True"):
        render_topdown(
            backend.run(make_situation(3), NoPerceptionStack(), seed=3), tmp_path / "x.png"
        )


def test_effects_cover_the_default_hyperspace(backend) -> None:
    effects = backend.effects()
    for element in load_hyperspace().element_names:
        assert element in effects and effects[element]


def test_timeout_is_a_pass() -> None:
    backend = EmbeddedBackend(sim_timeout=2.0)
    outcome = backend.run(make_situation(1), StandStill(), seed=0)
    assert (outcome.status, outcome.end_reason) == ("pass", "sim_timeout")
    assert outcome.sim_time == pytest.approx(2.0)


def test_latched_ego_and_waiting_ov_end_early(backend) -> None:
    outcome = backend.run(make_situation(1), StandStill(aeb=True), seed=0)
    assert (outcome.status, outcome.end_reason) == ("pass", "stopped")
    assert outcome.aeb_fired and outcome.aeb_time == 0.0
    assert outcome.sim_time < 1.0


def test_ego_reaches_goal_when_ov_gives_way() -> None:
    backend = EmbeddedBackend(adversary={"switch_distance": 1e9})  # OV cruises at once
    outcome = backend.run(make_situation(4), NoPerceptionStack(), seed=0)
    assert (outcome.status, outcome.end_reason) == ("pass", "goal")
    assert outcome.pet is not None and outcome.pet > 0.5


def test_wind_disturbs_both_vehicles() -> None:
    backend = EmbeddedBackend(adversary={"switch_distance": 1e9}, physics="physical")
    calm = backend.run(make_situation(4), NoPerceptionStack(), 5, record=True)
    windy = backend.run(
        make_situation(4, wind_intensity=100.0), NoPerceptionStack(), 5, record=True
    )
    for role in ("ego", "ov"):
        a, b = getattr(calm.trace, role), getattr(windy.trace, role)
        n = min(len(a), len(b)) - 1
        drift = max(abs(a[i][1] - b[i][1]) + abs(a[i][2] - b[i][2]) for i in range(n))
        assert drift > 0.02, role


def test_low_friction_pushes_the_ego_wide(backend) -> None:
    dry = backend.run(make_situation(6, friction=1.0), NoPerceptionStack(), 0)
    icy = backend.run(make_situation(6, friction=0.1), NoPerceptionStack(), 0)
    assert icy.metrics["mu"] < dry.metrics["mu"]
    assert icy.metrics["ego_max_lateral_offset"] > dry.metrics["ego_max_lateral_offset"] + 0.5


def test_grey_box_passes_the_situation() -> None:
    stack = StandStill()
    situation = make_situation(2)
    EmbeddedBackend(grey_box=True, sim_timeout=0.1).run(situation, stack, 0)
    EmbeddedBackend(sim_timeout=0.1).run(situation, stack, 0)
    grey, black = stack.infos
    assert grey.situation == situation and black.situation is None
    assert grey.dt == 0.05 and len(grey.route) > 90 and grey.goal == grey.route[-1]


def test_errors_are_config_errors() -> None:
    with pytest.raises(UnknownPluginError):
        make_backend("no-such-backend")
    with pytest.raises(ConfigError, match="perception"):
        make_backend("embedded", perception="lidar")
    with pytest.raises(ConfigError, match="adversary"):
        EmbeddedBackend(adversary={"gain": 3, "bogus": 1})
    bad = make_situation(1)
    bad = type(bad)(bins=dict(bad.bins), values={**bad.values, "intsit": "L-B"})
    with pytest.raises(ConfigError, match="intsit"):
        EmbeddedBackend().run(bad, StandStill(), 0)


def test_camera_mode_passes_images() -> None:
    class Looker(StandStill):
        def __init__(self) -> None:
            super().__init__()
            self.shapes: list[tuple] = []

        def step(self, observation: Observation) -> Control:
            assert observation.detections is None
            if observation.image is not None:
                self.shapes.append(observation.image.shape)
            return super().step(observation)

    stack = Looker()
    EmbeddedBackend(perception="camera", sim_timeout=0.5).run(make_situation(1), stack, 0)
    assert stack.shapes == [(450, 800, 3)] * 5


@pytest.mark.slow
def test_early_end_never_changes_a_verdict() -> None:
    """Every run ended as ``stopped`` (the latched AEB: the releasing one never ends a
    run early) would also pass if simulated to the 60 s timeout, and gets that run's
    verdict under every judge."""
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import make_stack
    from sitcov.generation import make_generator

    generator = make_generator("random", load_hyperspace())
    fast, full = EmbeddedBackend(), EmbeddedBackend(early_end=False)
    checked = 0
    for fault in (None, "f2"):
        stack = make_stack("reference-latched", fault=fault)
        for i in range(40):
            situation = generator.ask(ask_rng(11, i))
            outcome = fast.run(situation, stack, run_seed(11, i))
            if outcome.end_reason != "stopped":
                continue
            checked += 1
            whole = full.run(situation, stack, run_seed(11, i))
            assert whole.status == "pass"
            for judge in ("default", "paper", "strict"):
                verdict = Judge.from_spec(judge)
                assert verdict.kind(outcome) == verdict.kind(whole), (i, judge)
    assert checked >= 20


def test_another_map_runs_unchanged(tmp_path) -> None:
    backend = EmbeddedBackend(map="skewed-cross")
    outcome = backend.run(make_situation(5), NoPerceptionStack(), 0, record=True)
    assert outcome.collision  # the adversary works on any geometry
    assert outcome.trace.meta["map"] == "skewed-cross"
    assert render_topdown(outcome, tmp_path / "cross.png").stat().st_size > 10_000
