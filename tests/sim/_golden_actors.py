"""The golden multi-actor runs of the embedded world: record them, or compare against them.

The two-car golden file (``_golden_world.py``) pins the paper's situations only. This one
pins scenes with several road users on every shipped map (t-junction, crossroads,
roundabout, merge): ``Outcome.to_dict()`` of situations drawn from the shipped derived
hyperspaces (``sitcov/hyperspace/data/derived/<map>.yaml``: the ``intsit`` actor and the
``actor2`` slot) and from the same derivation with a third slot (``actor3``), x two seeds x
both physics profiles x three stacks: the reference stack, the pedestrian-ignoring fault
(``f4``) and the blind ego. Per map and per intsit kind (car, cyclist, pedestrian where the
map has it) the draws are chosen to have no extra actor, an ``actor2``, and an ``actor3``;
every other one is set to clear weather, so that the stacks' braking matters. The
situations with two extra actors come again with a behaviour per slot (scripted cruise /
stop / stop-go, pedestrian cross / kerb / hesitate), so every controller runs.

PEM mode with both PEMs pinned to copies in ``data/``: the car PEM
(``golden_world_pem.yaml``, shared with the two-car golden) and the per-class PEM
(``golden_actors_pem_classes.yaml``, every parameter written out so that a car PEM
refit cannot move it either). The situations' values are stored with the outcomes, so a
re-derivation of the hyperspaces does not move them.

Write (only on purpose, with the code whose results are the reference)::

    PYTHONPATH=. python tests/sim/_golden_actors.py --write

``--write-classes`` (re)writes the pinned per-class PEM from the shipped one first; do not
run it unless the golden outcomes are rewritten too.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from _golden_world import cases, make_stacks

DATA = Path(__file__).parent / "data"
GOLDEN = DATA / "golden_world_actors.json"
PEM = DATA / "golden_world_pem.yaml"
PEM_CLASSES = DATA / "golden_actors_pem_classes.yaml"
MAPS = ("t-junction", "crossroads", "roundabout", "merge")
#: Stacks (fault or "blind"); seeds per situation and profiles as in _golden_world.py.
STACKS = (None, "f4", "blind")
#: Weather elements set to 0 in the clear-weather situations (friction is kept as drawn).
CLEAR = ("cloudiness", "precipitation", "precipitation_deposits", "wind_intensity")
CLEAR += ("fog_density", "wetness")
#: Random draws tried per map before giving up on filling every (kind, extra) quota.
MAX_DRAWS = 4000


def _kind(values: dict[str, Any]) -> str:
    return values["intsit"].get("kind", "car")


def _extra(values: dict[str, Any]) -> str:
    """Which extra slot is the last one filled: "none", "actor2" or "actor3"."""
    if values.get("actor3", "none") != "none":
        return "actor3"
    return "actor2" if values.get("actor2", "none") != "none" else "none"


def _clear(hyperspace, bins: dict[str, str]) -> dict[str, str]:
    """``bins`` with the weather elements of :data:`CLEAR` at their value-0 bin."""
    out = dict(bins)
    for name in CLEAR:
        element = hyperspace.element(name)
        out[name] = next(b.label for b in element.bins if b.value == 0)
    return out


def _draws(hyperspace, seed: int):
    """Random situations of ``hyperspace`` (the ``random`` generator, as campaigns draw)."""
    from sitcov._seeding import ask_rng
    from sitcov.generation import make_generator

    generator = make_generator("random", hyperspace)
    for i in range(MAX_DRAWS):
        yield generator.ask(ask_rng(seed, i))


def map_situations(map_name: str) -> list[dict[str, Any]]:
    """One situation per (intsit kind, extra slot) of ``map_name``, every other one clear."""
    from sitcov.hyperspace import load_hyperspace
    from sitcov.hyperspace._situation import _thaw
    from sitcov.sim.embedded._derive import derive_hyperspace

    shipped = Path(__file__).parents[2] / "sitcov/hyperspace/data/derived" / f"{map_name}.yaml"
    two = load_hyperspace(shipped)
    three = load_hyperspace(derive_hyperspace(map_name, two.metadata["actors"], max_actors=3))
    picked: dict[tuple[str, str], Any] = {}
    for extras, hyperspace, seed in ((("none", "actor2"), two, 0), (("actor3",), three, 1)):
        kinds = hyperspace.element("intsit").metadata["kinds"]
        wanted = {(k, e) for k in kinds for e in extras}
        for s in _draws(hyperspace, seed):
            key = (_kind(s.values), _extra(s.values))
            if key in wanted and key not in picked:
                picked[key] = (hyperspace, s)
            if wanted <= set(picked):
                break
    out = []
    for n, key in enumerate(sorted(picked)):
        hyperspace, s = picked[key]
        bins = _clear(hyperspace, dict(s.bins)) if n % 2 == 0 else dict(s.bins)
        s = hyperspace.situation_from_bins(bins)
        out.append({"map": map_name, "bins": dict(s.bins), "values": _thaw(s.values)})
    return out


def with_behaviours(items: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Copies of the situations with two extra actors, each slot given a scripted or
    pedestrian behaviour in turn (cruise, stop, stop-go; cross, kerb, hesitate), so that
    every controller of the scene runs in the golden file (derived slots leave it unset:
    the timing law)."""
    from sitcov.sim.embedded._scene import BEHAVIOURS

    names = {
        kind: [b for b, kinds in BEHAVIOURS.items() if kind in kinds and b != "timed"]
        for kind in ("car", "cyclist", "pedestrian")
    }
    out: list[dict[str, Any]] = []
    turn = dict.fromkeys(names, 0)  # per kind: every behaviour of a kind in turn
    for item in items:
        if item["values"].get("actor3", "none") == "none":
            continue
        values, bins = dict(item["values"]), dict(item["bins"])
        for slot in ("actor2", "actor3"):
            kind = values[slot]["kind"]
            behaviour = names[kind][turn[kind] % len(names[kind])]
            turn[kind] += 1
            values[slot] = {**values[slot], "behaviour": behaviour}
            bins[slot] = f"{bins[slot]}/{behaviour}"
        out.append({"map": item["map"], "bins": bins, "values": values})
    return out


def situations() -> list[dict[str, Any]]:
    """The golden situations of every map in :data:`MAPS`, with their map; then the ones
    with two extra actors again, with behaviours (appended: earlier keys keep their index)."""
    drawn = [item for m in MAPS for item in map_situations(m)]
    return drawn + with_behaviours(drawn)


def run_all(stored: list[dict[str, Any]], every: int = 1) -> dict[str, dict[str, Any]]:
    """Outcome dicts of every ``every``-th golden case, keyed as in the golden file."""
    from sitcov.perception import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    backends: dict[tuple[str, str], Any] = {}
    stacks = make_stacks(STACKS)
    out = {}
    for n, (key, item, situation, stack, physics, seed) in enumerate(cases(stored, STACKS)):
        if n % every:
            continue
        map_name = item["map"]
        if (map_name, physics) not in backends:
            sensor = PEMSensor(params=str(PEM), classes=str(PEM_CLASSES))
            backends[map_name, physics] = EmbeddedBackend(
                map=map_name, physics=physics, sensor=sensor
            )
        outcome = backends[map_name, physics].run(situation, stacks[stack], seed)
        out[key] = json.loads(json.dumps(outcome.to_dict()))
    return out


def write_classes() -> None:
    """Copy the shipped per-class PEM with every parameter written out (see module doc)."""
    import yaml

    from sitcov.perception._pem_classes import PEM_CLASSES_FILE, load_class_params

    classes = {
        kind: {"label": label, "params": params.to_dict()}
        for kind, (label, params) in load_class_params(PEM_CLASSES_FILE).items()
    }
    header = (
        "# Pinned copy of sitcov/perception/data/pem_classes.yaml for the multi-actor golden\n"
        "# runs (tests/sim/_golden_actors.py), every parameter written out (missing names\n"
        "# would take the shipped car PEM's values). Do not edit: a change moves the goldens.\n"
    )
    text = yaml.safe_dump({"classes": classes}, sort_keys=False)
    PEM_CLASSES.write_text(header + text, encoding="utf-8")
    print(f"wrote {PEM_CLASSES}")


def main() -> None:
    """Write the golden file from the current code."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--write", action="store_true", help="(re)write the golden file")
    parser.add_argument(
        "--write-classes", action="store_true", help="(re)write the pinned per-class PEM first"
    )
    args = parser.parse_args()
    if not (args.write or args.write_classes):
        parser.error("nothing to do: pass --write to record the golden file")
    if args.write_classes:
        write_classes()
    if args.write:
        stored = situations()
        golden = {"situations": stored, "outcomes": run_all(stored)}
        text = json.dumps(golden, indent=None, sort_keys=True) + "\n"
        GOLDEN.write_text(text, encoding="utf-8")
        print(f"wrote {len(golden['outcomes'])} outcomes to {GOLDEN}")


if __name__ == "__main__":
    main()
