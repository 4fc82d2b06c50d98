"""Helpers for the simulation tests: situations built from the default hyperspace."""

from __future__ import annotations

from typing import Any

from sitcov.hyperspace import Situation

#: The paper's twelve intersection situations: (ego, OV, conflict label).
INTSITS = [
    ("L-B", "R-B", "c4"),
    ("L-R", "R-B", "c4"),
    ("L-R", "B-R", "c1"),
    ("L-R", "B-L", "c1"),
    ("B-L", "L-R", "c1"),
    ("B-L", "R-L", "c2"),
    ("B-L", "R-B", "c2"),
    ("B-R", "L-R", "c1"),
    ("R-L", "B-L", "c2"),
    ("R-B", "B-L", "c2"),
    ("R-B", "L-R", "c4"),
    ("R-B", "L-B", "c4"),
]


def make_situation(intsit: int = 1, **env: Any) -> Situation:
    """A situation with IntSit-``intsit`` and the given environment values (others absent)."""
    ego, ov, label = INTSITS[intsit - 1]
    values: dict[str, Any] = dict(env)
    values["intsit"] = {"ego": ego, "ov": ov, "conflict": label}
    bins = {k: str(v) for k, v in env.items()}
    bins["intsit"] = f"IntSit-{intsit}"
    return Situation(bins=bins, values=values)
