"""Seeded faults on the same situations and seeds: failure rate and AEB firing per fault.

Measures what docs/reference-stack.md quotes for the faults: N random situations of the
default hyperspace (embedded backend, PEM, one process), each run once with no fault and once
with each fault, with the same run seed. Reports the failure rate with a Wilson 95 %
interval, the share of runs whose AEB fired, and for each fault the share of the no-fault
AEB runs in which the fault's AEB still fired.

    PYTHONPATH=. python benchmarks/bench_faults.py --runs 200 --seed 0

``--hyperspace`` takes another hyperspace (a derived one runs on the map its
``metadata.map`` names, as a campaign does); the failures are then also broken down by the
kind of the intsit road user and by whether the scene has a pedestrian (F4, the AEB that
ignores pedestrians, can only matter there). ``--blind-seeds N`` adds the blind-ego check:
``NoPerceptionStack`` on every intsit bin of the hyperspace in clear weather at mu = 1
(every other element absent or "none"), seeds 0 .. N-1; every run should be a collision.
"""

from __future__ import annotations

import argparse
import math

import numpy as np

from sitcov.av import NoPerceptionStack, make_stack
from sitcov.av._fault_map import mapped_threshold
from sitcov.generation import make_generator
from sitcov.hyperspace import Hyperspace, Situation, load_hyperspace
from sitcov.sim.embedded import EmbeddedBackend

FAULTS = (None, "f1", "f1-raw", "f2", "f3", "f4")


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of k successes in n trials."""
    if n == 0:
        return 0.0, 1.0
    p = k / n
    den = 1 + z * z / n
    mid = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return mid - half, mid + half


def sign_test(new: int, cured: int) -> float:
    """One-sided exact sign test (McNemar) that the fault fails more often: P(X >= new)."""
    n = new + cured
    return sum(math.comb(n, k) for k in range(new, n + 1)) / 2**n if n else 1.0


def make_backend(hs: Hyperspace, switch_distance: float | None) -> EmbeddedBackend:
    """The embedded backend on the map a derived hyperspace names (else the default map)."""
    meta = hs.metadata or {}
    options = {"map": meta["map"]} if "derived_by" in meta and "map" in meta else {}
    return EmbeddedBackend(adversary={"switch_distance": switch_distance}, **options)


def measure(
    runs: int,
    seed: int,
    ratio: float | None = None,
    switch_distance: float | None = None,
    hyperspace: str | None = None,
) -> tuple[dict, list[Situation]]:
    """Per fault: (failure, AEB fired) per run, same situations and seeds; the situations.

    ``ratio`` maps F1 with another acceptance ratio (sensitivity); ``switch_distance``
    fixes the adversary's switch distance for every situation (e.g. the former 8 m).
    """
    hs = load_hyperspace(hyperspace)
    gen = make_generator("random", hs)
    rng = np.random.default_rng(seed)
    situations = [gen.ask(rng) for _ in range(runs)]
    seeds = rng.integers(0, 2**31, size=runs).tolist()
    backend = make_backend(hs, switch_distance)
    f1 = None if ratio is None else {"threshold": mapped_threshold(ratio)}
    out = {}
    for fault in FAULTS:
        stack = make_stack("reference", fault=fault, params=f1 if fault == "f1" else None)
        rows = [backend.run(s, stack, int(sd)) for s, sd in zip(situations, seeds, strict=True)]
        out[fault or "NF"] = [(o.failed, o.aeb_fired) for o in rows]
    return out, situations


def scene_kinds(situation: Situation) -> list[str]:
    """The kinds of the scene's road users, the intsit road user's first."""
    values = situation.values
    kinds = [values["intsit"].get("kind", "car")]
    kinds += [v["kind"] for k, v in values.items() if k.startswith("actor") and v != "none"]
    return kinds


def _kinds(situation: Situation) -> tuple[str, bool]:
    """The intsit road user's kind, and whether any road user of the scene is a pedestrian."""
    kinds = scene_kinds(situation)
    return kinds[0], "pedestrian" in kinds


def report_kinds(table: dict, situations: list[Situation]) -> None:
    """Failures per fault by intsit kind and by scenes with / without a pedestrian."""
    keys = [_kinds(s) for s in situations]
    groups = sorted({k for k, _ in keys}) + ["with pedestrian", "no pedestrian"]
    members = {g: [i for i, (k, _) in enumerate(keys) if k == g] for g in groups[:-2]}
    members["with pedestrian"] = [i for i, (_, p) in enumerate(keys) if p]
    members["no pedestrian"] = [i for i, (_, p) in enumerate(keys) if not p]
    for name, rows in table.items():
        parts = [f"{g} {sum(rows[i][0] for i in members[g])}/{len(members[g])}" for g in groups]
        print(f"{name:7s} by kind: " + ", ".join(parts))


def blind_check(hyperspace: str | None, seeds: int, switch_distance: float | None) -> None:
    """The blind ego on every intsit bin in clear weather at mu = 1, seeds 0 .. seeds-1."""
    hs = load_hyperspace(hyperspace)
    backend = make_backend(hs, switch_distance)
    stack = NoPerceptionStack()
    bins = hs.element("intsit").bins
    missed = []
    for b in bins:
        situation = Situation(
            bins={"intsit": b.label, "friction": "1.0"},
            values={"intsit": b.value, "friction": 1.0},
        )
        missed += [
            f"{b.label}/{seed}"
            for seed in range(seeds)
            if not backend.run(situation, stack, seed).collision
        ]
    n = len(bins) * seeds
    line = f"blind ego hit in {n - len(missed)} of {n} clear-weather runs "
    print(line + f"({len(bins)} situations x {seeds} seeds); missed: {missed or 'none'}")


def report(table: dict) -> None:
    nf_aeb = [a for _, a in table["NF"]]
    n = len(nf_aeb)
    for name, rows in table.items():
        k = sum(f for f, _ in rows)
        lo, hi = wilson(k, n)
        fired = sum(a for _, a in rows)
        both = sum(a for (_, a), b in zip(rows, nf_aeb, strict=True) if b)
        line = f"{name:7s} fail {k}/{n} = {k / n:.3f} [{lo:.3f}, {hi:.3f}]  aeb {fired}/{n}"
        if name != "NF":
            share = both / max(sum(nf_aeb), 1)
            line += f"  aeb in NF-aeb runs {both}/{sum(nf_aeb)} = {share:.3f}"
            new = sum(f and not g for (f, _), (g, _) in zip(rows, table["NF"], strict=True))
            cured = sum(g and not f for (f, _), (g, _) in zip(rows, table["NF"], strict=True))
            line += f"  newly failing {new}, cured {cured}, sign-test p {sign_test(new, cured):.1e}"
        print(line)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ratio", type=float, default=None, help="F1 acceptance ratio (default: F1's)")
    ap.add_argument("--switch-distance", type=float, default=None, help="fixed OV switch [m]")
    ap.add_argument("--hyperspace", default=None, help="hyperspace YAML (default: the paper's)")
    ap.add_argument("--blind-seeds", type=int, default=0, help="blind-ego check: seeds per bin")
    args = ap.parse_args()
    if args.runs > 0:
        table, situations = measure(
            args.runs, args.seed, args.ratio, args.switch_distance, args.hyperspace
        )
        report(table)
        if any(k != ("car", False) for k in map(_kinds, situations)):
            report_kinds(table, situations)
    if args.blind_seeds > 0:
        blind_check(args.hyperspace, args.blind_seeds, args.switch_distance)


if __name__ == "__main__":
    main()
