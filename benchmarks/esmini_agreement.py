"""Verdicts of the esmini backend against the embedded backend on the same situations.

Usage: python benchmarks/esmini_agreement.py --db DB --campaign NAME [--speed-sample 60]
       [--speed-only] [--speed-no-crop] [--own-road] [--reseed] [--out FILE.json]
       [--rows FILE.csv]

Every judged run (pass or fail) of an esmini campaign (``sitcov run --backend esmini``) is
run again, with its stored situation and run seed, on the embedded backend with the
campaign's stack, physics profile and judge; the two verdicts (``failed``) are compared.
Printed (and written as JSON with ``--out``): the agreement with its Wilson 95 % interval,
the 2x2 table, the failure kinds on each side, and the disagreements by ``intsit`` and by
the pair of end reasons, which is where the causes of the differences are read (see
docs/esmini.md).

``--speed-sample N`` also times the first N situations on both backends in this process,
one after the other, in CPU seconds (``time.process_time``, esmini's C library included):
runs per CPU second, i.e. runs/s per core, measured at the same moment of the machine
(the embedded side only for situations it can play, i.e. with an ``intsit``);
``--speed-only`` skips the comparison (e.g. for a campaign on a user's scenario).
``--own-road`` replays every run a third time, on esmini on the embedded map's own
OpenDRIVE export (the embedded world's geometry, esmini's engine and departure test): which
road departures follow the road and which the test (``own_road.road_departures_on``).
``--reseed`` runs the embedded world a second time under another run seed: how often its
own verdict flips with the seed bounds any per-run agreement between two worlds.
``--speed-no-crop`` times esmini loading the whole road every run (before the crop).
"""

from __future__ import annotations

import argparse
import collections
import csv
import json
import time
from pathlib import Path
from typing import Any

from sitcov.analysis._stats import wilson_interval
from sitcov.campaign import open_store
from sitcov.campaign._build import build_backend, build_stack
from sitcov.campaign._config import CampaignConfig
from sitcov.sim import Judge


def _embedded_config(config: CampaignConfig) -> CampaignConfig:
    return config.model_copy(update={"backend": "embedded", "backend_options": {}})


def _own_road_config(config: CampaignConfig) -> CampaignConfig:
    """The esmini campaign's config without ``road``: its situations on the embedded map's
    own OpenDRIVE export (the embedded world's geometry, esmini's engine and tests)."""
    options = {k: v for k, v in config.backend_options.items() if k not in ("road", "map")}
    return config.model_copy(update={"backend_options": options})


#: Added to a run's seed for the embedded world's agreement with itself (``--reseed``).
RESEED = 1_000_003


def compare(db: str, campaign: str, own_road: bool = False, reseed: bool = False) -> dict[str, Any]:
    """Re-run the campaign's judged runs on the embedded backend (and, with ``own_road``,
    on esmini on the embedded map's own OpenDRIVE export; with ``reseed``, on the embedded
    backend again under another run seed); the comparison."""
    store = open_store(db)
    try:
        info = store.campaign(campaign)
        config = CampaignConfig(**info.config)
        records = [r for r in store.iter_runs(campaign) if r.status in ("pass", "fail")]
    finally:
        store.close()
    emb_config = _embedded_config(config)
    backend, stack = build_backend(emb_config), build_stack(emb_config)
    own = build_backend(_own_road_config(config)) if own_road else None
    own_table: collections.Counter[str] = collections.Counter()
    departures: collections.Counter[str] = collections.Counter()
    same: collections.Counter[str] = collections.Counter()  # embedded vs itself, reseeded
    judge = Judge.from_spec(config.judge)
    table: collections.Counter[str] = collections.Counter()
    kinds: dict[str, collections.Counter[str]] = {
        "esmini": collections.Counter(),
        "embedded": collections.Counter(),
    }
    by_intsit: dict[str, list[int]] = collections.defaultdict(lambda: [0, 0])
    reasons: collections.Counter[str] = collections.Counter()
    rows: list[dict[str, Any]] = []
    for rec in records:
        emb = judge(backend.run(rec.situation, stack, rec.seed))
        es = rec.outcome
        table[f"esmini_{es.status}/embedded_{emb.status}"] += 1
        kinds["esmini"][es.kind] += 1
        kinds["embedded"][emb.kind] += 1
        label = rec.situation.bins.get("intsit", "-")
        agree = es.failed == emb.failed
        by_intsit[label][0] += 1
        by_intsit[label][1] += 0 if agree else 1
        if not agree:
            pair = f"esmini {es.kind}/{es.end_reason} vs embedded {emb.kind}/{emb.end_reason}"
            reasons[pair] += 1
        extra: dict[str, Any] = {}
        if reseed:
            again = judge(backend.run(rec.situation, stack, rec.seed + RESEED))
            same["agree" if again.failed == emb.failed else f"{emb.kind}/{again.kind}"] += 1
        if own is not None:
            mine = judge(own.run(rec.situation, stack, rec.seed))
            own_table[f"own_{mine.status}/embedded_{emb.status}"] += 1
            own_table[f"own_{mine.status}/esmini_{es.status}"] += 1
            dep = [o.kind == "road_departure" for o in (es, mine, emb)]
            if any(dep):
                sides = zip(("esmini", "own", "embedded"), dep, strict=True)
                departures["/".join(k for k, d in sides if d)] += 1
            extra = {"esmini_own": f"{mine.kind}/{mine.end_reason}", "own_aeb": mine.aeb_fired}
        rows.append(
            {
                "index": rec.index,
                **{f"bin_{k}": v for k, v in rec.situation.bins.items()},
                "esmini": f"{es.kind}/{es.end_reason}",
                "embedded": f"{emb.kind}/{emb.end_reason}",
                "esmini_aeb": es.aeb_fired,
                "embedded_aeb": emb.aeb_fired,
                **extra,
            }
        )
    stack.close()
    backend.close()
    n = len(records)
    agreeing = table["esmini_pass/embedded_pass"] + table["esmini_fail/embedded_fail"]
    return {
        "db": db,
        "campaign": campaign,
        "runs": n,
        "agreeing": agreeing,
        "agreement": agreeing / n if n else None,
        "agreement_ci95": wilson_interval(agreeing, n),
        "table": dict(table),
        "kinds": {k: dict(v) for k, v in kinds.items()},
        "disagreements_by_intsit": {
            k: {"runs": v[0], "disagree": v[1]} for k, v in sorted(by_intsit.items())
        },
        "disagreement_reasons": dict(reasons.most_common()),
        **(
            {}
            if own is None
            else {
                "own_road": {
                    "table": dict(own_table),
                    "agreement_with_embedded": _rate(own_table, "embedded", n),
                    "agreement_with_esmini": _rate(own_table, "esmini", n),
                    "road_departures_on": dict(departures.most_common()),
                }
            }
        ),
        **(
            {}
            if not reseed
            else {
                "embedded_vs_itself_reseeded": {
                    "agreeing": same["agree"],
                    "rate": same["agree"] / n if n else None,
                    "ci95": wilson_interval(same["agree"], n),
                    "flips": {k: v for k, v in same.most_common() if k != "agree"},
                }
            }
        ),
        "rows": rows,
    }


def _rate(table: collections.Counter[str], other: str, n: int) -> dict[str, Any]:
    agreeing = table[f"own_pass/{other}_pass"] + table[f"own_fail/{other}_fail"]
    return {"agreeing": agreeing, "rate": agreeing / n if n else None,
            "ci95": wilson_interval(agreeing, n)}  # fmt: skip


def speed(db: str, campaign: str, n: int, no_crop: bool = False) -> dict[str, Any]:
    """Runs per CPU second of both backends on the campaign's first ``n`` situations
    (``no_crop``: esmini loads the whole road file every run)."""
    store = open_store(db)
    try:
        config = CampaignConfig(**store.campaign(campaign).config)
        records = [r for r in store.iter_runs(campaign) if r.status in ("pass", "fail")][:n]
    finally:
        store.close()
    out: dict[str, Any] = {"runs": len(records)}
    if no_crop:
        options = {**config.backend_options, "crop_road": False}
        config = config.model_copy(update={"backend_options": options})
    sides = [("esmini", config)]
    if "intsit" in records[0].situation.values:  # the embedded world plays it too
        sides.append(("embedded", _embedded_config(config)))
    for name, cfg in sides:
        backend, stack = build_backend(cfg), build_stack(cfg)
        backend.run(records[0].situation, stack, records[0].seed)  # warm-up (JIT, road)
        start = time.process_time()
        for rec in records:
            backend.run(rec.situation, stack, rec.seed)
        cpu = time.process_time() - start
        out[name] = {"cpu_s": round(cpu, 3), "runs_per_cpu_s": round(len(records) / cpu, 2)}
        stack.close()
        backend.close()
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--db", required=True)
    parser.add_argument("--campaign", required=True)
    parser.add_argument("--speed-sample", type=int, default=0)
    parser.add_argument("--speed-only", action="store_true", help="no verdict comparison")
    parser.add_argument("--out", default=None)
    parser.add_argument("--rows", default=None, help="CSV of every run's two verdicts")
    parser.add_argument(
        "--reseed",
        action="store_true",
        help="also the embedded world against itself under another run seed (the ceiling)",
    )
    parser.add_argument(
        "--speed-no-crop",
        action="store_true",
        help="time esmini on the whole road file (crop_road=False), for the before/after",
    )
    parser.add_argument(
        "--own-road",
        action="store_true",
        help="also replay on esmini on the embedded map's own OpenDRIVE export",
    )
    args = parser.parse_args()
    result = {} if args.speed_only else compare(args.db, args.campaign, args.own_road, args.reseed)
    rows = result.pop("rows", [])
    if args.rows and rows:
        with open(args.rows, "w", newline="", encoding="utf-8") as fh:
            writer = csv.DictWriter(fh, fieldnames=list(rows[0]))
            writer.writeheader()
            writer.writerows(rows)
    if args.speed_sample:
        result["speed"] = speed(args.db, args.campaign, args.speed_sample, args.speed_no_crop)
    text = json.dumps(result, indent=2)
    print(text)
    if args.out:
        Path(args.out).write_text(text + "\n")


if __name__ == "__main__":
    main()
