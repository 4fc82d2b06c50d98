from __future__ import annotations

import pytest

from sitcov.hyperspace import Hyperspace, load_hyperspace

CONSTRAINTS = [
    {"forbid": {"friction": ["0.1"], "intsit": ["IntSit-3"]}},
    {"forbid": {"friction": ["0.1", "0.2"], "fog_density": ["100"]}},
    {"forbid": {"intsit": ["IntSit-12"], "wetness": ["0", "20", "40", "60", "80"]}},
]


@pytest.fixture(scope="session")
def default_hs() -> Hyperspace:
    return load_hyperspace()


@pytest.fixture(scope="session")
def constrained_hs() -> Hyperspace:
    d = load_hyperspace().to_dict()
    d["constraints"] = CONSTRAINTS
    return Hyperspace.from_dict(d)
