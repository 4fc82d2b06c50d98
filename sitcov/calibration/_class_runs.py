"""Camera-mode runs of pedestrian and cyclist situations, recorded frame by frame.

The per-class PEM (:mod:`sitcov.perception._pem_classes`) is fitted on static frames and,
as the car PEM is, on frames along re-simulated runs: the situations campaigns meet, in
the frames where the AEB decides. :func:`class_hyperspace` restricts a derived hyperspace
(``sitcov/hyperspace/data/derived/<map>.yaml``) to the situations whose conflicting road
user (``intsit``) is of one kind, with no extra actor (slots ``actor2``, ... = ``none``):
each run then measures that kind alone. :func:`class_camera_runs` drives the reference
stack through random situations of it in camera mode and records, per frame the detector
saw, the PEM features of the actor of that kind and the top score of the detections of
the labels its PEM detection stands for (:data:`sitcov.perception._detector.PEM_LABELS`:
a cyclist's rider, ``person``) matching its box.
Run ``i`` of seed ``s`` is situation ``ask_rng(s, i)`` simulated with ``run_seed(s, i)``,
as in the agreement experiment (stream A).
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Mapping, Sequence
from functools import lru_cache
from importlib import resources
from pathlib import Path
from typing import Any

from sitcov.calibration._camera_runs import CameraRun, _Recorder
from sitcov.errors import ConfigError

#: The kinds a class hyperspace can be restricted to.
CLASS_KINDS = ("pedestrian", "cyclist")
#: Map of the derived hyperspace used when none is named.
DEFAULT_MAP = "t-junction"


@lru_cache(maxsize=8)
def _derived(map_name: str) -> dict[str, Any]:
    from sitcov.hyperspace._load import read_yaml

    res = resources.files("sitcov.hyperspace") / "data" / "derived" / f"{map_name}.yaml"
    if not res.is_file():
        raise ConfigError(field="map", value=map_name, expected="a map with a derived hyperspace")
    return read_yaml(res.read_text(encoding="utf-8"), f"derived/{map_name}.yaml")


def class_hyperspace(kind: str, map_name: str = DEFAULT_MAP) -> Any:
    """The derived hyperspace of ``map_name`` restricted to situations of one ``kind``.

    ``intsit`` keeps the bins whose ``kind`` is ``kind``; every extra actor slot keeps
    only ``none``; the environment axis is unchanged.

    Raises:
        ConfigError: ``kind`` is not a class kind, or the map has no derived hyperspace or
            no situation of that kind.
    """
    from sitcov.hyperspace import Hyperspace

    if kind not in CLASS_KINDS:
        raise ConfigError(field="kind", value=kind, expected=" | ".join(CLASS_KINDS))
    data = _derived(map_name)
    axes = [_restrict_axis(axis, kind) for axis in data["axes"]]
    out = {**data, "name": f"{data['name']}-{kind}", "axes": axes}
    out["constraints"] = _restrict_constraints(data.get("constraints") or [], axes)
    intsit = [b for a in axes for e in a["elements"] if e["name"] == "intsit" for b in e["bins"]]
    if not intsit:
        raise ConfigError(field="intsit", value=map_name, expected=f"situations with a {kind}")
    return Hyperspace.from_dict(out, file=f"derived/{map_name}.yaml[{kind}]")


def _restrict_axis(axis: Mapping[str, Any], kind: str) -> dict[str, Any]:
    elements = []
    for element in axis["elements"]:
        name, bins = element["name"], element["bins"]
        if name == "intsit":
            bins = [b for b in bins if b["value"].get("kind", "car") == kind]
        elif name.startswith("actor") and name[5:].isdigit():
            bins = [b for b in bins if b["value"] == "none"]
        elements.append({**element, "bins": bins})
    return {**axis, "elements": elements}


def _restrict_constraints(constraints: list[Any], axes: list[dict[str, Any]]) -> list[Any]:
    """The constraints with the removed bins' labels dropped; a constraint left with an
    empty list forbids nothing any more and goes."""
    kept = {
        e["name"]: {b.get("label", str(b.get("value"))) for b in e["bins"]}
        for a in axes
        for e in a["elements"]
    }
    out = []
    for c in constraints:
        forbid = {k: [v for v in vals if v in kept.get(k, ())] for k, vals in c["forbid"].items()}
        if all(forbid.values()):
            out.append({**c, "forbid": forbid})
    return out


class ClassRecorder(_Recorder):
    """A camera-mode backend + reference stack over one kind's situations, recording the
    frames of the actors of that kind (detections of the labels its PEM detection stands
    for only: :data:`~sitcov.perception._detector.PEM_LABELS`). ``kind`` is a per-class
    entry: ``bicycle`` records the cyclists' situations scoring their bicycle boxes
    (:data:`~sitcov.perception._detector.PART_KIND`)."""

    def __init__(
        self, kind: str, model: str | None, map_name: str = DEFAULT_MAP, observe: bool = False
    ) -> None:
        from sitcov.generation import make_generator
        from sitcov.perception._detector import PART_KIND, PEM_LABELS

        super().__init__(model, observe)
        self.kind = PART_KIND[kind]
        self.labels = PEM_LABELS[kind]
        self.generator = make_generator("random", class_hyperspace(self.kind, map_name))

    def _records(self, actor: Any) -> bool:
        return actor.kind == self.kind

    def _candidates(self, detections: Any) -> Any:
        return [d for d in detections if d.label in self.labels]


_WORKER: dict[tuple[str, str | None, bool], ClassRecorder] = {}


def _run_in_worker(job: tuple[str, str | None, int, int, bool]) -> CameraRun:
    kind, model, seed, index, observe = job
    if (kind, model, observe) not in _WORKER:
        _WORKER[kind, model, observe] = ClassRecorder(kind, model, observe=observe)
    return _WORKER[kind, model, observe].run(seed, index)


def iter_class_runs(
    kind: str,
    runs: int,
    *,
    seed: int,
    model: str | os.PathLike[str] | None = None,
    workers: int = 1,
    observe: bool = False,
) -> Iterator[CameraRun]:
    """Runs ``0..runs-1`` of seed ``seed`` of ``kind``'s situations, as each one finishes
    (out of index order with ``workers > 1``; every run is the same whatever the workers).
    ``observe``: the stack gets no detections (every frame is recorded, see ``_Recorder``)."""
    model_arg = None if model is None else str(model)
    if workers <= 1:
        recorder = ClassRecorder(kind, model_arg, observe=observe)
        for i in range(runs):
            yield recorder.run(seed, i)
        return
    import multiprocessing as mp

    jobs = [(kind, model_arg, seed, i, observe) for i in range(runs)]
    with mp.get_context("spawn").Pool(workers) as pool:
        yield from pool.imap_unordered(_run_in_worker, jobs)


def class_camera_runs(
    kind: str,
    runs: int,
    *,
    seed: int,
    model: str | os.PathLike[str] | None = None,
    workers: int = 1,
    progress: Callable[[int], None] | None = None,
    observe: bool = False,
) -> list[CameraRun]:
    """:func:`iter_class_runs` collected in index order; ``progress`` gets the runs done."""
    out: list[CameraRun] = []
    runs_it = iter_class_runs(kind, runs, seed=seed, model=model, workers=workers, observe=observe)
    for run in runs_it:
        out.append(run)
        if progress is not None:
            progress(len(out))
    return sorted(out, key=lambda r: r.index)


def check_class_seeds(
    seeds: Sequence[int], kind: str, pem_classes: str | None, *, allow: bool
) -> None:
    """Refuse evaluation seeds the per-class PEM was calibrated on (``meta.calibration_seeds``
    of the per-class file), or a file that does not say, unless ``allow``.

    Raises:
        ConfigError: one line naming the seeds and the file.
    """
    import yaml

    from sitcov.perception._pem_classes import PEM_CLASSES_FILE

    if kind not in CLASS_KINDS:
        raise ConfigError(field="--kind", value=kind, expected=" | ".join(CLASS_KINDS))
    if allow:
        return
    path = PEM_CLASSES_FILE if pem_classes is None else pem_classes
    try:
        meta = (yaml.safe_load(Path(path).read_text()) or {}).get("meta") or {}
    except (OSError, yaml.YAMLError, AttributeError) as exc:
        raise ConfigError(f"{path}: cannot read the per-class PEM file: {exc}") from None
    calibrated = meta.get("calibration_seeds")
    if not isinstance(calibrated, list):
        raise ConfigError(
            f"{path}: meta.calibration_seeds is missing, so held-out seeds cannot be checked; "
            "pass --allow-calibration-seeds to evaluate anyway"
        )
    overlap = sorted(set(seeds) & {int(s) for s in calibrated})
    if overlap:
        raise ConfigError(
            f"--seeds: {overlap} calibrated the per-class PEM ({path}: calibration seeds "
            f"{calibrated}); choose held-out seeds or pass --allow-calibration-seeds"
        )
