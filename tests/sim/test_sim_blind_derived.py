"""Every derived conflict is real: a blind ego is hit in each one (clear weather, mu = 1).

The ego never brakes (``NoPerceptionStack``: no detections, so no AEB) and the adversary
times the other road user's arrival at the derived conflict point; if the two never touch,
the derivation listed a conflict that is not one. Run on every shipped map's derived
hyperspace (``sitcov/hyperspace/data/derived``), per kind of road user. A cyclist or
pedestrian synchronises its arrival up to the conflict (no early switch: ``_scene``).
"""

from __future__ import annotations

from pathlib import Path

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
