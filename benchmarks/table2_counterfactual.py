"""Table 2 counterfactual: a faults database re-simulated with the paper's judge and dry roads.

Every stored run of every fault campaign (same situation, same run seed, same backend and
stack settings) is simulated again with the ``friction`` element set to 1.0 and judged with
the paper's judge (collisions only); prints failures per generator for NF / F1 / F2 / F3.
docs/experiments.md quotes its output for ``sitcov experiment faults --runs 100 --seeds 5``:

    python benchmarks/table2_counterfactual.py faults.db
"""

from __future__ import annotations

import argparse
from collections import Counter

from sitcov.campaign import CampaignConfig, open_store
from sitcov.campaign._build import build_backend, build_stack
from sitcov.hyperspace import Situation
from sitcov.sim import Judge

FAULTS = ("NF", "F1", "F2", "F3")


def dry_road_failures(db: str) -> Counter:
    """Failures per (generator, fault) with friction 1.0 and the paper's judge."""
    store = open_store(db)
    judge = Judge.from_spec("paper")
    counts: Counter = Counter()
    try:
        for info in store.campaigns():
            config = CampaignConfig(**info.config)
            backend, stack = build_backend(config), build_stack(config)
            key = (info.tags["generator"], info.tags["fault"])
            for run in store.runs(campaign=info.name):
                sit = run.situation
                dry = Situation(
                    bins=dict(sit.bins, friction="1.0"), values=dict(sit.values, friction=1.0)
                )
                counts[key] += judge(backend.run(dry, stack, run.seed)).status == "fail"
    finally:
        store.close()
    return counts


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("db", help="database written by `sitcov experiment faults`")
    counts = dry_road_failures(parser.parse_args().db)
    for generator in sorted({g for g, _ in counts}):
        print(generator, " / ".join(str(counts[(generator, f)]) for f in FAULTS))


if __name__ == "__main__":
    main()
