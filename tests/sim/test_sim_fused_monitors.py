"""The built-in monitors' per-step work in one call (``_monitors.fused_update``): used only
for the built-in list, and the same results as calling every monitor through the public
protocol (the golden files check the fused path; here the public one, and which lists are
fused)."""

from __future__ import annotations

import json

import pytest
from _golden_actors import GOLDEN, run_all
from _golden_world import assert_reproduced

from sitcov.sim.embedded import _backend
from sitcov.sim.embedded._monitors import (
    EarlyEndMonitor,
    PETMonitor,
    ProximityMonitor,
    default_monitors,
    fused_update,
)


class _Counting(ProximityMonitor):
    """A user's subclass of a built-in monitor: must go through its own ``update``."""

    calls = 0

    def update(self, world) -> None:
        type(self).calls += 1
        super().update(world)


def _world_and_monitors(early_end: bool):
    """A real run's world (the backend's first golden situation) and its built-in list."""
    golden = json.loads(GOLDEN.read_text(encoding="utf-8"))
    captured = {}
    real = _backend.run_loop

    def capture(world, monitors, n_max, record):
        captured["world"], captured["monitors"] = world, monitors
        return real(world, monitors, 5, record)

    from _golden_world import cases, make_stacks

    key, item, situation, stack, physics, seed = next(iter(cases(golden["situations"][:1])))
    backend = _backend.EmbeddedBackend(map=item["map"], physics=physics)
    mp = pytest.MonkeyPatch()
    mp.setattr(_backend, "run_loop", capture)
    try:
        backend.run(situation, make_stacks((stack,))[stack], seed)
    finally:
        mp.undo()
    world, monitors = captured["world"], captured["monitors"]
    m = list(monitors)
    lane, road = m[0].lane, m[0].road
    return world, default_monitors(world, lane, road, early_end, 60.0)


def test_the_built_in_list_is_fused_with_and_without_the_early_end() -> None:
    world, monitors = _world_and_monitors(early_end=False)
    update, rest = fused_update(world, monitors)
    assert update is not None and rest == []
    world, monitors = _world_and_monitors(early_end=True)
    update, rest = fused_update(world, monitors)
    assert update is not None and [type(m) for m in rest] == [EarlyEndMonitor]


def test_other_lists_go_through_the_public_protocol() -> None:
    world, monitors = _world_and_monitors(early_end=False)
    for other in (
        monitors[1:],  # the route monitor left out
        [monitors[1], monitors[0], *monitors[2:]],  # reordered
        [*monitors[:2], _Counting(world), *monitors[3:]],  # a user's subclass
        monitors[:-1],  # no progress monitor
        [],
    ):
        update, rest = fused_update(world, other)
        assert update is None and rest == list(other)
    assert isinstance(monitors[1], PETMonitor)


def test_public_protocol_reproduces_the_golden_multi_actor_runs(monkeypatch) -> None:
    """Every monitor called one by one gives the golden outcomes the fused call gives."""
    monkeypatch.setattr(_backend, "fused_update", lambda world, ms: (None, list(ms)))
    golden = json.loads(GOLDEN.read_text(encoding="utf-8"))
    assert_reproduced(golden, run_all(golden["situations"], every=7))
