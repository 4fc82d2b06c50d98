"""Play every run of each set of benchmarks/xosc_esmini.py as one ParameterValueDistribution.

Usage: SITCOV_ESMINI=PATH/esmini python benchmarks/xosc_distribution.py WORK
(WORK: the --work folder of benchmarks/xosc_esmini.py). For each set folder it writes
campaign_template.xosc, campaign_distribution.xosc and catalogs/, plays every permutation
in esmini (``--param_dist``, ``--param_permutation``) and prints the same counts as for
the per-run files (docs/export-xosc.md).
"""

from __future__ import annotations

import json
import os
import sys
import time
from pathlib import Path

from sitcov.sim.xosc import play_distribution, summarise, write_distribution

SETS = ("t-junction", "crossroads", "skewed-cross", "roundabout", "merge", "default")


def main() -> None:
    work = Path(sys.argv[1])
    start = time.time()
    total: dict[str, int] = {}
    for name in SETS:
        folder = work / name
        files = sorted(f for f in folder.glob("*.xosc") if not f.stem.startswith("campaign_"))
        _, dist = write_distribution(files, folder)
        summary = summarise(play_distribution(dist)).to_dict()
        print(name, json.dumps(summary), flush=True)
        for key in ("files", "clean", "agree"):
            total[key] = total.get(key, 0) + summary[key]
    print("total", total, f"wall {time.time() - start:.0f} s, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
