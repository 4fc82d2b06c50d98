"""Do exported scenarios play in esmini as they ran in sitcov? (docs/export-xosc.md)

Usage: SITCOV_ESMINI=PATH/esmini python benchmarks/xosc_esmini.py [--runs 100]
       [--default-runs 300] [--seed 0] [--work DIR] [--json OUT]

Two sets, each through the CLI as a user would run it (``sitcov run``, ``sitcov
export-xosc``, then :func:`sitcov.sim.xosc.play` on every file):

- every shipped map with its shipped derived hyperspace (cars, cyclists, pedestrians,
  the second road user's behaviours): ``--runs`` runs of the reference stack, EVERY run
  exported (passes and failures, so "no collision" must agree too);
- the default campaign (the paper's hyperspace on the t-junction, reference stack):
  ``--default-runs`` runs, its FAILING runs exported;
- every behaviour of a second road user (pedestrian ``cross``/``kerb``/``hesitate``, car
  ``timed``/``cruise``/``stop``/``stop-go``, cyclist ``timed``/``stop``/``stop-go``) beside
  three ego movements with a conflicting car, on the crossroads and the t-junction, with
  the reference stack and with the blind ``no-perception`` stack (so that collisions
  happen): every situation run once and exported (``export_situations``).

Printed per set and in total: files, files that loaded with no rejected route or error
(clean), and files whose esmini collision agrees with sitcov's stored verdict (same road
user hit, within 0.5 s; or no collision in either).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MAPS = ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge")


def _cli(*args: str) -> None:
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    cmd = [sys.executable, "-m", "sitcov.cli", *args]
    subprocess.run(cmd, check=True, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)


def _set(name: str, work: Path, run_args: list[str], status: str) -> dict:
    from sitcov.sim.xosc import play, summarise

    db, out = work / f"{name}.db", work / name
    db.unlink(missing_ok=True)
    _cli("run", "--db", str(db), "--executor", "serial", "--workers", "1", *run_args)
    _cli("export-xosc", "--db", str(db), "--out", str(out), "--status", status)
    played = [play(f) for f in sorted(out.glob("*.xosc"))]
    summary = summarise(played).to_dict()
    kinds: dict[str, int] = {}
    for p in played:
        for kind in p.kinds.values():
            kinds[kind] = kinds.get(kind, 0) + 1
    summary["road_users"] = kinds
    print(f"{name:>14}: {json.dumps(summary)}", flush=True)
    return summary


#: (kind, route, behaviour) of the second road user in the behaviours set, per map.
BEHAVIOURS = {
    "crossroads": [("pedestrian", "XBL", b) for b in ("cross", "kerb", "hesitate")]
    + [("car", "R-L", b) for b in ("timed", "cruise", "stop", "stop-go")]
    + [("cyclist", "L-R", b) for b in ("timed", "stop", "stop-go")],
    "t-junction": [("pedestrian", "XBL", b) for b in ("cross", "kerb", "hesitate")]
    + [("car", "R-L", b) for b in ("timed", "cruise", "stop", "stop-go")]
    + [("cyclist", "L-R", b) for b in ("timed", "stop", "stop-go")],
}
#: (ego, conflicting car) movements of the behaviours set.
EGOS = {
    "crossroads": [("B-T", "L-R"), ("B-L", "R-B"), ("L-R", "T-B")],
    "t-junction": [("B-L", "L-R"), ("B-R", "R-L"), ("L-R", "B-L")],
}


def _behaviours(work: Path) -> dict:
    from sitcov.campaign._xosc import export_situations
    from sitcov.hyperspace import Situation
    from sitcov.sim.xosc import play, summarise

    played = []
    for name, users in BEHAVIOURS.items():
        sits = []
        for ego, ov in EGOS[name]:
            for kind, route, behaviour in users:
                values = {
                    "friction": 0.8,
                    "intsit": {"ego": ego, "ov": ov, "conflict": "k", "kind": "car"},
                    "actor2": {"kind": kind, "route": route, "behaviour": behaviour},
                }
                bins = {"friction": "0.8", "intsit": f"{ego}/car:{ov}",
                        "actor2": f"{kind}:{route}:{behaviour}"}  # fmt: skip
                sits.append(Situation(bins, values))
        for av in ("reference", "no-perception"):
            out = work / f"behaviours-{name}-{av}"
            written = export_situations(sits, out, map=name, av=av)
            played += [play(f) for f in written]
    summary = summarise(played).to_dict()
    print(f"{'behaviours':>14}: {json.dumps(summary)}", flush=True)
    return summary


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=100)
    parser.add_argument("--default-runs", type=int, default=300)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--work", type=Path, default=None)
    parser.add_argument("--json", type=Path, default=None)
    args = parser.parse_args()
    work = args.work or Path(tempfile.mkdtemp(prefix="sitcov-xosc-"))
    work.mkdir(parents=True, exist_ok=True)
    start = time.time()
    sets = {}
    for name in MAPS:
        hyperspace = ROOT / "sitcov" / "hyperspace" / "data" / "derived" / f"{name}.yaml"
        run = ["--runs", str(args.runs), "--seed", str(args.seed), "--hyperspace", str(hyperspace)]
        sets[name] = _set(name, work, run, "all")
    sets["default-failing"] = _set(
        "default", work, ["--runs", str(args.default_runs), "--seed", str(args.seed)], "fail"
    )
    sets["behaviours"] = _behaviours(work)
    total = {
        key: sum(s[key] for s in sets.values())
        for key in ("files", "clean", "agree", "expected_collisions")
    }
    total["clean_rate"] = round(total["clean"] / total["files"], 4)
    total["agree_rate"] = round(total["agree"] / total["files"], 4)
    print(f"{'total':>14}: {json.dumps(total)}")
    print(f"wall time {time.time() - start:.0f} s, load {os.getloadavg()[0]:.1f}, work {work}")
    if args.json is not None:
        args.json.write_text(json.dumps({"sets": sets, "total": total}, indent=1))


if __name__ == "__main__":
    main()
