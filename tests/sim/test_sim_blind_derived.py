"""Every derived conflict is real: a blind ego is hit in each one (clear weather, mu = 1).

The ego never brakes (``NoPerceptionStack``: no detections, so no AEB) and the adversary
times the other road user's arrival at the derived conflict point; if the two never touch,
the derivation listed a conflict that is not one. Run on every shipped map's derived
hyperspace (``sitcov/hyperspace/data/derived``), per kind of road user. A cyclist or
pedestrian synchronises its arrival up to the conflict (no early switch: ``_scene``).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

from sitcov.av import NoPerceptionStack
from sitcov.hyperspace import Situation
from sitcov.sim.embedded import EmbeddedBackend

DERIVED = Path(__file__).resolve().parents[2] / "sitcov" / "hyperspace" / "data" / "derived"
SMALL = ("t-junction", "merge")
MAPS = [
    m if m in SMALL else pytest.param(m, marks=pytest.mark.slow)
    for m in ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge")
]


def _situations(name: str, kind: str) -> list[tuple[str, dict]]:
    doc = yaml.safe_load((DERIVED / f"{name}.yaml").read_text())
    bins = doc["axes"][1]["elements"][0]["bins"]
    return [(b["label"], b["value"]) for b in bins if b["value"]["kind"] == kind]


@pytest.mark.parametrize("kind", ["car", "cyclist", "pedestrian"])
@pytest.mark.parametrize("name", MAPS)
def test_blind_ego_collides_in_every_derived_conflict(name: str, kind: str) -> None:
    situations = _situations(name, kind)
    if name == "merge" and kind == "pedestrian":
        assert situations == []  # the merge has no crosswalks
        return
    assert situations, f"{name} lists no {kind} conflicts"
    backend = EmbeddedBackend(map=name)
    missed = []
    for label, value in situations:
        situation = Situation(
            bins={"intsit": label, "friction": "1.0"},
            values={"intsit": value, "friction": 1.0},
        )
        outcome = backend.run(situation, NoPerceptionStack(), seed=0)
        assert not outcome.aeb_fired
        if not outcome.collision:
            missed.append(label)
    assert missed == [], f"{len(missed)} of {len(situations)} derived conflicts missed"


@pytest.mark.parametrize(
    ("name", "ego", "kind", "route"),
    [
        ("roundabout", "B-L", "cyclist", "T-R"),  # circles 3/4 of the ring to the ego's entry
        ("skewed-cross", "L-R", "pedestrian", "XRL"),  # the crosswalk of the ego's exit leg
    ],
)
def test_conflicts_a_blind_ego_once_missed_are_real_crossings(name, ego, kind, route) -> None:
    """The routes cross where the conflict lies (centre lines within 5 cm), so a miss there
    is the timing's fault, not the derivation's; a cyclist or pedestrian synchronises up to
    the conflict (switch distance 0) and is hit."""
    from sitcov.sim.embedded._map import load_map
    from sitcov.sim.embedded._routes import actor_route
    from sitcov.sim.embedded._scene import _geometry, ego_route

    m = load_map(name)
    er = ego_route(m, ego)
    start = None if kind == "pedestrian" else m.spawns["ov"][route[0]]
    path, conflict, _ = _geometry(m, ego, "ov", kind, route, start)
    assert conflict is not None and path.length <= actor_route(m, kind, route).length
    e = np.asarray(er.resampled(0.1))
    a = np.asarray(path.resampled(0.1))
    s = np.linspace(0.0, er.length, len(e))
    near = e[(s > conflict.s_ego - 5.0) & (s < conflict.s_ego_end + 5.0)]
    gap = np.hypot(near[:, None, 0] - a[None, :, 0], near[:, None, 1] - a[None, :, 1]).min()
    assert gap < 0.05
    value = {"ego": ego, "ov": route, "conflict": "k", "kind": kind}
    situation = Situation(
        bins={"intsit": "x", "friction": "1.0"}, values={"intsit": value, "friction": 1.0}
    )
    outcome = EmbeddedBackend(map=name).run(situation, NoPerceptionStack(), seed=0)
    assert outcome.collision and outcome.metrics["collision_kind"] == kind
    assert outcome.metrics["ov_switch_distance"] == 0.0
