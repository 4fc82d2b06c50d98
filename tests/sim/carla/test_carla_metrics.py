"""The CARLA backend (on its fake) reports min_ttc and pet with the shared definition.

The definition itself is checked by hand in tests/sim/test_sim_metrics.py; here the
plumbing: routes in the sitcov frame, vehicle sizes, and the collided flag.
"""

from __future__ import annotations

from carla_testkit import DrivingStack, fake_backend, situation, small_map


def test_a_collision_has_zero_pet_and_zero_time_to_collision(tmp_path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    outcome = backend.run(situation("L-R", "B-R", "c1"), DrivingStack(), seed=1)
    assert outcome.end_reason == "collision"
    assert outcome.pet == 0.0  # both reached the conflict zone and collided
    assert outcome.min_ttc == 0.0  # the footprint discs overlapped before the contact


def test_a_crossing_without_contact_has_a_positive_pet(tmp_path) -> None:
    backend, _ = fake_backend(small_map(tmp_path))
    outcome = backend.run(situation("B-L", "R-B", "c2"), DrivingStack(), seed=1)
    assert outcome.status == "pass"
    assert outcome.pet is not None and 0.0 < outcome.pet < 5.0
    assert outcome.min_ttc is not None and outcome.min_ttc >= 0.0
