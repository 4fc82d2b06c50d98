"""A car calibration's measurements as data: the :class:`Recording` and its samples file.

``sitcov calibrate --samples F`` writes a recording and ``--from-samples F`` reads it back,
so the PEM can be refitted without rendering (docs/pem.md).
"""

from __future__ import annotations

import gzip
import json
from dataclasses import asdict, dataclass
from typing import Any

from sitcov.calibration._calibrate import Sample
from sitcov.calibration._camera_runs import CameraRun, RunFrame, stored_features
from sitcov.errors import ConfigError
from sitcov.perception._pem import PEMFeatures


@dataclass(frozen=True)
class Recording:
    """Everything a car calibration measured, enough to refit without rendering.

    Attributes:
        seed: the calibration seed (sweep and camera runs). frames: sweep frames asked for.
        samples: the sweep's frames with the OV in view (:func:`sweep`).
        runs: the recorded camera-mode runs, with their situations, run seeds, verdicts and
            frames: what :func:`fit_pem` and :func:`choose_noise` need.
    """

    seed: int
    frames: int
    samples: tuple[Sample, ...]
    runs: tuple[CameraRun, ...] = ()


def write_recording(path: Any, recording: Recording) -> None:
    """A :class:`Recording` as JSON lines (gzip-compressed if ``path`` ends in ``.gz``):
    a ``meta`` line (seed, frames), one ``sweep`` line per sample, one ``run`` line per run.

    Floats are written by ``repr``, so :func:`read_recording` gives back equal values and a
    refit reproduces the fit made right after recording.
    """
    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "wt") as fh:
        meta = {"seed": recording.seed, "frames": recording.frames}
        fh.write(json.dumps({"meta": meta}) + "\n")
        for smp in recording.samples:
            fh.write(json.dumps({"sweep": asdict(smp)}) + "\n")
        for run in recording.runs:
            fh.write(json.dumps({"run": asdict(run)}) + "\n")


def read_recording(path: Any) -> Recording:
    """What :func:`write_recording` wrote.

    Raises:
        ConfigError: the file cannot be read, has no meta line, or a line is not a sweep,
            run or meta row (one line naming the file and the line number).
    """
    opener = gzip.open if str(path).endswith(".gz") else open
    meta: dict[str, Any] | None = None
    samples: list[Sample] = []
    runs: list[CameraRun] = []
    try:
        fh = opener(path, "rt")
        lines = list(fh)
        fh.close()
    except OSError as exc:
        raise ConfigError(file=str(path), expected="a readable --samples file") from exc
    for n, line in enumerate(lines, 1):
        try:
            row = json.loads(line)
            if "meta" in row:
                meta = {"seed": int(row["meta"]["seed"]), "frames": int(row["meta"]["frames"])}
            elif "sweep" in row:
                samples.append(_sample_from(row["sweep"]))
            else:
                runs.append(run_from_dict(row["run"]))
        except (ValueError, KeyError, TypeError) as exc:
            raise ConfigError(
                file=str(path), field=f"line {n}", value=line[:60],
                expected="a meta, sweep or run row written by sitcov calibrate --samples",
            ) from exc  # fmt: skip
    if meta is None:
        raise ConfigError(file=str(path), field="meta", expected="a meta line (seed, frames)")
    return Recording(meta["seed"], meta["frames"], tuple(samples), tuple(runs))


def _sample_from(row: dict[str, Any]) -> Sample:
    err, color = row["box_error"], row["color"]
    return Sample(
        **{
            **row,
            "features": PEMFeatures(*row["features"]),
            "box_error": None if err is None else tuple(err),
            "color": None if color is None else tuple(color),
        }
    )


def run_from_dict(row: dict[str, Any]) -> CameraRun:
    """A :class:`CameraRun` from its ``asdict`` form read back from JSON."""
    frames = tuple(
        RunFrame(
            **{
                **f,
                "features": stored_features(f["features"], row.get("situation")),
                "box_error": None if f["box_error"] is None else tuple(f["box_error"]),
            }
        )
        for f in row["frames"]
    )
    return CameraRun(**{**row, "frames": frames})
