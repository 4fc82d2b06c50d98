"""The reference stack on the embedded backend: in clear, dry weather its AEB saves it."""

from __future__ import annotations

import numpy as np

from sitcov.av import NoPerceptionStack, ReferenceStack
from sitcov.hyperspace import load_hyperspace
from sitcov.sim.embedded import EmbeddedBackend


def _clear_situations():
    hs = load_hyperspace()
    rng = np.random.default_rng(0)
    out = []
    for k in range(1, 13):
        bins = {e.name: e.bins[0].label for e in hs.elements}  # all weather at 0
        bins.update(friction="1.0", intsit=f"IntSit-{k}")
        out.append(hs.situation_from_bins(bins, rng))
    return out


def test_aeb_prevents_most_collisions_that_a_blind_stack_has():
    backend = EmbeddedBackend()
    situations = _clear_situations()
    seeing = [backend.run(s, ReferenceStack(), 1) for s in situations]
    blind = [backend.run(s, NoPerceptionStack(), 1) for s in situations]
    assert sum(o.failed for o in blind) >= 11
    assert not any(o.aeb_fired for o in blind)
    assert sum(not o.failed for o in seeing) >= 10
    assert all(o.aeb_fired and o.aeb_time is not None for o in seeing)


def test_runs_are_reproducible_with_a_reused_stack():
    backend = EmbeddedBackend()
    situation = _clear_situations()[4]
    stack = ReferenceStack(fault="f2")
    first = backend.run(situation, stack, 7)
    backend.run(_clear_situations()[0], stack, 8)  # a different run in between
    assert backend.run(situation, stack, 7) == first


class _ProtocolStack(ReferenceStack):
    """The reference stack seen only through the AVStack protocol (its ``step`` is its
    own, so the backend cannot take the built-in stack's plain-values path)."""

    def step(self, observation):
        return super().step(observation)


def test_the_backends_plain_values_path_gives_the_protocols_outcomes():
    """The embedded backend steps the built-in stack on plain values (``plain_step``);
    a subclass with its own ``step`` goes through Observation/Control: the same outcomes,
    AEB firing times included, with and without a fault."""
    assert ReferenceStack().plain_step() is not None
    assert _ProtocolStack().plain_step() is None
    backend = EmbeddedBackend()
    situations = _clear_situations()
    fired = 0
    for fault in (None, "f2"):
        for i, situation in enumerate(situations):
            plain = backend.run(situation, ReferenceStack(fault=fault), 30 + i)
            protocol = backend.run(situation, _ProtocolStack(fault=fault), 30 + i)
            assert plain == protocol, (fault, i)
            fired += plain.aeb_fired
    assert fired >= 10  # the AEB's latch went through both paths
