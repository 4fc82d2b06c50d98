"""The golden two-car runs of the embedded world: record them, or compare against them.

The world-of-actors redesign must reproduce the two-car runs exactly. This module records
``Outcome.to_dict()`` for random default-hyperspace situations (the ``random`` generator,
as ``sitcov bench`` draws them) x two seeds x both physics profiles x four stacks (the
reference stack, F2, F3 and the blind ego), in PEM mode with the PEM parameters pinned to
a copy (``data/golden_world_pem.yaml``) so a PEM refit does not move the golden values.
The situations' values are stored with the outcomes, so a change of the default
hyperspace does not move them either.

Write (only on purpose, with the code whose results are the reference)::

    PYTHONPATH=. python tests/sim/_golden_world.py --write
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

DATA = Path(__file__).parent / "data"
GOLDEN = DATA / "golden_world_two_cars.json"
PEM = DATA / "golden_world_pem.yaml"
#: Situations drawn, seeds per situation, profiles and stacks (fault or "blind").
N_SITUATIONS = 60
SEEDS = (0, 1)
PROFILES = ("carla", "physical")
STACKS = (None, "f2", "f3", "blind")


def situations() -> list[dict[str, Any]]:
    """The values of the first ``N_SITUATIONS`` random default-hyperspace situations."""
    from sitcov._seeding import ask_rng
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.hyperspace._situation import _thaw

    generator = make_generator("random", load_hyperspace())
    out = []
    for i in range(N_SITUATIONS):
        s = generator.ask(ask_rng(0, i))
        out.append({"bins": dict(s.bins), "values": _thaw(s.values)})
    return out


def cases(stored: list[dict[str, Any]], stacks: tuple[Any, ...] = STACKS):
    """Yield (key, stored item, situation, stack, physics, seed) for every golden run of
    ``stored`` with each of ``stacks`` (both golden files enumerate their runs this way)."""
    from sitcov._seeding import run_seed
    from sitcov.hyperspace import Situation

    for i, item in enumerate(stored):
        situation = Situation(bins=item["bins"], values=item["values"])
        for physics in PROFILES:
            for stack in stacks:
                for seed in SEEDS:
                    key = f"{i}/{physics}/{stack}/{seed}"
                    yield key, item, situation, stack, physics, run_seed(seed, i)


def make_stacks(names: tuple[Any, ...]) -> dict[Any, Any]:
    """The golden stacks by name: a reference stack with that fault (None: none), or
    ``"blind"``, the stack without perception."""
    from sitcov.av import NoPerceptionStack, ReferenceStack

    return {s: NoPerceptionStack() if s == "blind" else ReferenceStack(fault=s) for s in names}


def run_all(stored: list[dict[str, Any]], every: int = 1) -> dict[str, dict[str, Any]]:
    """Outcome dicts of every ``every``-th golden case, keyed as in the golden file."""
    from sitcov.perception import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    # the per-class PEM pinned too (the multi-actor golden's copy: the per-class file these
    # outcomes were recorded with), so a per-class refit does not move them either
    classes = str(DATA / "golden_actors_pem_classes.yaml")
    backends = {
        p: EmbeddedBackend(physics=p, sensor=PEMSensor(params=str(PEM), classes=classes))
        for p in PROFILES
    }
    stacks = make_stacks(STACKS)
    out = {}
    for n, (key, _, situation, stack, physics, seed) in enumerate(cases(stored)):
        if n % every:
            continue
        outcome = backends[physics].run(situation, stacks[stack], seed)
        out[key] = json.loads(json.dumps(outcome.to_dict()))
    return out


def differences(expected: dict[str, Any], actual: dict[str, Any]) -> list[str]:
    """The fields of two outcome dicts that differ, as ``name: expected != actual``."""
    return [
        f"{k}: {expected.get(k)!r} != {actual.get(k)!r}"
        for k in sorted(set(expected) | set(actual))
        if expected.get(k) != actual.get(k)
    ]


def assert_reproduced(golden: dict[str, Any], actual: dict[str, dict[str, Any]]) -> None:
    """Every run in ``actual`` equals its golden outcome exactly (shared by both golden tests)."""
    assert actual, "no golden case ran"
    bad = {key: differences(golden["outcomes"][key], out) for key, out in actual.items()}
    bad = {key: d for key, d in bad.items() if d}
    assert not bad, f"{len(bad)} of {len(actual)} runs differ, e.g. {next(iter(bad.items()))}"


def main() -> None:
    """Write the golden file from the current code."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--write", action="store_true", help="(re)write the golden file")
    args = parser.parse_args()
    if not args.write:
        parser.error("nothing to do: pass --write to record the golden file")
    stored = situations()
    golden = {"situations": stored, "outcomes": run_all(stored)}
    GOLDEN.write_text(json.dumps(golden, indent=None, sort_keys=True) + "\n", encoding="utf-8")
    print(f"wrote {len(golden['outcomes'])} outcomes to {GOLDEN}")


if __name__ == "__main__":
    main()
