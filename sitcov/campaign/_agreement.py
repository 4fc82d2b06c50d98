"""How often PEM mode and camera mode reach the same verdict: the agreement experiment.

Every agreement figure the docs quote about the PEM comes from :func:`run_agreement`
(``sitcov experiment agreement``), computed the same way for every pair of sides.

Construction. For evaluation seed ``s`` and index ``i`` the situation is the random
generator's ``ask_rng(s, i)`` (the situation of run ``i`` of ``sitcov run --generator random
--seed s``). Each situation is simulated with the reference stack, no fault, by up to four
*sides*: PEM mode or camera mode, each under one of two run seeds,

- stream ``A``: ``run_seed(s, i)``, the run seed ``sitcov run`` gives run ``i``;
- stream ``B``: :func:`second_run_seed` ``(s, i)``, drawn from a separate stream of the
  same seed sequence, so it differs from stream A and from every stream-A seed.

A *pair* compares the verdicts (``failed``) of two sides on the same situations, each run
judged by the experiment's judge (``--judge``): ``paper`` by default (collision, the
embedded backend's own status, the verdict of every rows file written before rows
recorded a judge), or any judge a campaign takes (``default`` is what ``sitcov run``
judges by: road departures, a blocked ego and an unfinished route fail a run too):

- ``pem-camera``: camera at A vs PEM at B (run seeds differ);
- ``camera-camera``: camera at A vs camera at B (run seeds differ);
- ``pem-pem``: PEM at A vs PEM at B (run seeds differ);
- ``pem-camera-shared-seed``: camera at A vs PEM at A (the same run seed on both sides;
  what the calibration compares).

The first three are the like-for-like comparisons: each side of each pair sees the same
situation and a run seed of its own, so "the PEM agrees with the camera as often as the
camera agrees with itself" can be checked by comparing their agreements directly.

Where a side's own run-to-run disagreement comes from, two more pairs split (named
explicitly; ``all`` is the four above). A third stream ``AB`` runs the *world* of run seed
A with the *perception* of run seed B (``EmbeddedBackend.run(..., perception_seed=)``):

- ``camera-camera-shared-world``: camera at A vs camera at AB;
- ``pem-pem-shared-world``: PEM at A vs PEM at AB.

What the run seed drives (embedded backend, ``carla`` physics profile): the world's draws
are the wind's direction and gusts (no force in this profile, the rain's slant comes from
the wind's strength, not its direction), each road user's body colour (drawn by the
palette's shares unless the situation declares ``ov_color``) and a pedestrian's or
cyclist's cruising speed; the perception's draws are the PEM's noise and, in camera mode,
where the rain streaks lie in each frame (the renderer and the detector draw nothing else).
The stack is given run seed A on both sides. The disagreement camera-camera-shared-world
leaves is the perception's part of the ceiling; what camera-camera adds to it, the world's
(roughly: the two parts need not add up exactly).

Stacks. Every side runs one AV stack (``--stack``, repeatable; default the reference
stack): the reference AEB, or any stack :func:`sitcov.av.make_stack` can name (e.g. the
decision rules of ``examples/aeb_stacks.py``). In camera mode a stack that has a
``detector`` attribute left None is given the SSD detector. Pairs are formed within a
stack; per stack and side, :func:`side_failures` also compares the failure rates of the
situations whose conflicting road user comes from the ego's left and from its right (a
stack blind on one side must fail more from that side, in both modes).

Evaluation seeds must not be calibration seeds (read from the PEM file's ``meta``, see
:func:`calibration_seeds`); :func:`check_seeds` refuses an overlap.
"""

from __future__ import annotations

import csv
import hashlib
import json
import os
import time
from collections.abc import Callable, Iterable, Iterator, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.hyperspace._situation import approach_side
from sitcov.sim import WORLD_MODEL_VERSION

#: Seed-sequence stream of the second run seed (0 and 1 are ask and run, sitcov._seeding).
_SECOND_RUN_STREAM = 2
#: Pair name -> (side A, side B); a side is (perception, run-seed stream). What ``all``
#: means: the protocol's four pairs.
PAIRS: dict[str, tuple[tuple[str, str], tuple[str, str]]] = {
    "pem-camera": (("camera", "A"), ("pem", "B")),
    "camera-camera": (("camera", "A"), ("camera", "B")),
    "pem-pem": (("pem", "A"), ("pem", "B")),
    "pem-camera-shared-seed": (("camera", "A"), ("pem", "A")),
}
#: The pairs that split a side's run-to-run disagreement into world and perception (stream
#: ``AB``: the world of run seed A, the perception of run seed B); named explicitly.
SPLIT_PAIRS: dict[str, tuple[tuple[str, str], tuple[str, str]]] = {
    "camera-camera-shared-world": (("camera", "A"), ("camera", "AB")),
    "pem-pem-shared-world": (("pem", "A"), ("pem", "AB")),
}
#: Every pair :func:`parse_pairs` accepts.
ALL_PAIRS = {**PAIRS, **SPLIT_PAIRS}
#: Columns of the rows file, one row per simulated run.
ROW_FIELDS = (
    "seed",
    "index",
    "situation_id",
    "perception",
    "stream",
    "run_seed",
    "status",
    "failed",
    "aeb_time",
    "cpu_s",
    "wall_s",
    "stack",
    "world_model",
    "judge",
)
#: The stack of a row that names none (rows files written before stacks were recorded).
DEFAULT_STACK = "reference"
#: The experiment's judge unless told (``--judge``), and that of a row that names none:
#: ``paper`` (collision, the ego hit while standing included), the embedded backend's
#: own status, which every rows file written before rows recorded a judge holds.
DEFAULT_JUDGE = "paper"
#: CPU seconds of one camera-mode run on the reference machine (docs/camera.md), for the
#: runtime estimate printed before the runs start; PEM runs cost about 1 % of it.
CAMERA_CPU_S_PER_RUN = 1.9
PEM_CPU_S_PER_RUN = 0.03
#: Judged statuses (the others, error and timeout, carry no verdict).
_JUDGED = ("pass", "fail")


def second_run_seed(seed: int, index: int) -> int:
    """Stream B's run seed of situation ``index`` of evaluation seed ``seed`` (32-bit)."""
    sequence = np.random.SeedSequence([_SECOND_RUN_STREAM, int(seed), int(index)])
    return int(sequence.generate_state(1, dtype=np.uint32)[0])


def stream_seed(stream: str, seed: int, index: int) -> int:
    """The run seed of ``stream`` (``A`` = the campaign's ``run_seed``, ``B`` = the second,
    ``AB`` = A's: its world is A's; the ``run_seed`` its rows record)."""
    from sitcov._seeding import run_seed

    if stream in ("A", "AB"):
        return run_seed(seed, index)
    if stream == "B":
        return second_run_seed(seed, index)
    raise ConfigError(field="stream", value=stream, expected="A | B | AB")


def perception_seed(stream: str, seed: int, index: int) -> int:
    """The run seed whose perception draws ``stream`` uses (``AB``: B's; else its own)."""
    return stream_seed("B" if stream == "AB" else stream, seed, index)


@dataclass(frozen=True)
class Job:
    """One simulation: situation ``index`` of evaluation seed ``seed`` by one side."""

    seed: int
    index: int
    perception: str
    stream: str
    stack: str = DEFAULT_STACK


def parse_pairs(text: str) -> list[str]:
    """Comma-separated pair names (``all`` = the four of :data:`PAIRS`), checked against
    :data:`ALL_PAIRS`."""
    names = list(PAIRS) if text.strip() == "all" else [p.strip() for p in text.split(",")]
    bad = [p for p in names if p not in ALL_PAIRS]
    if bad or not names:
        expected = "all or a comma-separated subset of " + ", ".join(ALL_PAIRS)
        raise ConfigError(field="--pairs", value=text, expected=expected)
    return list(dict.fromkeys(names))


def parse_seeds(text: str) -> list[int]:
    """Comma-separated distinct non-negative integers, e.g. ``2,4``."""
    try:
        seeds = [int(s) for s in text.split(",") if s.strip()]
    except ValueError:
        seeds = []
    if not seeds or min(seeds) < 0 or len(set(seeds)) != len(seeds):
        raise ConfigError(
            field="--seeds", value=text, expected="distinct non-negative integers, e.g. 2,4"
        )
    return seeds


def plan_jobs(
    seeds: Sequence[int], situations: int, pairs: Sequence[str],
    stacks: Sequence[str] = (DEFAULT_STACK,),
) -> list[Job]:  # fmt: skip
    """Every simulation the pairs need, each once per stack; camera runs first (they are
    the slow ones)."""
    sides = sorted({side for name in pairs for side in ALL_PAIRS[name]})
    jobs = [
        Job(seed, index, perception, stream, stack)
        for stack in stacks
        for perception, stream in sides
        for seed in seeds
        for index in range(situations)
    ]
    order = {stack: k for k, stack in enumerate(stacks)}
    return sorted(
        jobs, key=lambda j: (j.perception != "camera", order[j.stack], j.seed, j.index, j.stream)
    )


def parse_stacks(values: Sequence[str] | None) -> list[str]:
    """``--stack`` values (each may hold several, comma-separated), each built once to
    check it names a stack; default: the reference stack alone.

    Raises:
        ConfigError / UnknownPluginError: a name that is no stack (one line).
    """
    from sitcov.av import make_stack

    names = [n.strip() for v in values or () for n in v.split(",") if n.strip()]
    names = list(dict.fromkeys(names)) or [DEFAULT_STACK]
    for name in names:
        make_stack(name)
    return names


# --- calibration seeds ----------------------------------------------------------------------


def calibration_seeds(pem_file: str | os.PathLike[str] | None = None) -> list[int] | None:
    """The seeds a PEM file was calibrated on, from its ``meta``; None if it does not say.

    ``meta.calibration_seeds`` (a list) if present; otherwise ``meta.camera_runs.seed``,
    which ``sitcov calibrate`` writes (its sweep and its camera runs use that one seed).

    Raises:
        ConfigError: the file cannot be read, or ``meta.calibration_seeds`` is not a list of
            integers.
    """
    import yaml

    from sitcov.perception._pem_params import PEM_PARAMS_FILE

    path = Path(pem_file) if pem_file is not None else PEM_PARAMS_FILE
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except (OSError, yaml.YAMLError) as exc:
        raise ConfigError(f"{path}: cannot read the PEM file: {exc}") from None
    meta = data.get("meta") if isinstance(data, Mapping) else None
    if not isinstance(meta, Mapping):
        return None
    if "calibration_seeds" in meta:
        seeds = meta["calibration_seeds"]
        if not isinstance(seeds, list) or not all(_is_int(s) for s in seeds):
            raise ConfigError(
                file=str(path), field="meta.calibration_seeds", value=seeds,
                expected="a list of integers",
            )  # fmt: skip
        return sorted({int(s) for s in seeds})
    runs = meta.get("camera_runs")
    if isinstance(runs, Mapping) and _is_int(runs.get("seed")):
        return [int(runs["seed"])]
    return None


def _is_int(value: Any) -> bool:
    return isinstance(value, int) and not isinstance(value, bool)


def check_seeds(
    seeds: Sequence[int], calibrated: Sequence[int] | None, *, allow: bool, pem_file: str
) -> None:
    """Refuse evaluation seeds the PEM was calibrated on (or a PEM that does not say).

    Raises:
        ConfigError: one line naming the overlapping seeds and the PEM file, unless
            ``allow`` (``--allow-calibration-seeds``, for development only).
    """
    if allow:
        return
    if calibrated is None:
        raise ConfigError(
            f"{pem_file}: meta names no calibration seeds (meta.calibration_seeds or "
            "meta.camera_runs.seed), so held-out seeds cannot be checked; pass "
            "--allow-calibration-seeds to evaluate anyway"
        )
    overlap = sorted(set(seeds) & set(calibrated))
    if overlap:
        raise ConfigError(
            f"--seeds: {overlap} calibrated the PEM ({pem_file}: calibration seeds "
            f"{list(calibrated)}); choose held-out seeds or pass --allow-calibration-seeds"
        )


# --- running the sides ----------------------------------------------------------------------


@dataclass(frozen=True)
class SideSettings:
    """What a side needs to run: the PEM file and the detector model (None = defaults);
    ``kind``: situations of the derived hyperspace with a pedestrian or a cyclist only
    (:func:`sitcov.calibration._class_runs.class_hyperspace`); ``pem_classes``: the
    per-class PEM file (None = shipped); ``pem_draws``: a PEM side's verdict is the
    majority of that many perception draws of the run's world
    (:class:`~sitcov.campaign._draws.PerceptionDraws`; 1 = one run); ``judge``: the
    judge of every run's verdict (:func:`judge_text`)."""

    pem_file: str | None = None
    model: str | None = None
    kind: str | None = None
    pem_classes: str | None = None
    pem_draws: int = 1
    judge: str = DEFAULT_JUDGE


def judge_text(spec: str | Sequence[str] | None) -> str:
    """A judge setting as rows and summaries record it: its name (``paper``, ``default``,
    ``strict``) or its failure kinds, comma-separated (:func:`sitcov.sim.normalize_judge`;
    None is :data:`DEFAULT_JUDGE`).

    Raises:
        ConfigError: an unknown judge or failure kind.
    """
    from sitcov.sim import normalize_judge

    canon = normalize_judge(DEFAULT_JUDGE if spec is None else spec)
    return canon if isinstance(canon, str) else ",".join(canon)


class SideRunner:
    """Runs jobs with the reference stack on the embedded backend; one per process.

    The backends, stacks and the detector are built on first use and reused: the PEM
    sensor and the stack are reset at the start of every run, so a run's verdict depends
    only on (situation, run seed).
    """

    def __init__(self, settings: SideSettings) -> None:
        from sitcov.generation import make_generator
        from sitcov.sim import Judge

        self.settings = settings
        self.judge = Judge.from_spec(settings.judge)
        self.generator = make_generator("random", _hyperspace(settings.kind))
        self._sides: dict[tuple[str, str], tuple[Any, Any]] = {}
        self._detector: Any = None

    def _side(self, perception: str, name: str = DEFAULT_STACK) -> tuple[Any, Any]:
        if (perception, name) not in self._sides:
            from sitcov.av import make_stack
            from sitcov.perception import PEMSensor
            from sitcov.sim.embedded import EmbeddedBackend

            stack = make_stack(name)
            if perception == "pem":
                sensor = PEMSensor(self.settings.pem_file, classes=self.settings.pem_classes)
                backend = EmbeddedBackend(perception="pem", sensor=sensor)
                if self.settings.pem_draws > 1:
                    from sitcov.campaign._draws import PerceptionDraws

                    backend = PerceptionDraws(
                        backend, self.settings.pem_draws, lambda o: bool(self.judge(o).failed)
                    )
            else:
                from sitcov.perception import SSDDetector

                backend = EmbeddedBackend(perception="camera")
                if getattr(stack, "detector", False) is None:
                    if self._detector is None:
                        self._detector = SSDDetector(self.settings.model)
                    stack.detector = self._detector
            self._sides[perception, name] = (backend, stack)
        return self._sides[perception, name]

    def __call__(self, job: Job) -> dict[str, Any]:
        """Simulate ``job``; its row of the rows file."""
        from sitcov._seeding import ask_rng

        backend, stack = self._side(job.perception, job.stack)
        situation = self.generator.ask(ask_rng(job.seed, job.index))
        seed = stream_seed(job.stream, job.seed, job.index)
        sense = perception_seed(job.stream, job.seed, job.index)
        cpu, wall = time.process_time(), time.perf_counter()
        if sense == seed:
            outcome = backend.run(situation, stack, seed)
        else:
            outcome = backend.run(situation, stack, seed, perception_seed=sense)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        outcome = self.judge(outcome)
        return {
            **asdict(job),
            "situation_id": situation.id,
            "run_seed": seed,
            "status": outcome.status,
            "failed": bool(outcome.failed),
            "aeb_time": None if outcome.aeb_time is None else round(outcome.aeb_time, 4),
            "cpu_s": round(cpu, 4),
            "wall_s": round(wall, 4),
            "world_model": WORLD_MODEL_VERSION,
            "judge": self.settings.judge,
        }


def _hyperspace(kind: str | None) -> Any:
    """The situations' hyperspace: the default one, or one kind's (``kind``)."""
    if kind is None:
        from sitcov.hyperspace import load_hyperspace

        return load_hyperspace()
    from sitcov.calibration._class_runs import class_hyperspace

    return class_hyperspace(kind)


_WORKER: dict[SideSettings, SideRunner] = {}


def _run_in_worker(item: tuple[SideSettings, Job]) -> dict[str, Any]:
    """Worker entry point: one runner per process (per settings), reused across jobs."""
    settings, job = item
    if settings not in _WORKER:
        _WORKER[settings] = SideRunner(settings)
    return _WORKER[settings](job)


def iter_rows(
    jobs: Sequence[Job],
    settings: SideSettings,
    *,
    workers: int = 1,
    run_job: Callable[[Job], dict[str, Any]] | None = None,
) -> Iterator[dict[str, Any]]:
    """The rows of ``jobs`` as they finish (out of order with ``workers > 1``).

    ``run_job`` replaces the real :class:`SideRunner` (serial only; tests use a fake).
    Every row is the same whatever the number of workers.
    """
    if run_job is not None or workers <= 1:
        runner = run_job or SideRunner(settings)
        for job in jobs:
            yield runner(job)
        return
    import multiprocessing as mp

    with mp.get_context("spawn").Pool(workers) as pool:
        yield from pool.imap_unordered(_run_in_worker, [(settings, j) for j in jobs])


# --- the rows file --------------------------------------------------------------------------


def rows_format(path: Path) -> str:
    """``csv`` or ``jsonl`` from the file's suffix."""
    suffix = path.suffix.lower()
    if suffix not in (".csv", ".jsonl"):
        raise ConfigError(field="--out", value=str(path), expected="a .csv or .jsonl file name")
    return suffix[1:]


class RowsWriter:
    """Appends rows to the rows file as runs finish (an interrupted run keeps its data)."""

    def __init__(self, path: Path) -> None:
        self.path, self.fmt = path, rows_format(path)
        self._fh = open(path, "w", newline="")  # noqa: SIM115 - closed in close()
        self._csv = csv.DictWriter(self._fh, fieldnames=ROW_FIELDS) if self.fmt == "csv" else None
        if self._csv is not None:
            self._csv.writeheader()

    def write(self, row: Mapping[str, Any]) -> None:
        """One row, flushed."""
        if self._csv is not None:
            self._csv.writerow({k: "" if _field(row, k) is None else _field(row, k)
                                for k in ROW_FIELDS})  # fmt: skip
        else:
            self._fh.write(json.dumps({k: _field(row, k) for k in ROW_FIELDS}) + "\n")
        self._fh.flush()

    def close(self) -> None:
        """Close the file."""
        self._fh.close()


def _field(row: Mapping[str, Any], key: str) -> Any:
    """``row[key]``; the stack of a row that names none is the reference stack, its judge
    the backend's own (:data:`DEFAULT_JUDGE`), the world model of a row written before
    rows recorded it is unknown (empty)."""
    if key == "stack":
        return row.get(key, DEFAULT_STACK)
    if key == "judge":
        return row.get(key) or DEFAULT_JUDGE
    if key == "world_model":
        return row.get(key)
    return row[key]


def write_rows(path: Path, rows: Iterable[Mapping[str, Any]]) -> None:
    """Write ``rows`` to ``path`` (csv or jsonl by suffix) in one go."""
    writer = RowsWriter(path)
    try:
        for row in rows:
            writer.write(row)
    finally:
        writer.close()


def read_rows(path: Path) -> list[dict[str, Any]]:
    """Rows written by :class:`RowsWriter`, typed back (ints, bools, floats, None)."""
    if rows_format(path) == "jsonl":
        rows = [json.loads(line) for line in path.read_text().splitlines() if line.strip()]
        return [
            {
                **r,
                "stack": r.get("stack") or DEFAULT_STACK,
                "world_model": r.get("world_model"),
                "judge": r.get("judge") or DEFAULT_JUDGE,
            }
            for r in rows
        ]
    with open(path, newline="") as fh:
        return [_typed(raw) for raw in csv.DictReader(fh)]


def _typed(raw: Mapping[str, str]) -> dict[str, Any]:
    def num(text: str) -> float | None:
        return None if text == "" else float(text)

    return {
        "seed": int(raw["seed"]),
        "index": int(raw["index"]),
        "situation_id": raw["situation_id"],
        "perception": raw["perception"],
        "stream": raw["stream"],
        "run_seed": int(raw["run_seed"]),
        "status": raw["status"],
        "failed": raw["failed"] == "True",
        "aeb_time": num(raw["aeb_time"]),
        "cpu_s": num(raw["cpu_s"]),
        "wall_s": num(raw["wall_s"]),
        "stack": raw.get("stack") or DEFAULT_STACK,
        "world_model": int(raw["world_model"]) if raw.get("world_model") else None,
        "judge": raw.get("judge") or DEFAULT_JUDGE,
    }


def sort_rows(rows: Iterable[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """Rows in a fixed order (seed, index, perception, stream): reproducible files."""
    key = ("stack", "seed", "index", "perception", "stream")
    return sorted(
        ({**r, "stack": _field(r, "stack")} for r in rows),
        key=lambda r: tuple(r[k] for k in key),
    )


# --- the summary ----------------------------------------------------------------------------


def _interval(k: int, n: int) -> list[float] | None:
    from sitcov.analysis import wilson_interval

    ci = wilson_interval(k, n)
    return None if ci is None else [round(ci[0], 4), round(ci[1], 4)]


def compare(rows: Sequence[Mapping[str, Any]], pair: str) -> dict[str, Any]:
    """Agreement of one pair over ``rows`` (situations judged on both sides only).

    Returns n (situations judged by both sides), agree, agreement and its Wilson 95 %
    interval, each side's failures, failure rate and interval, the two kinds of
    disagreement and the situations left out because a side errored or timed out.
    """
    (pa, sa), (pb, sb) = ALL_PAIRS[pair]
    by_key = {(r["seed"], r["index"], r["perception"], r["stream"]): r for r in rows}
    keys = sorted({(r["seed"], r["index"]) for r in rows})
    n = agree = fail_a = fail_b = a_only = b_only = left_out = 0
    for seed, index in keys:
        ra, rb = by_key.get((seed, index, pa, sa)), by_key.get((seed, index, pb, sb))
        if ra is None or rb is None:
            continue
        if ra["status"] not in _JUDGED or rb["status"] not in _JUDGED:
            left_out += 1
            continue
        a, b = bool(ra["failed"]), bool(rb["failed"])
        n += 1
        agree += a == b
        fail_a, fail_b = fail_a + a, fail_b + b
        a_only, b_only = a_only + (a and not b), b_only + (b and not a)
    return {
        "side_a": f"{pa}@{sa}",
        "side_b": f"{pb}@{sb}",
        "n": n,
        "agree": agree,
        "agreement": round(agree / n, 4) if n else None,
        "agreement_ci95": _interval(agree, n),
        "failures_a": fail_a,
        "failure_rate_a": round(fail_a / n, 4) if n else None,
        "failure_rate_a_ci95": _interval(fail_a, n),
        "failures_b": fail_b,
        "failure_rate_b": round(fail_b / n, 4) if n else None,
        "failure_rate_b_ci95": _interval(fail_b, n),
        "a_fails_b_passes": a_only,
        "b_fails_a_passes": b_only,
        "not_judged": left_out,
    }


def ceiling_split(rows: Sequence[Mapping[str, Any]], perception: str) -> dict[str, int]:
    """Which draws decide a mode's run-to-run flips: situations judged at A, B and AB.

    ``flips``: A and B disagree (the ceiling's flips); ``shared_world_flips``: A and AB
    disagree (the perception's draws alone); of the ``flips``, ``world`` keep A's verdict
    at AB (the world's draws decide them) and ``perception`` take B's (A's world with B's
    perception gives B's verdict). ``world + perception == flips``.
    """
    by_key = {(r["seed"], r["index"], r["stream"]): r for r in rows
              if r["perception"] == perception and r["status"] in _JUDGED}  # fmt: skip
    out = dict(n=0, flips=0, shared_world_flips=0, world=0, perception=0)
    for seed, index in sorted({(k[0], k[1]) for k in by_key}):
        sides = [by_key.get((seed, index, s)) for s in ("A", "B", "AB")]
        if any(r is None for r in sides):
            continue
        a, b, ab = (bool(r["failed"]) for r in sides)  # type: ignore[index]
        out["n"] += 1
        out["shared_world_flips"] += a != ab
        if a != b:
            out["flips"] += 1
            out["world" if ab == a else "perception"] += 1
    return out


def summarise(
    rows: Sequence[Mapping[str, Any]], pairs: Sequence[str], seeds: Sequence[int]
) -> dict[str, Any]:
    """Per pair: pooled over ``seeds`` and per seed; per perception: cost of a run and,
    with its shared-world pair and its pair across run seeds, :func:`ceiling_split`."""
    result: dict[str, Any] = {"pairs": {}, "cost": {}}
    for pair in pairs:
        per_seed = {str(s): compare([r for r in rows if r["seed"] == s], pair) for s in seeds}
        result["pairs"][pair] = {"pooled": compare(rows, pair), "per_seed": per_seed}
    for perception in ("camera", "pem"):
        if {f"{perception}-{perception}", f"{perception}-{perception}-shared-world"} <= set(pairs):
            result.setdefault("ceiling_split", {})[perception] = ceiling_split(rows, perception)
    for perception in ("camera", "pem"):
        mine = [r for r in rows if r["perception"] == perception]
        if mine:
            result["cost"][perception] = {
                "runs": len(mine),
                "cpu_s_per_run": round(sum(r["cpu_s"] or 0.0 for r in mine) / len(mine), 4),
                "wall_s_per_run": round(sum(r["wall_s"] or 0.0 for r in mine) / len(mine), 4),
            }
    return result


def pool_rows_files(
    paths: Sequence[Path], pairs: Sequence[str], by: str | None = None,
    kind: str | None = None, stacks: Sequence[str] | None = None,
) -> dict[str, Any]:  # fmt: skip
    """Each pair's agreement pooled over the rows files of several runs of the experiment
    (e.g. seeds 2, 4 and seeds 8, 9, measured with different ``--situations``), per stack
    (pairs are formed within a stack; ``pairs`` at the top level is the first stack's, as
    in :func:`run_agreement`'s summary). With ``by`` (a hyperspace element, or
    ``approach``: where the road user comes from), each stack's pairs split by the
    situations' bin of it (:func:`split_agreement`); ``kind`` names the situations'
    hyperspace (pedestrian or cyclist rows); ``stacks`` keeps those stacks only.

    Raises:
        ConfigError: no file, two files holding the same (stack, seed, index, side) row,
            rows of several judges, a stack no file holds or an element the hyperspace
            does not have.
    """
    if not paths:
        raise ConfigError(field="FILES", value="", expected="at least one rows file")
    rows = _pooled_rows(paths)
    judges = sorted({_field(r, "judge") for r in rows})
    if len(judges) > 1:
        raise ConfigError(field="judge", value=judges,
                          expected="rows files of one judge (their verdicts differ)")  # fmt: skip
    found = list(dict.fromkeys(_field(r, "stack") for r in rows))
    for name in stacks or ():
        if name not in found:
            listed = ", ".join(found)
            raise ConfigError(field="--stack", value=name,
                              expected=f"a stack of the rows files ({listed})")  # fmt: skip
    keep = list(stacks) if stacks else found
    groups = situation_groups({(r["seed"], r["index"]) for r in rows}, by, kind) if by else None
    per_stack: dict[str, Any] = {}
    for name in keep:
        mine = [r for r in rows if _field(r, "stack") == name]
        entry: dict[str, Any] = {"pairs": {pair: compare(mine, pair) for pair in pairs}}
        if groups is not None:
            entry["by"] = {pair: split_agreement(mine, pair, groups) for pair in pairs}
        per_stack[name] = entry
    return {
        "files": [str(p) for p in paths],
        "judge": judges[0] if judges else DEFAULT_JUDGE,
        "seeds": sorted({r["seed"] for r in rows}),
        "pairs": per_stack[keep[0]]["pairs"] if keep else {},
        "stacks": per_stack,
        "by": by,
    }


def _pooled_rows(paths: Sequence[Path]) -> list[dict[str, Any]]:
    """The rows of every file; a (stack, seed, index, side) row in two files is refused."""
    rows: list[dict[str, Any]] = []
    seen: dict[tuple, Path] = {}
    for path in paths:
        for row in read_rows(Path(path)):
            key = (_field(row, "stack"), row["seed"], row["index"], row["perception"],
                   row["stream"])  # fmt: skip
            if key in seen:
                raise ConfigError(
                    file=str(path),
                    field="rows",
                    value=list(key),
                    expected=f"rows not already in {seen[key]} (the same run twice)",
                )
            seen[key] = Path(path)
            rows.append(row)
    return rows


#: The split of :func:`situation_groups` that is not a hyperspace element: where the
#: conflicting road user comes from (:func:`approach_side`).
APPROACH = "approach"


def situation_groups(
    keys: Iterable[tuple[int, int]], by: str, kind: str | None = None
) -> dict[tuple[int, int], str]:
    """(seed, index) -> the situation's bin of the element ``by`` (or its
    :func:`approach_side` for ``approach``), each situation regenerated.

    Raises:
        ConfigError: ``by`` is neither ``approach`` nor an element of the hyperspace.
    """
    from sitcov._seeding import ask_rng
    from sitcov.generation import make_generator

    space = _hyperspace(kind)
    names = [e.name for e in space.elements]
    if by != APPROACH and by not in names:
        expected = f"{APPROACH} or an element of the hyperspace ({', '.join(names)})"
        raise ConfigError(field="--by", value=by, expected=expected)
    gen = make_generator("random", space)
    out = {}
    for seed, index in sorted(keys):
        sit = gen.ask(ask_rng(seed, index))
        side = approach_side(sit.bins, sit.values) if by == APPROACH else None
        out[seed, index] = side or str(sit.bins[by])
    return out


def split_agreement(
    rows: Sequence[Mapping[str, Any]], pair: str, groups: Mapping[tuple[int, int], str]
) -> dict[str, dict[str, Any]]:
    """:func:`compare` of one pair within each group of situations (``groups``: (seed,
    index) -> label), with the exact McNemar test of its disagreements (two-sided: a
    side that fails alone more often than the other in this group, ``p``) and the
    Benjamini-Hochberg adjusted ``q`` over the groups (many groups give some small ``p``
    by chance; ``q`` < 0.05 bounds the share of such false finds among the groups it
    flags)."""
    from scipy.stats import binomtest, false_discovery_control

    by_label: dict[str, list[Mapping[str, Any]]] = {}
    for r in rows:
        label = groups.get((r["seed"], r["index"]))
        if label is not None:
            by_label.setdefault(label, []).append(r)
    out = {label: compare(by_label[label], pair) for label in sorted(by_label, key=_natural_key)}
    for row in out.values():
        flips = row["a_fails_b_passes"] + row["b_fails_a_passes"]
        row["p"] = binomtest(row["a_fails_b_passes"], flips, 0.5).pvalue if flips else 1.0
    if out:
        qs = false_discovery_control([row["p"] for row in out.values()])
        for row, q in zip(out.values(), qs, strict=True):
            row["p"], row["q"] = round(float(row["p"]), 6), round(float(q), 6)
    return out


def _natural_key(label: str) -> tuple[Any, ...]:
    """``IntSit-2`` before ``IntSit-10``; numeric bins by value."""
    import re

    return tuple(int(p) if p.isdigit() else p for p in re.split(r"(\d+)", label))


def pool_lines(pooled: Mapping[str, Any]) -> list[str]:
    """The printed pooled table (same columns as :func:`table_lines`): one block per stack
    when the files hold several, each pair's split by ``by`` under it."""
    lines = [f"pooled over {', '.join(pooled['files'])} (seeds {pooled['seeds']})"]
    stacks = pooled.get("stacks") or {DEFAULT_STACK: {"pairs": pooled["pairs"]}}
    for name, entry in stacks.items():
        if len(stacks) > 1 or name != DEFAULT_STACK:
            lines.append(f"== stack {name}")
        for pair, row in entry["pairs"].items():
            if not row["n"]:
                continue
            lines.append(_line(pair, row))
            for label, cell in entry.get("by", {}).get(pair, {}).items():
                lines.append(
                    _line(f"  {pooled['by']} {label}", cell)
                    + f"  McNemar p {_p(cell['p'])}, q {_p(cell['q'])}"
                    + ("  <-" if cell["q"] < SIDE_ALPHA else "")
                )
    return lines


def situation_sides(
    seeds: Sequence[int], situations: int, kind: str | None = None
) -> dict[tuple[int, int], str]:
    """(seed, index) -> :func:`approach_side` of the situation (regenerated)."""
    from sitcov._seeding import ask_rng
    from sitcov.generation import make_generator

    gen = make_generator("random", _hyperspace(kind))
    out = {}
    for s in seeds:
        for i in range(situations):
            sit = gen.ask(ask_rng(s, i))
            out[s, i] = approach_side(sit.bins, sit.values)
    return out


def side_failures(
    rows: Sequence[Mapping[str, Any]], sides: Mapping[tuple[int, int], str]
) -> dict[str, Any]:
    """Per side of the experiment (``camera@A``, ``pem@B``, ...): failures of the
    situations whose road user comes from the left and from the right, with Wilson 95 %
    intervals, and the one-sided Fisher exact p-value of "fails more often from the
    right" (and from the left): a weakness on one side shows as a small p."""
    from scipy.stats import fisher_exact

    cells: dict[str, dict[str, list[int]]] = {}
    for r in rows:
        if r["status"] not in _JUDGED:
            continue
        where = sides.get((r["seed"], r["index"]))
        if where not in ("left", "right"):
            continue
        cell = cells.setdefault(f"{r['perception']}@{r['stream']}", {}).setdefault(where, [0, 0])
        cell[0] += 1
        cell[1] += bool(r["failed"])
    out: dict[str, Any] = {}
    for side, by in sorted(cells.items()):
        (nl, kl), (nr, kr) = by.get("left", [0, 0]), by.get("right", [0, 0])
        table = [[kr, nr - kr], [kl, nl - kl]]
        p_right = float(fisher_exact(table, alternative="greater")[1]) if nl and nr else None
        p_left = float(fisher_exact(table, alternative="less")[1]) if nl and nr else None
        out[side] = {
            "left": {"n": nl, "failures": kl, "failure_rate": round(kl / nl, 4) if nl else None,
                     "ci95": _interval(kl, nl)},
            "right": {"n": nr, "failures": kr, "failure_rate": round(kr / nr, 4) if nr else None,
                      "ci95": _interval(kr, nr)},
            "p_right_fails_more": None if p_right is None else round(p_right, 6),
            "p_left_fails_more": None if p_left is None else round(p_left, 6),
        }  # fmt: skip
    return out


#: One-sided Fisher p below which :func:`side_verdict` says a side fails more.
SIDE_ALPHA = 0.05


def side_verdict(sides: Mapping[str, Mapping[str, Any]]) -> str | None:
    """Where each mode finds a side that fails more (:func:`side_failures`' rows: any run
    seed stream with p < :data:`SIDE_ALPHA`), in words: a side that fails more in both
    modes is the stack's; in PEM mode only, not shown to be the stack's (from the left the
    PEM's known bias: it under-reports close cars from the left, docs/pem.md "Within a
    band"); in camera mode only, a weakness the PEM hides. None without rows of both
    modes."""
    found: dict[str, set[str]] = {"camera": set(), "pem": set()}
    for name, row in sides.items():
        mode = name.partition("@")[0]
        for where in ("left", "right"):
            p = row.get(f"p_{where}_fails_more")
            if mode in found and p is not None and p < SIDE_ALPHA:
                found[mode].add(where)
    modes = {name.partition("@")[0] for name in sides}
    if not {"camera", "pem"} <= modes:
        return None
    said = []
    for where in ("left", "right"):
        cam, pem = where in found["camera"], where in found["pem"]
        if cam and pem:
            said.append(f"from the {where} fails more in both modes (the stack's)")
        elif pem:
            known = (
                ': the PEM under-reports close cars from the left, docs/pem.md "Within a band"'
                if where == "left"
                else ""
            )
            said.append(
                f"from the {where} fails more in PEM mode only (not shown to be the stack's{known})"
            )
        elif cam:
            said.append(f"from the {where} fails more in camera mode only (the PEM hides it)")
    return "; ".join(said) or "neither side fails significantly more in either mode"


def situation_bins(
    seeds: Sequence[int], situations: int, kind: str | None = None
) -> dict[tuple[int, int], dict]:
    """(seed, index) -> the situation's bins (regenerated: the random generator is cheap)."""
    from sitcov._seeding import ask_rng
    from sitcov.generation import make_generator

    gen = make_generator("random", _hyperspace(kind))
    return {(s, i): dict(gen.ask(ask_rng(s, i)).bins) for s in seeds for i in range(situations)}


def bin_differences(
    rows: Sequence[Mapping[str, Any]], pair: str, bins: Mapping[tuple[int, int], Mapping]
) -> dict[str, dict[str, Any]]:
    """Per element: the largest difference between the two sides' failure rates in one bin.

    Only situations judged on both sides count; ``min_n`` is the smallest bin's size, which
    says how much of the difference sampling noise alone explains.
    """
    (pa, sa), (pb, sb) = ALL_PAIRS[pair]
    by_key = {(r["seed"], r["index"], r["perception"], r["stream"]): r for r in rows}
    counts: dict[str, dict[str, list[int]]] = {}  # element -> bin -> [n, fails a, fails b]
    for (seed, index), sit_bins in bins.items():
        ra, rb = by_key.get((seed, index, pa, sa)), by_key.get((seed, index, pb, sb))
        if ra is None or rb is None or {ra["status"], rb["status"]} - set(_JUDGED):
            continue
        for element, name in sit_bins.items():
            cell = counts.setdefault(element, {}).setdefault(name, [0, 0, 0])
            cell[0], cell[1], cell[2] = cell[0] + 1, cell[1] + ra["failed"], cell[2] + rb["failed"]
    return {
        element: {
            "max_difference": round(max(abs(a - b) / n for n, a, b in per_bin.values()), 3),
            "min_n": min(n for n, _, _ in per_bin.values()),
        }
        for element, per_bin in counts.items()
    }


def estimate_seconds(jobs: Sequence[Job], workers: int) -> float:
    """Expected wall time of ``jobs`` on ``workers`` free cores [s] (a rough planning figure)."""
    cpu = sum(CAMERA_CPU_S_PER_RUN if j.perception == "camera" else PEM_CPU_S_PER_RUN
              for j in jobs)  # fmt: skip
    return cpu / max(1, workers)


def run_agreement(
    *,
    seeds: Sequence[int],
    situations: int,
    out: Path,
    pairs: Sequence[str] = tuple(PAIRS),
    pem_file: str | None = None,
    model: str | None = None,
    workers: int = 1,
    allow_calibration_seeds: bool = False,
    camera_rows: Path | Sequence[Path] | None = None,
    kind: str | None = None,
    pem_classes: str | None = None,
    stacks: Sequence[str] = (DEFAULT_STACK,),
    pem_draws: int = 1,
    judge: str | Sequence[str] | None = None,
    run_job: Callable[[Job], dict[str, Any]] | None = None,
    on_plan: Callable[[list[Job]], None] | None = None,
    progress: Callable[[dict[str, Any]], None] | None = None,
) -> dict[str, Any]:
    """Run the agreement experiment; write the rows to ``out``; return the summary.

    Checks everything before the first run: the pairs, the rows file's suffix, the PEM
    file, that no evaluation seed calibrated it, and (when a camera side is needed) the
    detector model. ``on_plan`` then gets the jobs (to print the plan), ``progress`` each
    row as it finishes. ``camera_rows``: one or several rows files of earlier runs whose
    camera-mode rows are taken instead of simulated again (see :func:`reusable_camera_rows`).
    ``kind``: pedestrian or cyclist situations only (their PEM: ``pem_classes``, whose
    calibration seeds are refused too). ``pem_draws``: each PEM run's verdict is the
    majority of that many perception draws of its world (odd; the camera side runs once).
    ``judge``: the verdict of every run (a campaign's judge setting; None = ``paper``, the
    backend's own status; ``default`` = what ``sitcov run`` judges by default); camera
    rows are reused only from the same judge.

    Raises:
        ConfigError: bad arguments, or evaluation seeds the PEM was calibrated on.
    """
    from sitcov._version import __version__
    from sitcov.perception._pem_params import PEM_PARAMS_FILE, load_pem_params

    if situations < 1:
        raise ConfigError(field="--situations", value=situations, expected="at least 1")
    from sitcov.campaign._draws import check_draws

    check_draws(pem_draws, field="--pem-draws")
    judge_name = judge_text(judge)
    rows_format(out)
    pem_path = Path(pem_file) if pem_file is not None else PEM_PARAMS_FILE
    pem_name = str(pem_file) if pem_file is not None else "sitcov/perception/data/pem.yaml"
    load_pem_params(pem_file)
    calibrated = calibration_seeds(pem_file)
    check_seeds(seeds, calibrated, allow=allow_calibration_seeds, pem_file=pem_name)
    if kind is not None:
        from sitcov.calibration._class_runs import check_class_seeds

        check_class_seeds(seeds, kind, pem_classes, allow=allow_calibration_seeds)
    jobs = plan_jobs(seeds, situations, pairs, stacks)
    row_files = _row_files(camera_rows)
    reused: dict[tuple, dict[str, Any]] = {}
    for path in row_files:  # the first file that has a row gives it
        for key, row in reusable_camera_rows(path, jobs, judge_name).items():
            reused.setdefault(key, row)
    jobs = [j for j in jobs if _job_key(j) not in reused]
    if run_job is None and any(j.perception == "camera" for j in jobs):
        from sitcov.perception._models import model_path

        model = str(model_path(model))
    settings = SideSettings(
        pem_file=None if pem_file is None else str(pem_file), model=model, kind=kind,
        pem_classes=pem_classes, pem_draws=pem_draws, judge=judge_name,
    )  # fmt: skip
    if on_plan is not None:
        on_plan(jobs)
    start = time.perf_counter()
    rows: list[dict[str, Any]] = list(reused.values())
    writer = RowsWriter(out)
    try:
        for row in rows:
            writer.write(row)
        for row in iter_rows(jobs, settings, workers=workers, run_job=run_job):
            rows.append(row)
            writer.write(row)
            if progress is not None:
                progress(row)
    finally:
        writer.close()
    wall = time.perf_counter() - start
    rows = sort_rows(rows)
    write_rows(out, rows)
    bins = situation_bins(seeds, situations, kind)
    sides = situation_sides(seeds, situations, kind)
    per_stack: dict[str, Any] = {}
    for name in stacks:
        mine = [r for r in rows if r["stack"] == name]
        result = summarise(mine, pairs, seeds)
        for pair in pairs:
            result["pairs"][pair]["bin_differences"] = bin_differences(mine, pair, bins)
        result["sides"] = side_failures(mine, sides)
        result["side_verdict"] = side_verdict(result["sides"])
        per_stack[name] = result
    summary = dict(per_stack[stacks[0]])
    summary["stacks"] = per_stack
    summary.update(
        construction=CONSTRUCTION,
        seeds=list(seeds),
        situations_per_seed=situations,
        pem_file=pem_name,
        pem_draws=pem_draws,
        judge=judge_name,
        pem_sha256=hashlib.sha256(pem_path.read_bytes()).hexdigest(),
        sitcov_version=__version__,
        world_model=WORLD_MODEL_VERSION,
        calibration_seeds=calibrated,
        workers=workers,
        runs={
            "camera": sum(j.perception == "camera" for j in jobs),
            "pem": sum(j.perception == "pem" for j in jobs),
            "camera_reused": len(reused),
        },  # fmt: skip
        camera_rows_from=_rows_from(row_files),
        kind=kind,
        pem_classes=pem_classes,
        wall_s=round(wall, 1),
        rows_file=str(out),
    )
    return summary


def _row_files(camera_rows: Path | Sequence[Path] | None) -> list[Path]:
    """``--camera-rows`` as a list of paths (none, one or several files)."""
    if camera_rows is None:
        return []
    if isinstance(camera_rows, (str, Path)):
        return [Path(camera_rows)]
    return [Path(p) for p in camera_rows]


def _rows_from(files: Sequence[Path]) -> str | list[str] | None:
    """The summary's ``camera_rows_from``: None, the one file (as before), or the list."""
    if not files:
        return None
    return str(files[0]) if len(files) == 1 else [str(f) for f in files]


def _job_key(job: Job) -> tuple[int, int, str, str, str]:
    return (job.seed, job.index, job.perception, job.stream, job.stack)


def reusable_camera_rows(
    path: Path, jobs: Sequence[Job], judge: str = DEFAULT_JUDGE
) -> dict[tuple, dict[str, Any]]:
    """The camera-mode rows of an earlier rows file that ``jobs`` would simulate again.

    A camera-mode run does not involve the PEM: after a recalibration its row is the same
    as before (with the same renderer, detector, backend and stack code, which the caller
    vouches for). A row is reused when its seed, index, stream and run seed match a
    planned camera job, it was judged (pass or fail) and it was simulated by this world
    model (``sitcov.sim.WORLD_MODEL_VERSION``): a row of another world model, or of a file
    written before rows recorded it, judged another world (other verdicts, road users
    that did not react) and is simulated again; so is a row of another ``judge``
    (:func:`judge_text`; a row that names none has the backend's own verdict, ``paper``).

    Raises:
        ConfigError: the file cannot be read.
    """
    try:
        old = read_rows(path)
    except (OSError, KeyError, ValueError) as exc:
        raise ConfigError(f"{path}: cannot read camera rows: {exc}") from None
    wanted = {_job_key(j): j for j in jobs if j.perception == "camera"}
    out: dict[tuple, dict[str, Any]] = {}
    for row in old:
        key = (row["seed"], row["index"], row["perception"], row["stream"], row["stack"])
        job = wanted.get(key)
        if job is None or row["status"] not in _JUDGED:
            continue
        if row.get("world_model") != WORLD_MODEL_VERSION or _field(row, "judge") != judge:
            continue
        if row["run_seed"] == stream_seed(job.stream, job.seed, job.index):
            out[key] = row
    return out


#: The construction, as stored in the summary JSON (and quoted by the docs).
CONSTRUCTION = (
    "situation i of evaluation seed s = random generator ask_rng(s, i); reference stack, no "
    "fault, embedded backend; run seed A = run_seed(s, i) (as sitcov run --generator random "
    "--seed s), run seed B = SeedSequence([2, s, i]) (a separate stream); pairs: pem-camera = "
    "camera@A vs pem@B, camera-camera = camera@A vs camera@B, pem-pem = pem@A vs pem@B, "
    "pem-camera-shared-seed = camera@A vs pem@A; split pairs (named explicitly): stream AB = "
    "the world of run seed A with the perception draws of run seed B, "
    "camera-camera-shared-world = camera@A vs camera@AB, pem-pem-shared-world = pem@A vs "
    "pem@AB; verdict = failed under the summary's judge (paper: the backend's own status); "
    "runs that error or time out are left out of their pairs; "
    "intervals are Wilson 95 %"
)


def command_line(
    *,
    seeds: Sequence[int],
    situations: int,
    out: str,
    pairs: str,
    workers: int,
    pem: str | None,
    allow: bool,
    camera_rows: str | Sequence[str] | None = None,
    kind: str | None = None,
    pem_classes: str | None = None,
    stacks: Sequence[str] = (DEFAULT_STACK,),
    pem_draws: int = 1,
    judge: str = DEFAULT_JUDGE,
) -> str:
    """The ``sitcov experiment agreement`` command that reproduces a summary."""
    import shlex

    parts = ["sitcov experiment agreement", "--seeds", ",".join(map(str, seeds)),
             "--situations", str(situations), "--workers", str(workers), "--out", out]  # fmt: skip
    if pairs != "all":
        parts += ["--pairs", pairs]
    if pem is not None:
        parts += ["--pem", pem]
    if allow:
        parts.append("--allow-calibration-seeds")
    for path in [camera_rows] if isinstance(camera_rows, str) else camera_rows or ():
        parts += ["--camera-rows", path]
    if kind is not None:
        parts += ["--kind", kind]
    if pem_classes is not None:
        parts += ["--pem-classes", pem_classes]
    if list(stacks) != [DEFAULT_STACK]:
        for name in stacks:
            parts += ["--stack", name]
    if pem_draws != 1:
        parts += ["--pem-draws", str(pem_draws)]
    if judge != DEFAULT_JUDGE:
        parts += ["--judge", judge]
    return " ".join(p if i == 0 else shlex.quote(p) for i, p in enumerate(parts))


def _pct(value: float | None, ci: Sequence[float] | None) -> str:
    if value is None or ci is None:
        return "-"
    return f"{100 * value:5.1f}% [{100 * ci[0]:4.1f}, {100 * ci[1]:4.1f}]"


def _line(label: str, row: Mapping[str, Any]) -> str:
    sides = f"{row['side_a']} vs {row['side_b']}"
    return (
        f"{label:<28} {sides:<22} {row['n']:>4}  "
        f"{_pct(row['agreement'], row['agreement_ci95']):<22} "
        f"{_pct(row['failure_rate_a'], row['failure_rate_a_ci95']):<22} "
        f"{_pct(row['failure_rate_b'], row['failure_rate_b_ci95']):<22} "
        f"{row['a_fails_b_passes']:>3} / {row['b_fails_a_passes']:<3}"
        + (f"  ({row['not_judged']} not judged)" if row["not_judged"] else "")
    )


def table_lines(summary: Mapping[str, Any]) -> list[str]:
    """The printed table: each pair pooled over the seeds, then per seed; then run costs;
    with several stacks (or another than the reference), one such block per stack with
    its left/right failure rates."""
    stacks = summary.get("stacks") or {}
    if not stacks or list(stacks) == [DEFAULT_STACK]:
        return _block_lines(summary)
    lines: list[str] = []
    for name, result in stacks.items():
        lines.append(f"== stack {name}")
        lines += _block_lines({**summary, **result})
        for side, row in result.get("sides", {}).items():
            left, right = row["left"], row["right"]
            lines.append(
                f"  {side:<9} from the left {_pct(left['failure_rate'], left['ci95'])} "
                f"(n={left['n']}), from the right {_pct(right['failure_rate'], right['ci95'])} "
                f"(n={right['n']}); one-sided Fisher p: right fails more "
                f"{_p(row['p_right_fails_more'])}, left fails more {_p(row['p_left_fails_more'])}"
            )
        if result.get("side_verdict"):
            lines.append(f"  sides, p < {SIDE_ALPHA:g}: {result['side_verdict']}")
    return lines


def _p(value: float | None) -> str:
    return "-" if value is None else f"{value:.2g}"


def _block_lines(summary: Mapping[str, Any]) -> list[str]:
    """:func:`table_lines` of one stack."""
    head = (
        f"{'pair':<28} {'sides (A vs B)':<22} {'n':>4}  {'agreement [Wilson 95%]':<22} "
        f"{'failure rate A':<22} {'failure rate B':<22} A only / B only"
    )
    lines = [
        f"seeds {','.join(map(str, summary['seeds']))}, {summary['situations_per_seed']} "
        f"situations each; PEM {summary['pem_file']} (calibration seeds "
        f"{summary['calibration_seeds']}); run seed A = run_seed(s, i), B = second stream; "
        f"judge {summary.get('judge', DEFAULT_JUDGE)}",
        head,
    ]
    for pair, result in summary["pairs"].items():
        lines.append(_line(pair, result["pooled"]))
        if len(result["per_seed"]) > 1:
            for seed, row in result["per_seed"].items():
                lines.append(_line(f"  seed {seed}", row))
    for pair in ("pem-camera", "camera-camera"):
        diffs = summary["pairs"].get(pair, {}).get("bin_differences")
        if diffs:
            text = ", ".join(f"{el} {d['max_difference']:.2f}" for el, d in diffs.items())
            low = min(d["min_n"] for d in diffs.values())
            lines.append(
                f"{pair}: largest per-bin failure-rate difference (smallest bin {low} runs): {text}"
            )
    for perception, split in summary.get("ceiling_split", {}).items():
        lines.append(
            f"{perception}: of {split['flips']} flips across run seeds (n={split['n']}), "
            f"{split['world']} keep A's verdict with B's perception (the world's draws decide "
            f"them), {split['perception']} take B's; {split['shared_world_flips']} flips with "
            "the world shared"
        )
    for perception, cost in summary["cost"].items():
        lines.append(
            f"{perception} run: {cost['cpu_s_per_run']:.3f} CPU-s, {cost['wall_s_per_run']:.3f} s "
            f"wall (mean of {cost['runs']})"
        )
    return lines
