"""Overhead of the external-process protocol: control steps per second through a pipe.

Usage: python benchmarks/bench_protocol.py [--steps N] [--runs N] [--image]

Two measurements for each way of plugging in the same route-following stack
(in-process plug-in, external Python process, external Node.js process):

- ``round trip``: ``step()`` calls with a fixed observation (two detections), no
  simulation: the per-step cost of the boundary itself (JSON encode, pipe, the stack's
  parse and answer, JSON decode);
- ``embedded``: whole runs of the embedded backend (PEM perception), steps per second
  of simulated control, i.e. what a campaign sees.

``--image`` adds a round trip with an 800x450 RGB frame through the shared frame file.
Run it on an idle machine: the numbers are wall-clock.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from examples.plugin_stack import PluginStack  # noqa: E402
from sitcov._seeding import run_seed  # noqa: E402
from sitcov.av import EgoState, ExternalProcessStack, Observation, RunInfo  # noqa: E402
from sitcov.hyperspace import load_hyperspace  # noqa: E402
from sitcov.perception import CameraSpec, Detection  # noqa: E402
from sitcov.sim import make_backend  # noqa: E402

IMAGE_STACK = """
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m["type"] == "hello":
        out = {"type": "hello", "protocol": 1, "name": "img", "wants": "image"}
    elif m["type"] == "reset":
        out = {"type": "ready"}
    elif m["type"] == "step":
        with open(m["image"]["path"], "rb") as f:
            frame = f.read()
        out = {"type": "control", "throttle": frame[0] / 255.0}
    else:
        break
    sys.stdout.write(json.dumps(out) + "\\n"); sys.stdout.flush()
"""


def stacks() -> dict[str, object]:
    """The same stack plugged in three ways (Node only if installed)."""
    found = {
        "plug-in (in process)": PluginStack,
        "external Python": lambda: ExternalProcessStack(
            [sys.executable, str(ROOT / "examples" / "python_stack.py")], step_timeout=5.0
        ),
    }
    if shutil.which("node"):
        found["external Node.js"] = lambda: ExternalProcessStack(
            ["node", str(ROOT / "examples" / "node_stack.js")], step_timeout=5.0
        )
    return found


def run_info() -> RunInfo:
    route = tuple((float(i), 0.0) for i in range(200))
    return RunInfo(0.05, route, route[-1], "t-junction", CameraSpec(), 0)


def round_trip(stack, steps: int, image: np.ndarray | None = None) -> float:
    """Steps per second of bare ``step`` calls."""
    dets = (
        Detection((100.0, 200.0, 140.0, 230.0), 0.7),
        Detection((500.0, 180.0, 560.0, 240.0), 0.9),
    )
    stack.reset(run_info())
    obs = [
        Observation(
            0.05 * k,
            EgoState(0.1 * k, 0.2, 0.0, 5.0, 0.05 * k),
            None if image is not None else dets,
            image,
        )
        for k in range(steps)
    ]
    start = time.perf_counter()
    for o in obs:
        stack.step(o)
    return steps / (time.perf_counter() - start)


def embedded(stack, runs: int) -> tuple[float, float]:
    """(steps per second, ms per run) over ``runs`` runs of the embedded backend."""
    hs = load_hyperspace()
    backend = make_backend("embedded")
    rng = np.random.default_rng(0)
    situations = []
    for _ in range(runs):
        bins = {e: hs.labels(e)[int(rng.integers(len(hs.labels(e))))] for e in hs.element_names}
        situations.append(hs.situation_from_bins(bins, rng))
    steps = 0
    start = time.perf_counter()
    for i, situation in enumerate(situations):
        steps += backend.run(situation, stack, run_seed(0, i)).metrics["steps"]
    wall = time.perf_counter() - start
    return steps / wall, 1000.0 * wall / runs


def main() -> None:
    """Measure and print one table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=5000, help="round-trip steps per stack")
    parser.add_argument("--runs", type=int, default=40, help="embedded runs per stack")
    parser.add_argument("--image", action="store_true", help="also time 800x450 frames")
    args = parser.parse_args()
    print(f"{'stack':<22} {'round trip [steps/s]':>21} {'embedded [steps/s]':>19} {'ms/run':>8}")
    for label, factory in stacks().items():
        stack = factory()
        try:
            rate = round_trip(stack, args.steps)
            sim_rate, ms = embedded(stack, args.runs)
        finally:
            stack.close()
        print(f"{label:<22} {rate:>21,.0f} {sim_rate:>19,.0f} {ms:>8.1f}")
    if args.image:
        stack = ExternalProcessStack([sys.executable, "-c", IMAGE_STACK], step_timeout=5.0)
        frame = np.random.default_rng(0).integers(0, 256, (450, 800, 3), dtype=np.uint8)
        try:
            rate = round_trip(stack, max(1, args.steps // 5), frame)
        finally:
            stack.close()
        print(f"{'external Python, image':<22} {rate:>21,.0f}")


if __name__ == "__main__":
    main()
