"""Physics profiles and delays in the embedded backend, end to end.

``carla`` (default): weather other than friction never reaches the vehicles; ``physical``:
wet roads lose grip and the wind pushes. Delays: the AEB's braking shifts by the delay.
"""

from __future__ import annotations

import pytest
from _sim_helpers import make_situation

from sitcov.av import NoPerceptionStack, ReferenceStack
from sitcov.errors import ConfigError
from sitcov.hyperspace import load_hyperspace
from sitcov.sim import PHYSICS_PROFILES, Outcome, make_backend
from sitcov.sim.embedded import EmbeddedBackend

WET = {"wetness": 100.0, "precipitation": 80.0, "precipitation_deposits": 60.0}


def test_physics_option_is_validated() -> None:
    with pytest.raises(ConfigError, match=r"^physics: expected carla \| physical, got 'real'$"):
        EmbeddedBackend(physics="real")
    with pytest.raises(ConfigError, match="perception_delay: expected seconds >= 0"):
        make_backend("embedded", perception_delay=-0.1)
    with pytest.raises(ConfigError, match="brake_delay: expected seconds >= 0"):
        EmbeddedBackend(brake_delay="soon")  # type: ignore[arg-type]


def test_delay_defaults_per_profile() -> None:
    carla, physical = EmbeddedBackend(), EmbeddedBackend(physics="physical")
    assert (carla.perception_delay, carla.brake_delay) == (0.0, 0.0)  # CARLA: next tick
    assert 0.1 <= physical.brake_delay <= 0.4  # brake build-up of a passenger car
    assert EmbeddedBackend(physics="physical", brake_delay=0.0).brake_delay == 0.0


@pytest.mark.parametrize("physics", PHYSICS_PROFILES)
def test_effects_per_profile_cover_the_hyperspace(physics: str) -> None:
    effects = EmbeddedBackend(physics=physics).effects()
    for element in load_hyperspace().element_names:
        assert effects.get(element), element


def test_effects_differ_where_the_profiles_do() -> None:
    carla = EmbeddedBackend().effects()
    physical = EmbeddedBackend(physics="physical").effects()
    for element in ("wetness", "precipitation", "precipitation_deposits", "wind_intensity"):
        assert carla[element] != physical[element]
        assert "perception only" in carla[element]
    assert carla["fog_density"] == physical["fog_density"]


def test_metrics_store_profile_and_mu() -> None:
    situation = make_situation(4, friction=0.6, **WET)
    carla = EmbeddedBackend(sim_timeout=1.0).run(situation, NoPerceptionStack(), 0)
    physical = EmbeddedBackend(physics="physical", sim_timeout=1.0).run(
        situation, NoPerceptionStack(), 0
    )
    assert (carla.metrics["physics"], carla.metrics["mu"]) == ("carla", 0.6)
    assert physical.metrics["physics"] == "physical"
    assert 0.0 < physical.metrics["mu"] < carla.metrics["mu"]


def _without_metrics(outcome: Outcome) -> Outcome:
    return Outcome(**{**outcome.__dict__, "metrics": {}})


@pytest.mark.parametrize(("intsit", "seed"), [(1, 0), (4, 3), (6, 7), (11, 2)])
def test_carla_profile_weather_leaves_the_drive_unchanged(intsit: int, seed: int) -> None:
    """Wind 0 vs 100: identical trajectories and verdicts (wind only slants the rain)."""
    backend = EmbeddedBackend()
    calm = backend.run(make_situation(intsit, friction=0.4), ReferenceStack(), seed, record=True)
    stormy = backend.run(
        make_situation(intsit, friction=0.4, wind_intensity=100.0),
        ReferenceStack(),
        seed,
        record=True,
    )
    assert calm.trace.ego == stormy.trace.ego
    assert calm.trace.ov == stormy.trace.ov
    assert _without_metrics(calm) == _without_metrics(stormy)
    assert calm.metrics["mu"] == stormy.metrics["mu"] == 0.4


def test_physical_profile_wind_pushes() -> None:
    backend = EmbeddedBackend(physics="physical", adversary={"switch_distance": 1e9})
    calm = backend.run(make_situation(4), NoPerceptionStack(), 5, record=True)
    windy = backend.run(
        make_situation(4, wind_intensity=100.0), NoPerceptionStack(), 5, record=True
    )
    n = min(len(calm.trace.ego), len(windy.trace.ego)) - 1
    drift = max(
        abs(calm.trace.ego[i][1] - windy.trace.ego[i][1])
        + abs(calm.trace.ego[i][2] - windy.trace.ego[i][2])
        for i in range(n)
    )
    assert drift > 0.02


def _braking_onset(outcome: Outcome) -> float:
    """First recorded time the ego is 0.2 m/s slower than when the AEB fired [s]."""
    rows = outcome.trace.ego
    v_fire = next(r[4] for r in rows if r[0] >= outcome.aeb_time - 1e-9)
    return next(r[0] for r in rows if r[0] > outcome.aeb_time and r[4] < v_fire - 0.2)


@pytest.mark.parametrize("intsit", [1, 5, 9])
def test_brake_delay_shifts_the_aeb_braking(intsit: int) -> None:
    situation = make_situation(intsit)
    prompt = EmbeddedBackend().run(situation, ReferenceStack(), 0, record=True)
    late = EmbeddedBackend(brake_delay=0.2).run(situation, ReferenceStack(), 0, record=True)
    assert prompt.aeb_fired and late.aeb_fired
    assert late.aeb_time == prompt.aeb_time  # same perception, same decision
    shift = _braking_onset(late) - _braking_onset(prompt)
    assert shift == pytest.approx(0.2, abs=0.026)


@pytest.mark.parametrize("intsit", [1, 5, 9])
def test_perception_delay_shifts_the_aeb(intsit: int) -> None:
    situation = make_situation(intsit)
    prompt = EmbeddedBackend().run(situation, ReferenceStack(), 0, record=True)
    late = EmbeddedBackend(perception_delay=0.2).run(situation, ReferenceStack(), 0, record=True)
    assert prompt.aeb_fired and late.aeb_fired
    assert late.aeb_time - prompt.aeb_time == pytest.approx(0.2, abs=0.051)
    shift = _braking_onset(late) - _braking_onset(prompt)
    assert shift == pytest.approx(0.2, abs=0.051)
