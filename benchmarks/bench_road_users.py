"""How the road users other than the ego behave: actor-actor collisions, collisions into a
standing ego, timed pedestrians' and cyclists' top speeds (issue 23's checks).

Usage: python benchmarks/bench_road_users.py [--maps t-junction,...] [--runs 200] [--seed 0]
       [--ego blind|halt]

Per map: ``--runs`` two-actor scenes (``intsit`` plus an ``actor2`` that is not ``none``)
from the map's derived hyperspace (``sitcov/hyperspace/data/derived``, the ``random``
generator with ``ask_rng(seed, i)``, run seed ``run_seed(seed, i)``), on a dry road in
clear weather (friction 1.0; rain, puddles, wetness, wind and fog 0). The ego is

- ``blind``: ``NoPerceptionStack``, which drives its route and never brakes;
- ``halt``: the same stack, which brakes to a stop once it has driven a share of its route
  drawn per run uniformly in [0.3, 0.7] and stands there for good (a standing ego before,
  in or after the junction, where the others' routes cross its own);
- ``reference``: the reference stack (its emergency brake stops the ego for good).

Reported per map: the scenes with an actor-actor collision; the ego's collisions with a
pedestrian or cyclist while the ego stood (below :data:`STANDING` m/s at the contact, the
issue's measure), and among them those where the ego had stood for :data:`STOOD` s or more
(the road user walked or rode into a car that stood; the others are an ego braking to a
stop across the path of a road user too close to stop: at 3.5 m/s^2 a cyclist at 5 m/s
needs 3.6 m); the top speed of every timed pedestrian and cyclist (``behaviour``
``timed``: the adversary's role) that moved, its median and 5th / 95th percentiles.
"""

from __future__ import annotations

import argparse
import statistics
from typing import Any

import numpy as np

from sitcov._seeding import ask_rng, run_seed
from sitcov.av import NoPerceptionStack, ReferenceStack
from sitcov.av._base import Control, Observation, RunInfo
from sitcov.generation import make_generator
from sitcov.hyperspace import Situation, load_hyperspace
from sitcov.sim.embedded import EmbeddedBackend

MAPS = ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge")
#: Dry road, clear weather.
DRY = {
    "friction": 1.0,
    "precipitation": 0,
    "precipitation_deposits": 0,
    "wetness": 0,
    "wind_intensity": 0,
    "fog_density": 0,
}
#: The ego counts as standing below this speed [m/s] (issue 23's measure).
STANDING = 0.3
#: ... and had stood at least this long [s] (about a perception-reaction time).
STOOD = 1.0
VRU = ("pedestrian", "cyclist")


class HaltingStack(NoPerceptionStack):
    """Drives its route blindly, then brakes to a stop for good once it is nearest to the
    route point ``halt`` (a share of the route drawn per run from its seed, uniformly in
    [0.3, 0.7])."""

    name = "halting"

    def reset(self, info: RunInfo) -> None:
        """Start a run; draw where it halts."""
        super().reset(info)
        self.points = np.asarray(info.route)
        share = float(np.random.default_rng([23, info.seed]).uniform(0.3, 0.7))
        self.halt = int(share * (len(self.points) - 1))
        self.halted = False

    def step(self, observation: Observation) -> Control:
        """Route following until the halt point, full brake from there on."""
        control = super().step(observation)
        if not self.halted:
            ego = observation.ego
            d = np.hypot(self.points[:, 0] - ego.x, self.points[:, 1] - ego.y)
            self.halted = int(np.argmin(d)) >= self.halt
        return Control(0.0, 1.0, control.steer) if self.halted else control


def two_actor_scenes(name: str, runs: int, seed: int) -> list[tuple[int, Situation]]:
    """``runs`` (index, situation) pairs of the map's derived hyperspace with an actor2."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[1] / "sitcov/hyperspace/data/derived" / f"{name}.yaml"
    generator = make_generator("random", load_hyperspace(path))
    out: list[tuple[int, Situation]] = []
    i = 0
    while len(out) < runs:
        s = generator.ask(ask_rng(seed, i))
        if s.values.get("actor2", "none") != "none":
            values = {**s.values, **{k: v for k, v in DRY.items() if k in s.values}}
            out.append((i, Situation(bins=dict(s.bins), values=values)))
        i += 1
    return out


def measure(name: str, runs: int, seed: int = 0, ego: str = "blind") -> dict[str, Any]:
    """The map's counts and timed road users' top speeds (module docstring)."""
    backend = EmbeddedBackend(map=name)
    stack = {"blind": NoPerceptionStack, "halt": HaltingStack, "reference": ReferenceStack}[ego]()
    a2a = into_standing = into_stood = ego_hits = 0
    tops: dict[str, list[float]] = {k: [] for k in VRU}
    for i, situation in two_actor_scenes(name, runs, seed):
        o = backend.run(situation, stack, run_seed(seed, i), record=True)
        m = o.metrics
        a2a += bool(m.get("actor_collisions"))
        if o.collision:
            ego_hits += 1
            if m.get("collision_kind") in VRU and m["ego_final_speed"] < STANDING:
                into_standing += 1
                moving = [row[0] for row in o.trace.ego if row[4] >= STANDING]
                into_stood += o.sim_time - (moving[-1] if moving else 0.0) >= STOOD
        for actor, info in m["actors"].items():
            if info["kind"] in VRU and info.get("behaviour") == "timed":
                top = max(row[4] for row in o.trace.actors[actor])
                if top > 0.05:
                    tops[info["kind"]].append(top)
    return {
        "map": name,
        "runs": runs,
        "actor_collisions": a2a,
        "ego_collisions": ego_hits,
        "vru_into_standing_ego": into_standing,
        "vru_into_stood_ego": into_stood,
        "top_speeds": tops,
    }


def _pct(xs: list[float]) -> str:
    if not xs:
        return "-"
    q = np.percentile(xs, [5, 50, 95])
    return f"median {statistics.median(xs):.2f} (5-95 % {q[0]:.2f}-{q[2]:.2f}, n={len(xs)})"


def main() -> None:
    """Print one block per map."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--maps", default=",".join(MAPS))
    parser.add_argument("--runs", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ego", choices=("blind", "halt", "reference"), default="blind")
    args = parser.parse_args()
    for name in args.maps.split(","):
        r = measure(name, args.runs, args.seed, args.ego)
        print(
            f"{name}: ego={args.ego} scenes={r['runs']} actor-actor={r['actor_collisions']} "
            f"({100.0 * r['actor_collisions'] / r['runs']:.1f} %) ego-hit={r['ego_collisions']} "
            f"vru-into-standing-ego={r['vru_into_standing_ego']} "
            f"(ego stood >= {STOOD:g} s: {r['vru_into_stood_ego']})"
        )
        for kind, xs in r["top_speeds"].items():
            print(f"  timed {kind} top speed [m/s]: {_pct(xs)}")


if __name__ == "__main__":
    main()
