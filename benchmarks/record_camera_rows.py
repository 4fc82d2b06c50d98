"""Record camera-mode rows of the agreement experiment without running any PEM side.

Camera rows do not depend on the PEM, so a held-out set can be recorded before the PEM it
will judge is fitted (and nobody sees a PEM-vs-camera figure while fitting it). The rows
file is the one ``sitcov experiment agreement`` writes; pass it back with ``--camera-rows``
to evaluate a PEM on it without simulating the camera again::

    python benchmarks/record_camera_rows.py --seeds 8,9 --situations 200 --streams A \
        --out docs/data/agreement-seeds-8-9.csv

Situations are interleaved across seeds (index 0 of every seed, then index 1, ...) so an
interrupted recording still covers every seed evenly; rows are flushed as runs finish.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from sitcov.campaign import _agreement as ag


def main() -> None:
    """Parse the arguments and record the rows."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", required=True, help="comma-separated evaluation seeds")
    parser.add_argument("--situations", type=int, required=True, help="situations per seed")
    parser.add_argument("--streams", default="A", help="run-seed streams: A, B or A,B")
    parser.add_argument("--out", type=Path, required=True, help="rows file (.csv or .jsonl)")
    args = parser.parse_args()
    seeds = ag.parse_seeds(args.seeds)
    streams = [s.strip() for s in args.streams.split(",") if s.strip()]
    ag.check_seeds(seeds, ag.calibration_seeds(), allow=False, pem_file="pem.yaml")
    jobs = [
        ag.Job(seed, index, "camera", stream)
        for index in range(args.situations)
        for stream in streams
        for seed in seeds
    ]
    from sitcov.perception._models import model_path

    settings = ag.SideSettings(model=str(model_path(None)))
    start, cpu = time.perf_counter(), time.process_time()
    rows = []
    writer = ag.RowsWriter(args.out)
    try:
        for row in ag.iter_rows(jobs, settings):
            rows.append(row)
            writer.write(row)
    finally:
        writer.close()
    ag.write_rows(args.out, ag.sort_rows(rows))
    wall, cpu = time.perf_counter() - start, time.process_time() - cpu
    print(f"{len(rows)} camera rows -> {args.out} ({wall:.0f} s wall, {cpu:.0f} CPU-s)")


if __name__ == "__main__":
    main()
