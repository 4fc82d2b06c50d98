"""Recorded detector frames per class: what the frame model is fitted on and checked against.

A frames file holds, per kind of road user (``car``, ``pedestrian``, ``cyclist``), camera
runs recorded frame by frame (:class:`~sitcov.calibration._camera_runs.CameraRun`) and
static sweep frames, as JSON lines ``{"kind": ..., "run": {...}}`` and ``{"kind": ...,
"sweep": [features], "score": s}`` (gzip when the name ends in ``.gz``). It is the
per-class samples format of ``sitcov calibrate --classes --samples``; the car calibration's
recording (:mod:`sitcov.calibration._recording`: ``meta``/``sweep``/``run`` rows) is read
too, as kind ``car``. :func:`record_frames` writes one: ``sitcov calibrate --record-frames``.
"""

from __future__ import annotations

import gzip
import json
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, field
from typing import Any

from sitcov.calibration._camera_runs import CameraRun
from sitcov.errors import ConfigError
from sitcov.perception._pem import PEMFeatures

#: The kinds a frames file can hold, and the name each is reported as: the detector's
#: class, and for a cyclist its two detections, the rider (``person`` boxes) and the
#: bicycle (``bicycle`` boxes; docs/pem.md, "The cyclist's two detections").
KIND_LABEL = {"car": "car", "pedestrian": "person", "cyclist": "rider", "bicycle": "bicycle"}


@dataclass
class KindFrames:
    """One kind's recorded frames: sweep frames (features, score, distance [m] or -1) and
    camera runs."""

    sweep: list[tuple[PEMFeatures, float, float]] = field(default_factory=list)
    runs: list[CameraRun] = field(default_factory=list)


def parse_kinds(text: str) -> list[str]:
    """``--kinds``: comma-separated kinds among :data:`KIND_LABEL`, each once."""
    kinds = [k.strip() for k in text.split(",") if k.strip()]
    if not kinds or any(k not in KIND_LABEL for k in kinds) or len(set(kinds)) != len(kinds):
        raise ConfigError(
            field="--kinds", value=text, expected="car, pedestrian, cyclist and/or bicycle"
        )
    return kinds


def record_frames(
    kinds: Sequence[str],
    runs: int,
    *,
    seed: int,
    sweep: int = 0,
    model: str | None = None,
    workers: int = 1,
    observe: bool = True,
    progress: Callable[[str, int], None] | None = None,
) -> dict[str, KindFrames]:
    """``sweep`` static frames and ``runs`` camera runs of each kind, recorded.

    Sweep frames: one road user at random distance, bearing, heading, colour and one
    weather element at a time (:func:`sitcov.calibration._calibrate.sweep` for cars,
    :func:`sitcov.calibration._class_fit.class_sweep` for the others). Runs: camera runs
    of each kind's random situations, recorded frame by frame.

    Cars: the default hyperspace (:func:`~sitcov.calibration._camera_runs.camera_runs`);
    pedestrians and cyclists: the derived hyperspace restricted to them
    (:func:`~sitcov.calibration._class_runs.class_camera_runs`). ``observe`` (default):
    the stack is given no detections, so every frame to the run's end is recorded, not only
    those before the reference AEB fires.
    """
    from sitcov.calibration._camera_runs import camera_runs
    from sitcov.calibration._class_runs import class_camera_runs

    out: dict[str, KindFrames] = {}
    detector = None
    for kind in kinds:
        frames: list[tuple[PEMFeatures, float, float]] = []
        if sweep > 0:
            from sitcov.calibration._calibrate import SWEEP_MIN_SCORE
            from sitcov.calibration._calibrate import sweep as car_sweep
            from sitcov.calibration._class_fit import class_sweep
            from sitcov.perception._detector import SSDDetector

            detector = detector or SSDDetector(model, min_score=SWEEP_MIN_SCORE)
            if kind == "car":
                got_s = car_sweep(sweep, detector, seed=seed)
                frames = [(s.features, s.score, s.distance) for s in got_s]
            else:
                frames = [(f, sc, -1.0) for f, sc in class_sweep(kind, sweep, detector, seed=seed)]
        tick = None if progress is None else (lambda r, k=kind: progress(k, r))
        if kind == "car":
            got = camera_runs(runs, seed=seed, model=model, workers=workers, progress=tick,
                              observe=observe)  # fmt: skip
        else:
            got = class_camera_runs(kind, runs, seed=seed, model=model, workers=workers,
                                    progress=tick, observe=observe)  # fmt: skip
        out[kind] = KindFrames(sweep=frames, runs=got)
    return out


def write_frames(path: Any, frames: dict[str, KindFrames]) -> None:
    """``frames`` as a frames file (module docstring); floats by ``repr`` (exact)."""
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "wt") as fh:
        for kind, data in frames.items():
            for feats, score, dist in data.sweep:
                row = {"kind": kind, "sweep": list(feats), "score": score, "distance": dist}
                fh.write(json.dumps(row) + "\n")
            for run in data.runs:
                fh.write(json.dumps({"kind": kind, "run": asdict(run)}) + "\n")


def read_frames(path: Any) -> dict[str, KindFrames]:
    """A frames file, or a car recording (``sitcov calibrate --samples``) as kind ``car``.

    Raises:
        ConfigError: the file cannot be read or a line is none of those rows (one line
            naming the file and the line number).
    """
    from sitcov.calibration._recording import run_from_dict

    opener = gzip.open if str(path).endswith(".gz") else open
    try:
        with opener(path, "rt") as fh:
            lines = list(fh)
    except OSError as exc:
        raise ConfigError(file=str(path), expected="a readable frames file") from exc
    out: dict[str, KindFrames] = {}
    for n, line in enumerate(lines, 1):
        try:
            row = json.loads(line)
            if "meta" in row:
                continue
            kind = str(row.get("kind", "car"))
            if kind not in KIND_LABEL:
                raise ValueError(kind)
            data = out.setdefault(kind, KindFrames())
            if "run" in row:
                data.runs.append(run_from_dict(row["run"]))
            elif "kind" in row:
                feats = PEMFeatures(*row["sweep"])
                data.sweep.append((feats, float(row["score"]), float(row.get("distance", -1.0))))
            else:  # a car recording's sweep sample
                smp = row["sweep"]
                feats = PEMFeatures(*smp["features"])
                data.sweep.append((feats, float(smp["score"]), float(smp["distance"])))
        except (ValueError, KeyError, TypeError) as exc:
            raise ConfigError(
                file=str(path), field=f"line {n}", value=line[:60],
                expected="a sweep or run row written by sitcov calibrate",
            ) from exc  # fmt: skip
    return out
