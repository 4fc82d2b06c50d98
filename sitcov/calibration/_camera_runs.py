"""Camera-mode runs recorded frame by frame: the ground truth the PEM is calibrated against.

``camera_runs`` drives the reference stack through random situations in camera mode (the
renderer and the SSD detector, exactly as ``sitcov run --perception camera`` does, with
the same frame gating) and records, for every frame the detector saw, the PEM's features
of the OV, the top score among the detections overlapping its box (:func:`match`) and
that detection's box error; and, per run, the verdict. Run ``i`` of seed ``s`` is
situation ``ask_rng(s, i)`` of the random generator simulated with seed
``run_seed(s, i)``: the convention of ``sitcov run --generator random --seed s``, so a
PEM can be run on exactly the same situations and seeds and its verdicts compared
(:func:`sitcov.calibration._calibrate.choose_tau`).
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sitcov.perception._camera import project_box
from sitcov.perception._nms import iou
from sitcov.perception._pem import PEMFeatures, PEMSensor

#: A detection matches the OV when its IoU with the projected box reaches this.
MATCH_IOU = 0.3
#: ``RunFrame.score_best_iou`` of frames recorded before it was stored.
NOT_STORED = -1.0
#: Reporting threshold of the detector while recording (low: the scores below the
#: stack's own floor are seen too; the AEB's decisions are unchanged by it).
RECORD_MIN_SCORE = 0.05


@dataclass(frozen=True)
class RunFrame:
    """One frame the detector saw in a camera-mode run.

    Attributes:
        features: the PEM's features of the OV.
        score: the top score among the detections whose IoU with the OV's true box is at
            least :data:`MATCH_IOU` (what a stack acting on any detection sees), 0 if none.
            Recordings made before 26 Nov 2026 (evening) hold the best-overlap score here.
        box_error: (dx0, dy0, dx1, dy1) of that detection's box over the true box size, or None.
        width_px: width of the OV's true (clipped) box [px].
        frame: the camera frame's number in the run (simulated time over the frame
            period; -1 in recordings made before it was stored: consecutive frames).
        actor: the actor's position among the run's road users in view (0 for one).
        distance: camera to the actor's centre [m] (-1 when not stored).
        score_best_iou: the score of the detection overlapping the true box best (IoU at
            least :data:`MATCH_IOU`; 0 if none): the older definition of ``score``, kept to
            compare the two (:data:`NOT_STORED` in older recordings).
    """

    features: PEMFeatures
    score: float
    box_error: tuple[float, float, float, float] | None
    width_px: float
    frame: int = -1
    actor: int = 0
    distance: float = -1.0
    score_best_iou: float = NOT_STORED


@dataclass(frozen=True)
class CameraRun:
    """One camera-mode run: which one, its verdict, its frames and what it cost.

    ``cpu_s`` and ``wall_s`` are the process CPU time and wall time of the simulation
    (rendering and detection included) [s].
    """

    index: int
    seed: int
    situation: dict[str, Any]
    failed: bool
    aeb_time: float | None
    frames: tuple[RunFrame, ...]
    cpu_s: float = 0.0
    wall_s: float = 0.0


def stored_features(values: Sequence[float], situation: dict[str, Any] | None) -> PEMFeatures:
    """A run frame's :class:`PEMFeatures` from its stored values: frames recorded before
    ``rain_wind`` (one value fewer) get their run's (``situation``'s precipitation times
    its wind, :func:`sitcov.weather.rain_wind_of`), the value the sensor gives them now."""
    features = PEMFeatures(*values)
    if len(values) < len(PEMFeatures._fields) and situation:
        from sitcov.weather import rain_wind_of

        features = features._replace(rain_wind=rain_wind_of(situation.get("values") or {}))
    return features


def match(truth: Sequence[float], detections: Sequence[Any]) -> tuple[float, Any]:
    """Score and box error of the top-scoring detection overlapping ``truth``.

    Among the detections whose IoU with ``truth`` is at least :data:`MATCH_IOU`, the one
    with the highest score (ties: the better overlap): a stack acts on any detection that
    passes its tests, and the SSD often puts a second, higher-scoring box on a close car,
    so the best-overlapping box's score understates what a stack sees (docs/pem.md).
    ``(0.0, None)`` when no detection overlaps enough.
    """
    overlaps = _overlaps(truth, detections)
    ok = np.flatnonzero(overlaps >= MATCH_IOU)
    if ok.size == 0:
        return 0.0, None
    scores = np.asarray([float(detections[i].score) for i in ok])
    top = int(ok[np.lexsort((overlaps[ok], scores))[-1]])
    t = np.asarray(truth, dtype=np.float64)
    bw, bh = max(t[2] - t[0], 1.0), max(t[3] - t[1], 1.0)
    d = np.asarray(detections[top].box, dtype=np.float64) - t
    return float(detections[top].score), (d[0] / bw, d[1] / bh, d[2] / bw, d[3] / bh)


def best_overlap_score(truth: Sequence[float], detections: Sequence[Any]) -> float:
    """Score of the detection overlapping ``truth`` best, if its IoU reaches
    :data:`MATCH_IOU` (else 0): what :func:`match` returned before it took the top score."""
    overlaps = _overlaps(truth, detections)
    if overlaps.size == 0:
        return 0.0
    best = int(np.argmax(overlaps))
    return float(detections[best].score) if overlaps[best] >= MATCH_IOU else 0.0


def _overlaps(truth: Sequence[float], detections: Sequence[Any]) -> np.ndarray:
    """IoU of ``truth`` with each detection's box (empty for no detections)."""
    if not detections:
        return np.zeros(0)
    boxes = np.asarray([d.box for d in detections], dtype=np.float64)
    return np.asarray(iou(np.asarray(truth, dtype=np.float64), boxes), dtype=np.float64)


def _clocked_stack(detector: Any) -> Any:
    """A :class:`~sitcov.av.ReferenceStack` that notes the time of each step in ``.t``
    (the built-in fast path calls ``_step_values`` with it; the decisions are unchanged)."""
    from sitcov.av import ReferenceStack

    class ClockedStack(ReferenceStack):
        t = 0.0

        def _step_values(self, t, *args):  # type: ignore[no-untyped-def]
            self.t = t
            return super()._step_values(t, *args)

    return ClockedStack(detector=detector)


#: Camera frame period of the recorded runs [s] (the embedded backend's 10 Hz).
FRAME_PERIOD = 0.1
#: The frame gate of the recorded runs (``EmbeddedBackend``'s ``frame_gate`` when the
#: stored frame files were recorded; camera campaigns now skip more frames by default).
RECORD_FRAME_GATE = 0.5


class _Recorder:
    """A backend + stack whose detector records what it saw in each frame.

    With ``observe`` the stack is given no detections (its AEB never fires), so a run
    records every frame the detector sees until the run ends: frames not selected by the
    stack's own decisions (held-out checks of the frame model, ``--observe``).
    """

    def __init__(self, model: str | None, observe: bool = False) -> None:
        from sitcov.generation import make_generator
        from sitcov.hyperspace import load_hyperspace
        from sitcov.perception._detector import SSDDetector
        from sitcov.sim.embedded import EmbeddedBackend

        self.detector = SSDDetector(model, min_score=RECORD_MIN_SCORE)
        # the frames recorded since the PEM's calibration: every frame with a box at least
        # half the stack's smallest, across the whole image (the campaign's gate skips more)
        self.backend = EmbeddedBackend(perception="camera", frame_gate=RECORD_FRAME_GATE)
        self.backend.frame_observer = self._observe
        self.observe = bool(observe)
        self.stack = _clocked_stack(self._detect)
        self.stack.centre_window = (0.0, 1.0)
        self.generator = make_generator("random", load_hyperspace())
        self.sensor = PEMSensor()
        self._truth: tuple[Any, ...] = ()
        self.frames: list[RunFrame] = []

    def _observe(self, camera: Any, pose: Any, actors: Any, conditions: Any) -> None:
        self._truth = (camera, pose, actors, conditions)

    def _detect(self, image: np.ndarray) -> tuple[Any, ...]:
        detections = self.detector(image)
        candidates = self._candidates(detections)
        camera, pose, actors, conditions = self._truth
        frame = round(self.stack.t / FRAME_PERIOD)
        for key, actor in enumerate(actors):
            if not self._records(actor):
                continue
            feats = self.sensor.features(pose, actor, conditions)
            proj = project_box(camera, pose, actor)
            if feats is None or proj is None:
                continue
            score, err = match(proj.box, candidates)
            best = best_overlap_score(proj.box, candidates)
            dist = round(float(proj.distance), 4)
            self.frames.append(RunFrame(feats, score, err, proj.width, frame, key, dist, best))
        return () if self.observe else detections

    def _records(self, actor: Any) -> bool:
        """Whether this actor's frames are recorded (every actor here)."""
        return True

    def _candidates(self, detections: Any) -> Any:
        """The detections an actor's box is matched against (all of them here)."""
        return detections

    def run(self, seed: int, index: int) -> CameraRun:
        from sitcov._seeding import ask_rng, run_seed

        situation = self.generator.ask(ask_rng(seed, index))
        sim_seed = run_seed(seed, index)
        self.frames = []
        cpu, wall = time.process_time(), time.perf_counter()
        outcome = self.backend.run(situation, self.stack, sim_seed)
        cpu, wall = time.process_time() - cpu, time.perf_counter() - wall
        return CameraRun(index, sim_seed, situation.to_dict(), outcome.failed,
                         outcome.aeb_time, tuple(self.frames), cpu, wall)  # fmt: skip


_WORKER: dict[tuple[str | None, bool], _Recorder] = {}


def _run_in_worker(job: tuple[str | None, int, int, bool]) -> CameraRun:
    model, seed, index, observe = job
    if (model, observe) not in _WORKER:
        _WORKER[model, observe] = _Recorder(model, observe)
    return _WORKER[model, observe].run(seed, index)


def iter_camera_runs(
    runs: int,
    *,
    seed: int = 0,
    model: str | os.PathLike[str] | None = None,
    workers: int = 1,
    observe: bool = False,
) -> Iterator[CameraRun]:
    """Runs ``0..runs-1`` of seed ``seed`` in camera mode, recorded, as each one finishes.

    ``workers > 1`` spreads the runs over that many processes (then they arrive out of
    index order); every run is the same as with one worker. ``observe``: the stack gets
    no detections (every frame to the run's end is recorded; see :class:`_Recorder`).
    """
    model_arg = None if model is None else str(model)
    if workers <= 1:
        recorder = _Recorder(model_arg, observe)
        for i in range(runs):
            yield recorder.run(seed, i)
        return
    import multiprocessing as mp

    jobs = [(model_arg, seed, i, observe) for i in range(runs)]
    with mp.get_context("spawn").Pool(workers) as pool:
        yield from pool.imap_unordered(_run_in_worker, jobs)


def camera_runs(
    runs: int,
    *,
    seed: int = 0,
    model: str | os.PathLike[str] | None = None,
    workers: int = 1,
    progress: Callable[[int], None] | None = None,
    observe: bool = False,
) -> list[CameraRun]:
    """:func:`iter_camera_runs`, collected in index order; ``progress`` gets the runs done."""
    out: list[CameraRun] = []
    for run in iter_camera_runs(runs, seed=seed, model=model, workers=workers, observe=observe):
        out.append(run)
        if progress is not None:
            progress(len(out))
    return sorted(out, key=lambda r: r.index)
