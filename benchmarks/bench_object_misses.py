"""Misses in time of the object lists' noise model (docs/your-own-stack.md#object-lists):
mean miss-run lengths, and what they do to a stack that needs three consecutive frames.

    python benchmarks/bench_object_misses.py --frames 100000 --situations 100 --seed 8

Part 1, a static scene seen at 10 Hz for ``--frames`` frames (the ego at the origin, the
road user side-on ahead): the share of frames missed and the mean length of a run of
consecutive misses [frames], for a car at 30 m in dense fog starting at the camera (fog
density 100) and a pedestrian at 20 m in clear weather, with the shipped model
(``sitcov/perception/data/objects.yaml``) drawing misses independently (``miss_tau: 0``,
as before) and correlated (``miss_tau: pem``, shipped). Then the PEM sensor itself on the
same scene (a miss: no detection at its floor), and the object list driven at the PEM's
own per-frame rate (a flat ``detection_probability``), so their runs compare at one rate.

Part 2: ``--situations`` random situations of the default hyperspace (situation ``i`` from
``ask_rng(seed, i)``, run seed ``run_seed(seed, i)``), the object-list planner of
examples/object_stack.py as a Python stack braking after the path is taken in 1 or in 3
consecutive frames, on the embedded backend with ground-truth objects, the shipped noise
with independent misses and with correlated misses: failures per configuration, and the
runs whose verdict the three-frame rule changes against the one-frame rule; the same with
the position, heading and velocity errors off ("exact states": the misses alone), and the
paired (sign test) comparison of independent against correlated misses.
"""

from __future__ import annotations

import argparse
import importlib.util
import math
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def _mean_run(miss: np.ndarray) -> float:
    padded = np.concatenate([[0], miss.astype(int), [0]])
    d = np.diff(padded)
    lengths = np.flatnonzero(d == -1) - np.flatnonzero(d == 1)
    return float(lengths.mean()) if lengths.size else math.nan


def part1(frames: int, seed: int) -> None:
    from sitcov.perception import (
        ActorView,
        ObjectMisses,
        PEMSensor,
        Pose,
        load_object_noise,
        object_list,
    )
    from sitcov.sim import conditions_from_values

    cases = (
        ("car, 30 m, fog 100", "car", 30.0, 4.6, 1.9, 1.5, {"fog_density": 100.0}),
        ("pedestrian, 20 m, clear", "pedestrian", 20.0, 0.6, 0.6, 1.8, {}),
    )
    ego = Pose(0.0, 0.0, 0.0)
    print(f"| road user | model | missed | mean miss run [frames] |  ({frames} frames, 10 Hz)")
    print("|---|---|---|---|")
    for name, kind, dist, length, width, height, values in cases:
        cond = conditions_from_values(values)
        # side-on, ahead of the camera (mounted at the ego's front)
        view = ActorView(Pose(dist + 2.5, 0.0, math.pi / 2), length, width, height, kind=kind)
        actors = [(1, view, 0.0, 0.0)]

        def run(noise, cond=cond, actors=actors) -> np.ndarray:
            rng, misses = np.random.default_rng(seed), ObjectMisses()
            miss = np.empty(frames, dtype=bool)
            for k in range(frames):
                objs = object_list(ego, actors, mount_x=2.5, conditions=cond, noise=noise,
                                   rng=rng, misses=misses, time=0.1 * k)  # fmt: skip
                miss[k] = not objs
            return miss

        for label, tau in (("objects.yaml, independent", 0.0), ("objects.yaml, correlated", "pem")):
            miss = run(load_object_noise(miss_tau=tau))
            print(f"| {name} | {label} | {miss.mean():.3f} | {_mean_run(miss):.2f} |", flush=True)
        sensor = PEMSensor()
        sensor.reset(frame_dt=0.1)
        rng = np.random.default_rng(seed)
        pem = np.array([not sensor.detect(ego, (view,), cond, rng) for _ in range(frames)])
        print(f"| {name} | PEM sensor (detections >= floor) | {pem.mean():.3f} | "
              f"{_mean_run(pem):.2f} |")  # fmt: skip
        p = 1.0 - float(pem.mean())
        for label, tau in (("independent", 0.0), ("correlated", "pem")):
            flat = load_object_noise(miss_tau=tau, occlusion_hidden=1.0)
            flat = type(flat)(**{**flat.__dict__, "detection_probability": lambda *a, p=p: p})
            miss = run(flat)
            print(f"| {name} | objects at the PEM's rate, {label} | {miss.mean():.3f} | "
                  f"{_mean_run(miss):.2f} |", flush=True)  # fmt: skip


SCAN = (("car", (4.6, 1.9, 1.5)), ("pedestrian", (0.6, 0.6, 1.8)), ("cyclist", (1.8, 0.6, 1.7)))


def scan(frames: int, seed: int) -> None:
    """Per class, distance (8-40 m, side-on) and fog (0, 60): the PEM sensor's own miss
    rate, mean miss run and lag-1 autocorrelation of its miss indicator, against the
    object list driven at the same per-frame rate, independent and correlated."""
    from sitcov.perception import ActorView, ObjectMisses, ObjectNoise, PEMSensor, Pose, object_list
    from sitcov.sim import conditions_from_values

    def lag1(m: np.ndarray) -> float:
        return float(np.corrcoef(m[:-1], m[1:])[0, 1])

    ego = Pose(0.0, 0.0, 0.0)
    print(
        f"\n| road user | PEM missed | PEM run | PEM lag-1 | objects run (lag-1), independent "
        f"| objects run (lag-1), correlated |  ({frames} frames each)"
    )
    print("|---|---|---|---|---|---|")
    for kind, dims in SCAN:
        for dist in (8.0, 15.0, 25.0, 40.0):
            for fog in (0.0, 60.0):
                cond = conditions_from_values({"fog_density": fog})
                view = ActorView(Pose(dist + 2.5, 0.0, math.pi / 2), *dims, kind=kind)
                sensor = PEMSensor()
                sensor.reset(frame_dt=0.1)
                rng = np.random.default_rng(seed)
                pem = np.array([not sensor.detect(ego, (view,), cond, rng) for _ in range(frames)])
                if not 0.01 < pem.mean() < 0.99:
                    continue
                cells = [f"{pem.mean():.3f}", f"{_mean_run(pem):.2f}", f"{lag1(pem):.2f}"]
                for tau in (0.0, "pem"):
                    p = 1.0 - float(pem.mean())
                    noise = ObjectNoise(miss_tau=tau, detection_probability=lambda *a, p=p: p)
                    rng, misses = np.random.default_rng(seed), ObjectMisses()
                    om = np.array([not object_list(ego, [(1, view, 0.0, 0.0)], mount_x=2.5,
                                                   conditions=cond, noise=noise, rng=rng,
                                                   misses=misses, time=0.1 * k)
                                   for k in range(frames)])  # fmt: skip
                    cells.append(f"{_mean_run(om):.2f} ({lag1(om):.2f})")
                name = f"{kind}, {dist:.0f} m, fog {fog:.0f}"
                print(f"| {name} | " + " | ".join(cells) + " |", flush=True)


def part2(situations: int, seed: int) -> None:
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import AVStack, Control
    from sitcov.generation import make_generator
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim.embedded import EmbeddedBackend

    spec = importlib.util.spec_from_file_location(
        "object_stack", ROOT / "examples" / "object_stack.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    class Planner(AVStack):
        """examples/object_stack.py's planner, braking once the path is taken in ``need``
        consecutive frames (and releasing in the first frame it is clear)."""

        wants = "objects"

        def __init__(self, need: int) -> None:
            self.need = need

        def reset(self, info) -> None:  # type: ignore[no-untyped-def]
            self.inner = module.Stack()
            self.inner.reset({"route": [list(p) for p in info.route], "goal": list(info.goal)})
            self.count = 0

        def step(self, obs) -> Control:  # type: ignore[no-untyped-def]
            e = obs.ego
            ego = {"x": e.x, "y": e.y, "yaw": e.yaw, "speed": e.speed}
            if obs.objects is not None:
                taken = self.inner.path_taken(ego, [o.to_dict() for o in obs.objects])
                self.count = self.count + 1 if taken else 0
                self.inner.blocked = self.count >= self.need
            msg = self.inner.step({"ego": ego, "objects": None})
            return Control(msg["throttle"], msg["brake"], msg["steer"])

    gen = make_generator("random", load_hyperspace())
    sits = [gen.ask(ask_rng(seed, i)) for i in range(situations)]
    exact = {"pos_sigma0": 0.0, "pos_sigma_per_m": 0.0, "heading_sigma": 0.0, "vel_sigma": 0.0}
    configs = (
        ("ground truth", None),
        ("independent misses", {"miss_tau": 0.0}),
        ("correlated misses (shipped)", {}),
        ("independent misses, exact states", {"miss_tau": 0.0, **exact}),
        ("correlated misses, exact states", exact),
    )
    print(
        f"\n| objects | 1-frame stack fails | 3-frame stack fails | 3-frame fails, "
        f"1-frame not | 1-frame fails, 3-frame not |  ({situations} situations, seed {seed})"
    )
    print("|---|---|---|---|---|")
    every = {}
    for label, over in configs:
        if over is None:
            backend = EmbeddedBackend()
        else:
            from sitcov.perception import load_object_noise

            backend = EmbeddedBackend(object_noise=load_object_noise(**over))
        fails = {}
        t0 = time.perf_counter()
        for need in (1, 3):
            stack = Planner(need)
            fails[need] = [bool(backend.run(s, stack, run_seed(seed, i)).failed)
                           for i, s in enumerate(sits)]  # fmt: skip
        every[label] = fails
        only3 = sum(b and not a for a, b in zip(fails[1], fails[3], strict=True))
        only1 = sum(a and not b for a, b in zip(fails[1], fails[3], strict=True))
        print(
            f"| {label} | {sum(fails[1])} | {sum(fails[3])} | {only3} | {only1} |  "
            f"({time.perf_counter() - t0:.0f} s)",
            flush=True,
        )
    pairs = ((configs[1][0], configs[2][0]), (configs[3][0], configs[4][0]))
    for first, second in pairs:
        for need in (1, 3):
            x, y = every[first][need], every[second][need]
            a = sum(u and not v for u, v in zip(x, y, strict=True))
            b = sum(v and not u for u, v in zip(x, y, strict=True))
            print(f"{need}-frame stack, {first} vs {second}: fails only with the first {a}, "
                  f"only with the second {b} (paired; exact two-sided sign-test p "
                  f"{_sign_p(a, b):.3f})")  # fmt: skip


def _sign_p(a: int, b: int) -> float:
    """Two-sided exact binomial (sign) test of a vs b discordant pairs."""
    n, k = a + b, min(a, b)
    if n == 0:
        return 1.0
    tail = sum(math.comb(n, i) for i in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100000)
    parser.add_argument("--situations", type=int, default=100)
    parser.add_argument("--scan-frames", type=int, default=0, help="0: no scan")
    parser.add_argument("--seed", type=int, default=8)
    args = parser.parse_args()
    if args.frames:
        part1(args.frames, args.seed)
    if args.scan_frames:
        scan(args.scan_frames, args.seed)
    if args.situations:
        part2(args.situations, args.seed)


if __name__ == "__main__":
    main()
