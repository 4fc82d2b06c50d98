"""Per-element weather trends in PEM and camera mode, paired (docs/weather.md, trend table).

Runs 0..N-1 of ``--seed`` (the intersection situation of the random generator's situation,
simulation seed ``run_seed(seed, i)``) are driven by the reference stack (no fault; another
with ``--stack``, e.g. ``examples.aeb_stacks:Threshold07`` with the checkout on
``PYTHONPATH``) once per
arm and perception mode, every weather element at its mildest bin (0, friction ``--friction``)
except what the arm changes:

- ``baseline``: nothing;
- ``fog_density``: fog_density 100 from the camera on (fog_distance 0);
- ``fog_distance``: the same fog starting 40 m out (compared with ``fog_density``: the
  element's low bin 0 vs 40, at full density; it does nothing without fog);
- ``cloudiness``: cloudiness 100;
- ``precipitation``: precipitation 100.

Same situations and seeds in every arm and mode, so each element's change is paired: the
element's low arm vs its high arm, with the discordant counts (runs that fail only in one of
the two) and a two-sided exact sign test on them. Prints one JSON object with every failure
rate (Wilson 95 %) and change, and the Markdown trend table of docs/weather.md; reports
camera-mode throughput (runs per wall-clock second over ``--workers`` processes).

    python benchmarks/bench_weather_trends.py --runs 120 --seed 7 --workers 2

``--wind`` measures only the wind in the rain: precipitation 100 with wind 0 against
wind 100 (the renderer slants the streaks with the wind; without rain the wind changes no
frame). ``--first K`` starts at run K (to extend a measurement), ``--json FILE`` also writes the
report; ``--merge A.json B.json ...`` pools reports of disjoint runs (counts add up) and
prints the pooled report and table without running anything.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing as mp
import time

ARMS = {
    "baseline": {},
    "fog_density": {"fog_density": 100.0},
    "fog_distance": {"fog_density": 100.0, "fog_distance": 40.0},
    "cloudiness": {"cloudiness": 100.0},
    "precipitation": {"precipitation": 100.0},
}
#: element -> (its low arm, its high arm)
ELEMENTS = {
    "fog_density": ("baseline", "fog_density"),
    "fog_distance": ("fog_density", "fog_distance"),
    "cloudiness": ("baseline", "cloudiness"),
    "precipitation": ("baseline", "precipitation"),
}
#: ``--wind``: the wind in the rain, the one element whose effect needs another (the
#: renderer slants the streaks with the wind; without rain the wind changes no frame)
WIND_ARMS = {
    "precipitation": {"precipitation": 100.0},
    "rain_wind": {"precipitation": 100.0, "wind_intensity": 100.0},
}
WIND_ELEMENTS = {"wind_intensity": ("precipitation", "rain_wind")}
MILD = {
    "cloudiness": 0.0, "precipitation": 0.0, "precipitation_deposits": 0.0,
    "wind_intensity": 0.0, "fog_density": 0.0, "fog_distance": 0.0, "wetness": 0.0,
}  # fmt: skip
_STATE: dict = {}


def _run(job: tuple) -> dict:
    """One situation in every arm: ``(mode, seed, index, friction[, arms[, stack]])``."""
    mode, seed, i, friction = job[:4]
    arms = job[4] if len(job) > 4 else ARMS
    stack_name = job[5] if len(job) > 5 else "reference"
    from sitcov._seeding import ask_rng, run_seed
    from sitcov.av import make_stack
    from sitcov.generation import make_generator
    from sitcov.hyperspace import Situation, load_hyperspace
    from sitcov.sim.embedded import EmbeddedBackend

    if "gen" not in _STATE:
        _STATE["gen"] = make_generator("random", load_hyperspace())
    if _STATE.get("stack_name") != stack_name:
        _STATE["stack_name"], _STATE["stack"] = stack_name, make_stack(stack_name)
    if mode not in _STATE:
        _STATE[mode] = EmbeddedBackend(perception=mode)
    base = _STATE["gen"].ask(ask_rng(seed, i))
    out: dict = {"mode": mode, "index": i}
    for arm, change in arms.items():
        values = {**MILD, "friction": friction, **change, "intsit": base.values["intsit"]}
        sit = Situation(dict.fromkeys(values, "-"), values)
        outcome = _STATE[mode].run(sit, _STATE["stack"], run_seed(seed, i))
        out[arm] = bool(outcome.failed)
    return out


def sign_test(up: int, down: int) -> float:
    """Two-sided exact binomial (p = 1/2) p-value of ``up`` vs ``down`` discordant pairs."""
    n = up + down
    if n == 0:
        return 1.0
    k = min(up, down)
    tail = sum(math.comb(n, j) for j in range(k + 1)) / 2.0**n
    return min(1.0, 2.0 * tail)


def summarize(rows: list[dict], arms: dict = ARMS, elements: dict = ELEMENTS) -> dict:
    """Failure rates per arm and the paired change per element, for one mode's rows."""
    counts = {arm: sum(r[arm] for r in rows) for arm in arms}
    pairs = {
        element: (
            sum(r[high] and not r[low] for r in rows),
            sum(r[low] and not r[high] for r in rows),
        )
        for element, (low, high) in elements.items()
    }
    return _report(len(rows), counts, pairs, elements)


def _report(n: int, counts: dict, pairs: dict, elements: dict = ELEMENTS) -> dict:
    """The report of ``n`` paired runs: failures per arm, (up, down) discordant per element."""
    from sitcov.analysis._stats import wilson_interval

    report: dict = {"runs": n, "arms": {}, "elements": {}}
    for arm in counts:
        k = counts[arm]
        lo, hi = wilson_interval(k, n)
        report["arms"][arm] = {"failures": k, "rate": round(k / n, 3),
                               "wilson95": [round(lo, 3), round(hi, 3)]}  # fmt: skip
    for element, (low, high) in elements.items():
        up, down = pairs[element]
        report["elements"][element] = {
            "low": low, "high": high, "change": round((up - down) / n, 3),
            "fail_only_high": up, "fail_only_low": down,
            "sign_test_p": round(sign_test(up, down), 4),
        }  # fmt: skip
    return report


def _direction(e: dict) -> str:
    if e["sign_test_p"] >= 0.05:
        return "flat"
    return "up" if e["change"] > 0 else "down"


def table(report: dict) -> str:
    """The trend table (Markdown): per element, each mode's paired change and direction."""
    modes = [m for m in ("pem", "camera") if m in report]
    head = "| element (low -> high) | " + " | ".join(
        f"{m}: failures low -> high, change [discordant], p" for m in modes
    )
    lines = [head + " | agree |", "|---" * (len(modes) + 2) + "|"]
    for element, first in report[modes[0]]["elements"].items():
        low, high = first["low"], first["high"]
        cells, dirs = [], []
        for m in modes:
            e, arms = report[m]["elements"][element], report[m]["arms"]
            dirs.append(_direction(e))
            cells.append(
                f"{arms[low]['failures']} -> {arms[high]['failures']}, {e['change']:+.3f} "
                f"[+{e['fail_only_high']}/-{e['fail_only_low']}], {e['sign_test_p']:.3f} "
                f"({dirs[-1]})"
            )
        agree = "yes" if len(set(dirs)) == 1 else "no"
        lines.append(f"| {element} ({low} -> {high}) | " + " | ".join(cells) + f" | {agree} |")
    return "\n".join(lines)


def merge(reports: list[dict]) -> dict:
    """Pool reports of disjoint runs of the same arms: counts add up."""
    out: dict = {"merged": len(reports), "friction": reports[0].get("friction")}
    for mode in ("pem", "camera"):
        parts = [r[mode] for r in reports if mode in r]
        if not parts:
            continue
        counts = {arm: sum(p["arms"][arm]["failures"] for p in parts) for arm in parts[0]["arms"]}
        elements = {e: (v["low"], v["high"]) for e, v in parts[0]["elements"].items()}
        pairs = {
            e: (sum(p["elements"][e]["fail_only_high"] for p in parts),
                sum(p["elements"][e]["fail_only_low"] for p in parts))
            for e in elements
        }  # fmt: skip
        out[mode] = _report(sum(p["runs"] for p in parts), counts, pairs, elements)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=120)
    parser.add_argument("--first", type=int, default=0, help="index of the first run")
    parser.add_argument("--json", help="also write the report to this file")
    parser.add_argument("--merge", nargs="+", help="pool these reports (no runs)")
    parser.add_argument("--seed", type=int, default=7)
    parser.add_argument("--workers", type=int, default=1)
    parser.add_argument("--friction", type=float, default=1.0)
    parser.add_argument("--modes", default="pem,camera", help="pem, camera or both")
    parser.add_argument(
        "--wind", action="store_true", help="only the wind in the rain (precipitation 100)"
    )
    parser.add_argument("--stack", default="reference", help="AV stack (sitcov run --av names)")
    args = parser.parse_args()
    arms, elements = (WIND_ARMS, WIND_ELEMENTS) if args.wind else (ARMS, ELEMENTS)
    if args.merge:
        from pathlib import Path

        report = merge([json.loads(Path(f).read_text()) for f in args.merge])
        print(json.dumps(report, indent=1))
        print(table(report))
        return
    report: dict = {"seed": args.seed, "friction": args.friction, "first": args.first,
                    "stack": args.stack}  # fmt: skip
    for mode in args.modes.split(","):
        jobs = [
            (mode, args.seed, i, args.friction, arms, args.stack)
            for i in range(args.first, args.first + args.runs)
        ]
        start = time.perf_counter()
        if args.workers > 1:
            with mp.get_context("spawn").Pool(args.workers) as pool:
                rows = list(pool.imap_unordered(_run, jobs))
        else:
            rows = [_run(j) for j in jobs]
        wall = time.perf_counter() - start
        report[mode] = summarize(sorted(rows, key=lambda r: r["index"]), arms, elements)
        runs = len(rows) * len(arms)
        report[mode]["runs_per_second"] = round(runs / wall, 2)
        report[mode]["workers"] = args.workers
    print(json.dumps(report, indent=1))
    print(table(report))
    if args.json:
        from pathlib import Path

        Path(args.json).write_text(json.dumps(report, indent=1))


if __name__ == "__main__":
    main()
