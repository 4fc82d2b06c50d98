"""Why the PEM and the camera disagree, frame by frame: re-simulates the flips and classifies them.

A *flip* is a situation whose verdict differs between camera mode and PEM mode with the
same run seed (stream A of ``sitcov experiment agreement``: the same world, the OV's
colour included). The flips are read from a stored rows file (``--rows``, default
``docs/data/agreement-ceiling-seed8-100.csv``); each is re-simulated on the embedded
backend in both modes with an instrumented copy of its stack that records, per frame
the stack received and per road user in view: the true box (clipped, px), its centre and
width over the image width, distance, view angle, truncation, the signed ``side``, how
much of it nearer road users' boxes cover, the PEM's noise-free logit and marginal
P(the stack's single-frame test passes) (``pass_probability`` at the stack's threshold
times whether the *true* box passes the centering and distance tests), the score of the
detection matching it (IoU >= 0.3; camera: the SSD with a 0.05 floor, the stack still
gets only its usual >= 0.3 detections; PEM: its own detections) and whether that
detection passes the stack's single-frame test; plus when the AEB first fired.

Each flip is then put in one class (the first that applies):

- ``none``: the two verdicts agree on this code (the stored row was judged by older code).
- ``d-noise``: the PEM's per-run draw. ``--perception-seeds`` PEM runs of the same world
  (``EmbeddedBackend.run(..., perception_seed=)``) reach the camera's verdict in at least
  half of them.
- ``other``: the AEB fired at the same time in both modes, or in neither: the verdicts
  differ after the first firing (a releasing AEB), or not through the AEB.
- ``b-timing``: the PEM's marginal is not what is off, the arrangement of its hits in
  time is. The *window* is the camera run's frames up to its AEB's first firing (all of
  them if it never fired; both modes see the same world until either fires). If the
  camera fired first (the PEM under-reports), the PEM would have fired by then with
  probability >= 0.5 were its per-frame test outcomes independent draws of its
  marginal (``pass_probability`` times the true box passing the geometry tests; for
  the three-frame stack: three in a row); if the PEM fired first (over-reports), it
  would have fired before the camera with probability < 0.5, or (three frames) the
  camera had >= 3 hits there, only not in a row. What decides is then the PEM's noise
  correlation (its AR(1) runs), not its per-frame rates.
- ``a-cell``: the marginal is off in the window (the test above fails), and a PEM whose per-frame
  probability matched the detector's rate in the frame's cell (box height band x
  distance band x side-on or not, from the held-out frames file ``--cells``) would
  reach the camera's verdict: the known per-cell misses.
- ``c-stray``: the marginal is off and the camera fired only on detections that match no
  road user's true box (IoU < 0.3 with every one: a misplaced box or a false positive),
  which the PEM, reporting boxes on road users only, cannot produce.
- ``c-feature``: the marginal is off and the cell rates do not explain it: something
  of this scene the PEM's cells do not carry (colour, rain, lighting, occlusion, the
  detector's box geometry, image position...); the record lists those features.

With ``--observe N`` it also runs situations 0..N-1 once per mode with a stack that
records but never brakes (the same world in both modes to the run's end) and reports,
over every frame of the conflicting road user, the lengths of runs of consecutive
frames with a score >= θ (θ = 0.5, 0.7) and with the reference test passing, in both
modes, and the per-frame rates by approach side and image position (the left/right
asymmetry: in the marginal or in the timing?).

    PYTHONPATH=. python benchmarks/pem_flip_diagnosis.py --seed 8 --observe 100 \\
        --out docs/data/pem-flips-seed8.json

Camera runs cost 1.5-3 CPU-s each (one process: ``--workers`` is not offered, the
machine is shared); the PEM runs about 0.03 s. docs/pem.md, "Why the PEM and the camera
disagree, frame by frame", quotes the output.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import time
from collections import Counter, defaultdict
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sitcov.calibration._camera_runs import MATCH_IOU
from sitcov.perception._base import Detection
from sitcov.perception._camera import project_box
from sitcov.perception._colors import PALETTE, ov_color
from sitcov.perception._nms import iou
from sitcov.perception._pem import PEMSensor, pass_probability, pem_logit
from sitcov.perception._recording import FrameTruth, RecordingDetector, RecordingPEM

#: Stack names of the rows files -> short names used in the output.
STACKS = {
    "reference": "reference",
    "examples.aeb_stacks:Threshold07": "threshold-0.7",
    "examples.aeb_stacks:ThreeFrames": "three-frames",
    "examples.aeb_stacks:RightBlind": "right-blind",
}
#: Detector floor while recording (the stack gets only detections >= its usual floor).
RECORD_FLOOR = 0.05
#: Cells of the per-cell rates: box height [px], distance [m].
HEIGHT_BANDS = (0, 20, 30, 40, 60, 90, 150, 10000)
DISTANCE_BANDS = (0, 10, 20, 40, 1000)
SIDE_ON = 0.8  # view angle [rad] above which a box counts as side-on
FRAME_S = 0.1  # camera frame period of the embedded backend [s]
#: Truncation bands of the observe runs' table [-].
TRUNC_BANDS = ((0.0, 0.01), (0.01, 0.2), (0.2, 0.4), (0.4, 1.01))
#: Box height bands [px] of the per-class score tables.
SCORE_BANDS = (0, 30, 60, 120, 10000)
_COLOR_NAMES = {rgb: name for name, (rgb, _) in PALETTE.items()}


# --- instrumented runs -------------------------------------------------------------------


class FrameLog(FrameTruth):
    """What one run's stack received, frame by frame (filled by the instrumented parts;
    ``truth``, ``views`` and ``raw`` as :class:`FrameTruth`'s)."""

    def __init__(self) -> None:
        super().__init__()
        self.frames: list[dict[str, Any]] = []

    def start(self) -> None:
        self.__init__()


def _single_test(stack: Any) -> Any:
    """The stack's single-frame test on a detection list (no streak state)."""
    from examples.aeb_stacks import RightBlind
    from sitcov.av import ReferenceStack

    if isinstance(stack, RightBlind):
        return lambda dets: RightBlind._perceive(stack, dets, None)
    return lambda dets: ReferenceStack._perceive(stack, dets, None)


def recorded_stack(name: str, log: FrameLog, observe: bool = False) -> Any:
    """An instance of stack ``name`` whose perception is logged into ``log`` (its
    decisions unchanged; ``observe``: it never brakes)."""
    from sitcov.av import make_stack

    base = type(make_stack(name))

    class Recorded(base):  # type: ignore[misc, valid-type]
        _t = 0.0

        def _step_values(self, t, *args):  # type: ignore[no-untyped-def]
            self._t = t
            return super()._step_values(t, *args)

        def _perceive(self, detections, image):  # type: ignore[no-untyped-def]
            if detections is None and image is None:
                return False
            raw = None
            if detections is None:
                detections = self._detect(image)
                raw = log.raw
            truth, log.truth = log.truth, None
            hit = _single_test(self)(detections)
            fire = False if observe else super()._perceive(detections, None)
            if truth is not None:
                log.frames.append(_frame_record(self, self._t, truth, raw or detections, hit, fire))
            return fire

    stack = Recorded()
    return stack


_FEATURES = PEMSensor()


def _frame_record(
    stack: Any, t: float, truth: tuple[Any, ...], dets: Sequence[Detection], hit: bool, fire: bool
) -> dict[str, Any]:
    """One frame: per road user in view its truth, the PEM's marginal and the matched score."""
    pose, views, cond = truth
    test = _single_test(stack)
    width = float(stack.camera.width)
    theta = float(stack._threshold)
    boxes = []
    for view in views:
        proj = project_box(stack.camera, pose, view)
        boxes.append(proj if proj is not None and proj.visible else None)
    out = []
    for a, (view, proj) in enumerate(zip(views, boxes, strict=True)):
        if proj is None:
            continue
        feats = _FEATURES.features(pose, view, cond)
        if feats is None:
            continue
        params, label = _FEATURES._class_params(view.kind)
        box = proj.box
        geo = bool(test((Detection(box, 1.0, label),)))
        pt = pass_probability(feats, params, theta, width)
        p = pt * geo
        score, score_iou, dbox, dhit = 0.0, 0.0, None, False
        if dets:  # the top-scoring detection overlapping the true box (IoU >= MATCH_IOU)
            cand = np.asarray([d.box for d in dets], dtype=np.float64)
            ov = iou(np.asarray(box, dtype=np.float64), cand)
            ok = np.flatnonzero(ov >= MATCH_IOU)
            if len(ok):  # and the best-overlapping one's (what the frames files record)
                score_iou = float(dets[int(np.argmax(ov))].score)
                best = int(ok[np.argmax([dets[k].score for k in ok])])
                score, dbox = float(dets[best].score), dets[best].box
                dhit = any(test((dets[k],)) for k in ok)
        out.append({
            "a": a,
            "kind": view.kind,
            "dist": round(float(proj.distance), 2),
            "box": [round(float(v), 1) for v in box],
            "cx": round(0.5 * (box[0] + box[2]) / width, 3),
            "wf": round((box[2] - box[0]) / width, 3),
            "h": round(float(feats.height_px), 1),
            "view": round(float(feats.view_angle), 3),
            "trunc": round(float(feats.truncation), 3),
            "side": round(float(feats.side), 3),
            "occl": round(_covered(proj, a, boxes), 3),
            "z": round(pem_logit(feats, params), 3),
            "p": round(p, 4),
            "pt": round(pt, 4),
            "p05": round(pass_probability(feats, params, 0.5, width), 4),
            "p07": round(pass_probability(feats, params, 0.7, width), 4),
            "geo": geo,
            "score": round(score, 4),
            "score_iou": round(score_iou, 4),
            "dbox": None if dbox is None else [round(float(v), 1) for v in dbox],
            "dhit": dhit,
        })  # fmt: skip
    # every detection passing the single-frame test: score and best IoU with a true box
    # (< MATCH_IOU: a box on no road user, a misplaced box or a false positive)
    passing = []
    truths = [np.asarray(b.box, dtype=np.float64) for b in boxes if b is not None]
    for d in dets:
        if test((d,)):
            best = max((float(iou(tb, np.asarray([d.box]))[0]) for tb in truths), default=0.0)
            passing.append([round(float(d.score), 3), round(best, 3)])
    return {"t": round(t, 3), "hit": bool(hit), "fire": bool(fire), "actors": out,
            "passing": passing}  # fmt: skip


def _covered(proj: Any, a: int, boxes: Sequence[Any]) -> float:
    """Fraction of road user ``a``'s clipped box covered by the boxes of nearer ones
    (union approximated by the largest single overlap)."""
    x0, y0, x1, y1 = proj.box
    area = max((x1 - x0) * (y1 - y0), 1e-9)
    best = 0.0
    for b, other in enumerate(boxes):
        if b == a or other is None or other.distance >= proj.distance:
            continue
        u0, v0, u1, v1 = other.box
        w, h = min(x1, u1) - max(x0, u0), min(y1, v1) - max(y0, v0)
        if w > 0 and h > 0:
            best = max(best, w * h / area)
    return best


class Simulator:
    """Builds the backends once; runs one (situation, stack, mode) instrumented."""

    def __init__(self, seed: int) -> None:
        from sitcov.generation import make_generator
        from sitcov.hyperspace import load_hyperspace
        from sitcov.sim.embedded import EmbeddedBackend

        self.seed = seed
        self.generator = make_generator("random", load_hyperspace())
        self.log = FrameLog()
        self.detector: RecordingDetector | None = None  # made at the first camera run
        self.pem = RecordingPEM(log_of=lambda: self.log)
        self.camera_backend = EmbeddedBackend(perception="camera")
        self.pem_backend = EmbeddedBackend(perception="pem", sensor=self.pem)
        self.plain_backend = EmbeddedBackend(perception="pem")
        self.camera_backend.frame_observer = self._observe
        self._stacks: dict[tuple[str, bool], Any] = {}

    def _observe(self, camera: Any, pose: Any, actors: Any, conditions: Any) -> None:
        self.log.truth = (pose, actors, conditions)

    def situation(self, index: int) -> Any:
        from sitcov._seeding import ask_rng

        return self.generator.ask(ask_rng(self.seed, index))

    def run(
        self, index: int, stack: str, mode: str, observe: bool = False
    ) -> tuple[Any, list[dict[str, Any]], float]:
        """(outcome, frames, CPU s) of situation ``index`` at run seed A."""
        from sitcov._seeding import run_seed

        key = (stack, observe)
        if key not in self._stacks:
            self._stacks[key] = recorded_stack(stack, self.log, observe)
        st = self._stacks[key]
        if mode == "camera" and self.detector is None:
            self.detector = RecordingDetector(lambda: self.log, floor=RECORD_FLOOR)
        st.detector = self.detector
        self.log.start()
        backend = self.camera_backend if mode == "camera" else self.pem_backend
        cpu = time.process_time()
        outcome = backend.run(self.situation(index), st, run_seed(self.seed, index))
        return outcome, list(self.log.frames), time.process_time() - cpu

    def pem_verdicts(
        self, index: int, stack: str, seeds: Sequence[int], backend: Any = None
    ) -> list[bool]:
        """PEM verdicts of situation ``index``'s world A under other perception seeds (on
        ``backend``, default the shipped PEM's)."""
        from sitcov._seeding import run_seed
        from sitcov.av import make_stack

        st = make_stack(stack)
        sit, seed = self.situation(index), run_seed(self.seed, index)
        backend = backend or self.plain_backend
        return [bool(backend.run(sit, st, seed, perception_seed=int(s)).failed) for s in seeds]


# --- the per-cell rates ------------------------------------------------------------------


def _band(value: float, edges: Sequence[float]) -> int:
    return int(np.clip(np.searchsorted(edges, value, side="right") - 1, 0, len(edges) - 2))


def cell_key(h: float, dist: float, view: float) -> tuple[int, int, int]:
    return _band(h, HEIGHT_BANDS), _band(dist, DISTANCE_BANDS), int(view > SIDE_ON)


def cell_rates(path: str, thresholds: Sequence[float]) -> dict[float, dict[tuple, tuple]]:
    """Per θ and cell: (detector's share of frames >= θ, the PEM's mean P(>= θ), frames)
    over the car frames of a frames file (runs and sweep)."""
    from sitcov.calibration import _frame_model as fm
    from sitcov.calibration._frames import read_frames

    t = fm.tracks_of(read_frames(path)["car"])
    params = _FEATURES.params
    out: dict[float, dict[tuple, tuple]] = {}
    keys = [
        cell_key(f.height_px, d, f.view_angle) for f, d in zip(t.feats, t.distance, strict=True)
    ]
    for th in thresholds:
        acc: dict[tuple, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
        for f, s, k in zip(t.feats, t.score, keys, strict=True):
            a = acc[k]
            a[0] += float(s >= th)
            a[1] += pass_probability(f, params, th)
            a[2] += 1
        out[th] = {k: (a[0] / a[2], a[1] / a[2], a[2]) for k, a in acc.items()}
    return out


def cell_rates_of_runs(
    runs: list[dict[str, Any]], thresholds: Sequence[float]
) -> dict[float, dict[tuple, tuple]]:
    """:func:`cell_rates` from the observe runs' camera frames of every road user, with
    the top score among the detections overlapping the true box (what the AEB acts on;
    the frames files hold the best-overlapping detection's score)."""
    out: dict[float, dict[tuple, tuple]] = {}
    for th in thresholds:
        key_p = "p05" if th == 0.5 else "p07"
        acc: dict[tuple, list[float]] = defaultdict(lambda: [0.0, 0.0, 0])
        for r in runs:
            for f in r["camera"]:
                for a in f["actors"]:
                    row = acc[cell_key(a["h"], a["dist"], a["view"])]
                    row[0] += float(a["score"] >= th)
                    row[1] += a[key_p]
                    row[2] += 1
        out[th] = {k: (a[0] / a[2], a[1] / a[2], a[2]) for k, a in acc.items()}
    return out


# --- classification ----------------------------------------------------------------------


def p_fire(probs: Sequence[float], need: int) -> float:
    """P(at least ``need`` consecutive successes) in independent trials ``probs``."""
    if need <= 1:
        return 1.0 - float(np.prod([1.0 - p for p in probs])) if probs else 0.0
    state = np.zeros(need + 1)  # state[k]: current run k (< need); state[need]: done
    state[0] = 1.0
    for p in probs:
        new = np.zeros_like(state)
        new[need] = state[need]
        for k in range(need):
            new[min(k + 1, need)] += state[k] * p
            new[0] += state[k] * (1.0 - p)
        state = new
    return float(state[need])


def runs_of(flags: Sequence[bool]) -> list[int]:
    """Lengths of the runs of consecutive True."""
    out, n = [], 0
    for f in flags:
        if f:
            n += 1
        elif n:
            out.append(n)
            n = 0
    if n:
        out.append(n)
    return out


def frame_prob(frame: dict[str, Any], key: str = "p") -> float:
    return 1.0 - float(np.prod([1.0 - a[key] for a in frame["actors"]]))


def cam_theta(flip: dict[str, Any]) -> float:
    return float(flip["threshold"])


def band_table(frames: list[dict], theta: float) -> dict[str, list[float]]:
    """Per box-height band x side-on: [frames, sum of the detector's score (0 = none),
    sum of the PEM's median score (sigmoid of its noise-free logit), frames the detector
    scores >= θ, sum of the PEM's P(score >= θ)] over the frames given (each road user
    in view in the frames given)."""
    out: dict[str, list[float]] = {}
    for f in frames:
        for a in f["actors"]:
            band = _band(a["h"], SCORE_BANDS)
            view = "side" if a["view"] > SIDE_ON else "end"
            key = f"{SCORE_BANDS[band]}-{SCORE_BANDS[band + 1]} px {view}"
            row = out.setdefault(key, [0, 0.0, 0.0, 0, 0.0])
            row[0] += 1
            row[1] += a["score"]
            row[2] += 1.0 / (1.0 + math.exp(-a["z"]))
            row[3] += int(a["score"] >= theta)
            row[4] += a["pt"]
    return {k: [round(v, 4) for v in row] for k, row in out.items()}


def classify(
    flip: dict[str, Any], cam: list[dict], pem: list[dict], need: int,
    cells: dict[tuple, tuple],
) -> dict[str, Any]:  # fmt: skip
    """The flip's class and the numbers behind it (see the module docstring).

    The window is the camera run's frames up to its AEB's first firing (all of them if it
    never fired); the world is the same in both modes until either fires. If the PEM fired
    first, the question is whether its marginal makes it fire *before* the camera (the
    frames strictly before the camera's firing); if the camera fired first, whether it
    makes it fire *by then* (the window with the firing frame)."""
    tc, tp = flip["aeb_camera"], flip["aeb_pem"]
    out: dict[str, Any] = {}
    if flip["pem_agree_share"] >= 0.5:
        out["class"] = "d-noise"
    end = tc if tc is not None else math.inf
    pem_first = tp is not None and (tc is None or tp < tc - 1e-6)
    window = [f for f in cam if f["t"] <= end + 1e-6]
    if pem_first and tc is not None:
        window = [f for f in window if f["t"] < tc - 1e-6]
    pem_end = tp if pem_first else end
    pem_window = [f for f in pem if f["t"] <= pem_end + 1e-6]
    cam_hits = [f["hit"] for f in window]
    probs = [frame_prob(f) for f in window]
    # the PEM's marginal with each frame's cell bias removed (detector rate - PEM mean)
    fixed = []
    for f in window:
        q = []
        for a in f["actors"]:
            r, m, _ = cells.get(cell_key(a["h"], a["dist"], a["view"]), (None, None, 0))
            adj = a["p"] if r is None or not a["geo"] else min(max(a["p"] + r - m, 0.0), 1.0)
            q.append(adj)
        fixed.append(1.0 - float(np.prod([1.0 - v for v in q])))
    cam_scores = [max((a["score"] for a in f["actors"]), default=0.0) for f in window]
    out.update({
        "window_frames": len(window),
        "window_end": window[-1]["t"] if window else None,
        "pem_fired_first": pem_first,
        "both_fired_within_s": (round(abs(tc - tp), 2)
                                if tc is not None and tp is not None else None),
        "camera_hits": int(sum(cam_hits)),
        "camera_max_run": max(runs_of(cam_hits), default=0),
        "pem_hits": int(sum(f["hit"] for f in pem_window)),
        "pem_max_run": max(runs_of([f["hit"] for f in pem_window]), default=0),
        "pem_expected_hits": round(float(sum(probs)), 3),
        "pem_fire_indep": round(p_fire(probs, need), 3),
        "pem_fire_cellfixed": round(p_fire(fixed, need), 3),
        "camera_max_score": round(max(cam_scores, default=0.0), 3),
    })  # fmt: skip
    out["bands"] = band_table(window, cam_theta(flip))
    # the detector's box passes the centering/distance tests where the true box does not
    out["camera_box_only_hits"] = int(sum(
        1 for f in window for a in f["actors"] if a["dhit"] and not a["geo"]
    ))  # fmt: skip
    # the camera's firing frame(s): did only detections on no road user pass?
    if tc is not None and not pem_first:
        last = [f for f in window if f["hit"]][-need:]
        out["camera_fire_stray"] = bool(last) and all(
            all(q[1] < MATCH_IOU for q in f.get("passing", [])) for f in last
        )
    # the frame where the first-firing mode fired: the largest road user's truth there
    fire_frames = pem if pem_first else cam
    t_fire = tp if pem_first else tc
    hit = [f for f in fire_frames if t_fire is not None and abs(f["t"] - t_fire) < 1e-6]
    if hit and hit[0]["actors"]:
        a = max(hit[0]["actors"], key=lambda a: a["wf"])
        keys = ("h", "dist", "view", "trunc", "cx", "side", "score", "score_iou", "pt")
        out["fire_frame"] = {"mode": "pem" if pem_first else "camera",
                             **{k: a[k] for k in keys}}  # fmt: skip
    if flip["camera_failed"] == flip["pem_failed"]:
        out["class"] = "none"  # not a flip on this code (the stored row is older)
        return out
    if "class" in out:
        return out
    if (tc is None and tp is None) or (tc is not None and tp is not None and abs(tc - tp) < 1e-6):
        out["class"] = "other"
        return out
    if pem_first:  # over-report: does its marginal make it fire before the camera?
        marginal_ok = out["pem_fire_indep"] < 0.5
        if need > 1 and out["camera_hits"] >= need and out["camera_max_run"] < need:
            marginal_ok = True  # the camera had the hits, only not in a row
        cell_ok = out["pem_fire_cellfixed"] < 0.5
    else:  # under-report: does its marginal make it fire by the camera's firing?
        marginal_ok = out["pem_fire_indep"] >= 0.5
        cell_ok = out["pem_fire_cellfixed"] >= 0.5
    out["class"] = "b-timing" if marginal_ok else ("a-cell" if cell_ok else "c-feature")
    if out["class"] != "b-timing" and out.get("camera_fire_stray"):
        out["class"] = "c-stray"  # the camera fired on a box matching no road user
    return out


# --- the observe runs --------------------------------------------------------------------


def _conflict_car_frames(
    runs: list[dict[str, Any]],
) -> Iterator[tuple[dict[str, Any], dict[str, Any]]]:
    """(run, actor record) for every camera frame of each run's conflicting road user,
    when it is a car."""
    for r in runs:
        frames = r["camera"]
        a = conflict_actor(frames)
        for f in frames:
            for x in f["actors"]:
                if x["a"] == a and x["kind"] == "car":
                    yield r, x


def conflict_actor(frames: list[dict]) -> int | None:
    """The road user seen largest in the run (the conflicting one)."""
    best: dict[int, float] = defaultdict(float)
    for f in frames:
        for a in f["actors"]:
            best[a["a"]] = max(best[a["a"]], a["wf"])
    return max(best, key=best.get) if best else None


def observe_stats(runs: list[dict[str, Any]], thresholds: Sequence[float]) -> dict[str, Any]:
    """Run lengths of frames >= θ and of reference-test hits, per mode; per-frame rates by
    approach side and image-position band."""
    stats: dict[str, Any] = {}
    for mode, field in (("camera", "score"), ("pem", "score"), ("camera_iou_match", "score_iou")):
        per: dict[str, Any] = {}
        for th in thresholds:
            lengths: list[int] = []
            onsets: dict[str, list[float]] = defaultdict(list)
            for r in runs:
                fr = r[mode.split("_")[0]]
                a = conflict_actor(fr)
                flags, last_t = [], None
                for f in fr:  # a frame not rendered (camera's gate) ends a run
                    if last_t is not None and f["t"] - last_t > FRAME_S + 1e-6:
                        flags.append(False)
                    last_t = f["t"]
                    x = next((x for x in f["actors"] if x["a"] == a), None)
                    flags.append(x is not None and x[field] >= th)
                lengths += runs_of(flags)
                first = next(
                    (f["t"] for f in fr for x in f["actors"] if x["a"] == a and x[field] >= th),
                    None,
                )
                if first is not None:
                    onsets[r["side"]].append(first)
            per[str(th)] = {
                "situations_with_any": sum(len(v) for v in onsets.values()),
                "runs": len(lengths),
                "frames": int(sum(lengths)),
                "mean_length": round(float(np.mean(lengths)), 2) if lengths else None,
                "length_hist": {
                    str(k): v for k, v in sorted(Counter(min(n, 10) for n in lengths).items())
                },  # fmt: skip
                "share_in_runs_ge3": round(
                    sum(n for n in lengths if n >= 3) / max(sum(lengths), 1), 3
                ),
                "onset_median_s": {s: round(float(np.median(v)), 2) for s, v in onsets.items()},
            }
        stats[mode] = per
    # the first frame whose detection passes the reference test, per mode, paired by run
    onset: dict[str, list[float]] = defaultdict(list)
    only: Counter[str] = Counter()
    for r in runs:
        t = {}
        for mode in ("camera", "pem"):
            a = conflict_actor(r[mode])
            t[mode] = next((f["t"] for f in r[mode] for x in f["actors"]
                            if x["a"] == a and x["dhit"]), None)  # fmt: skip
        if t["camera"] is not None and t["pem"] is not None:
            onset[r["side"]].append(t["pem"] - t["camera"])
        elif t["camera"] is not None or t["pem"] is not None:
            only[f"{r['side']} only {'camera' if t['pem'] is None else 'pem'}"] += 1
    stats["hit_onset_pem_minus_camera_s"] = {
        s: {"runs": len(v), "median": round(float(np.median(v)), 2),
            "mean": round(float(np.mean(v)), 2),
            "pem_earlier": int(sum(d < -1e-6 for d in v)),
            "pem_later": int(sum(d > 1e-6 for d in v))}
        for s, v in sorted(onset.items())
    }  # fmt: skip
    stats["hit_in_one_mode_only"] = dict(only)
    # the PEM run's own frames: its realized share >= 0.5 (to set against its marginal)
    realized: dict[str, list[float]] = defaultdict(lambda: [0, 0.0, 0.0])
    for r in runs:
        a = conflict_actor(r["pem"])
        for f in r["pem"]:
            for x in f["actors"]:
                if x["a"] == a and x["kind"] == "car":
                    row = realized[f"{r['side']} {_dband(x['dist'])}"]
                    row[0] += 1
                    row[1] += float(x["score"] >= 0.5)
                    row[2] += x["p05"]
    stats["pem_run_frames"] = {
        k: {"frames": int(v[0]), "pem_ge05": round(v[1] / v[0], 3),
            "pem_p_ge05": round(v[2] / v[0], 3)}
        for k, v in sorted(realized.items()) if v[0] >= 10
    }  # fmt: skip
    # per-frame, the conflicting car: detector >= 0.5 vs the PEM's P(>= 0.5) (camera frames)
    table: dict[str, list[float]] = defaultdict(lambda: [0, 0.0, 0.0, 0, 0.0, 0.0])
    for r, x in _conflict_car_frames(runs):
        band = f"{r['side']} cx {min(int(x['cx'] * 5), 4) / 5:.1f}"
        dband = f"{r['side']} {_dband(x['dist'])}"
        for k in (band, dband):
            row = table[k]
            row[0] += 1
            row[1] += float(x["score"] >= 0.5)
            row[2] += x["p05"]
            row[3] += int(x["score"] > 0)
            row[4] += x["score"]
            row[5] += float(x["score_iou"] >= 0.5)
    # every camera frame of the conflicting car by box height, view and distance band:
    # the detector's mean score and shares >= 0.5 / 0.7 against the PEM's median score
    # and P(score >= 0.5 / 0.7)
    cells: dict[str, list[float]] = defaultdict(lambda: [0] + [0.0] * 7)
    for _, x in _conflict_car_frames(runs):
        band = _band(x["h"], SCORE_BANDS)
        view = "side" if x["view"] > SIDE_ON else "end"
        key = f"{SCORE_BANDS[band]}-{SCORE_BANDS[band + 1]} px {view} {_dband(x['dist'])}"
        row = cells[key]
        row[0] += 1
        row[1] += x["score"]
        row[2] += 1.0 / (1.0 + math.exp(-x["z"]))
        row[3] += float(x["score"] >= 0.5)
        row[4] += x["p05"]
        row[5] += float(x["score"] >= 0.7)
        row[6] += x["p07"]
        row[7] += float(x["score_iou"] >= 0.5)
    stats["cells"] = {
        k: {"frames": int(v[0]), "detector_mean": round(v[1] / v[0], 3),
            "pem_median": round(v[2] / v[0], 3), "detector_ge05": round(v[3] / v[0], 3),
            "pem_p_ge05": round(v[4] / v[0], 3), "detector_ge07": round(v[5] / v[0], 3),
            "pem_p_ge07": round(v[6] / v[0], 3),
            "detector_iou_match_ge05": round(v[7] / v[0], 3)}
        for k, v in sorted(cells.items(), key=lambda kv: _band_order(kv[0])) if v[0] >= 20
    }  # fmt: skip
    # the same by truncation (fraction of the true box outside the image), distance band
    # and approach side: the edge of the image, where a road user from the left is
    trunc: dict[str, list[float]] = defaultdict(lambda: [0, 0.0, 0.0, 0.0])
    for r in runs:
        fr = r["camera"]
        a = conflict_actor(fr)
        for f in fr:
            for x in f["actors"]:
                if x["a"] != a or x["kind"] != "car" or x["dist"] >= 20:
                    continue
                tb = next(f"{lo:.1f}-{hi:.1f}" for lo, hi in TRUNC_BANDS if x["trunc"] < hi)
                for key in (f"trunc {tb} {_dband(x['dist'])}",
                            f"trunc {tb} {_dband(x['dist'])} {r['side']}"):  # fmt: skip
                    row = trunc[key]
                    row[0] += 1
                    row[1] += float(x["score"] >= 0.5)
                    row[2] += x["p05"]
                    row[3] += float(x["score_iou"] >= 0.5)
    stats["truncation"] = {
        k: {"frames": int(v[0]), "detector_ge05": round(v[1] / v[0], 3),
            "pem_p_ge05": round(v[2] / v[0], 3),
            "detector_iou_match_ge05": round(v[3] / v[0], 3)}
        for k, v in sorted(trunc.items()) if v[0] >= 15
    }  # fmt: skip
    stats["side_frames"] = {
        k: {"frames": int(v[0]), "detector_ge05": round(v[1] / v[0], 3),
            "pem_p_ge05": round(v[2] / v[0], 3), "mean_score": round(v[4] / v[0], 3),
            "detector_iou_match_ge05": round(v[5] / v[0], 3)}
        for k, v in sorted(table.items()) if v[0] >= 10
    }  # fmt: skip
    return stats


def _dband(d: float) -> str:
    return "0-10 m" if d < 10 else "10-20 m" if d < 20 else "20+ m"


# --- main --------------------------------------------------------------------------------


def read_flips(path: str, seed: int) -> dict[str, list[tuple[int, bool, bool, bool | None]]]:
    """Per stack, (index, camera@A failed, PEM@A failed, camera@AB failed) of the flips."""
    with open(path, encoding="utf-8") as fh:
        rows = list(csv.DictReader(fh))
    by = {(r["stack"], r["perception"], r["stream"], int(r["index"])): r for r in rows
          if int(r["seed"]) == seed}  # fmt: skip
    out: dict[str, list] = defaultdict(list)
    for (stack, perc, stream, i), r in sorted(by.items()):
        if (perc, stream) != ("camera", "A") or ("pem", "A") not in {
            (k[1], k[2]) for k in by if k[0] == stack and k[3] == i
        }:
            continue
        cam, pem = r["failed"] == "True", by[stack, "pem", "A", i]["failed"] == "True"
        ab = by.get((stack, "camera", "AB", i))
        if cam != pem:
            out[stack].append((i, cam, pem, None if ab is None else ab["failed"] == "True"))
    return out


def modal_agreement(
    sim: Simulator, rows: str, seed: int, stacks: Sequence[str], n: int,
    rng: np.random.Generator,
) -> dict[str, Any]:  # fmt: skip
    """Per stack, over the situations of ``rows`` with a camera@A verdict: the stored
    PEM@A's agreement with it, the mean agreement of ``n`` PEM runs of world A with
    other perception seeds (the PEM's expected agreement), and the agreement of their
    majority verdict (a PEM without per-run noise in its verdicts; ties count half)."""
    with open(rows, encoding="utf-8") as fh:
        by = {(r["stack"], r["perception"], r["stream"], int(r["index"])): r
              for r in csv.DictReader(fh) if int(r["seed"]) == seed}  # fmt: skip
    out: dict[str, Any] = {}
    for stack in stacks:
        idx = sorted(k[3] for k in by if k[:3] == (stack, "camera", "A"))
        stored, expected, major, split = 0, 0.0, 0.0, []
        for i in idx:
            cam = by[stack, "camera", "A", i]["failed"] == "True"
            pem = by.get((stack, "pem", "A", i))
            stored += pem is not None and (pem["failed"] == "True") == cam
            seeds = rng.integers(0, 2**32, size=n)
            share = float(np.mean([v == cam for v in sim.pem_verdicts(i, stack, seeds)]))
            expected += share
            major += 1.0 if share > 0.5 else (0.5 if share == 0.5 else 0.0)
            split.append(share)
        m = max(len(idx), 1)
        out[STACKS.get(stack, stack)] = {
            "situations": len(idx),
            "stored_pem_a_agreement": round(stored / m, 3),
            "expected_agreement": round(expected / m, 3),
            "majority_agreement": round(major / m, 3),
            "systematic_flips": int(sum(s < 0.5 for s in split)),
            "coin_situations": int(sum(0.2 <= s <= 0.8 for s in split)),
        }
    return out


def parse_whatif(text: str) -> tuple[str, dict[str, float]]:
    """``NAME:key=value,key=value`` -> (name, PEM parameter overrides)."""
    name, _, body = text.partition(":")
    try:
        over = {k.strip(): float(v) for k, v in (kv.split("=") for kv in body.split(","))}
    except ValueError:
        raise SystemExit(f"--whatif: {text!r}: expected NAME:key=value[,key=value]") from None
    return name, over


def whatif_agreement(
    sim: Simulator, rows: str, seed: int, stacks: Sequence[str], n: int,
    variants: Sequence[tuple[str, dict[str, float]]],
) -> dict[str, Any]:  # fmt: skip
    """Per variant (PEM parameter overrides; ``shipped`` first) and stack: the expected
    agreement with camera@A of ``n`` PEM runs of world A per situation (the same
    perception seeds for every variant: paired), the majority verdict's agreement, and
    the expected failure rates from the left and the right against the camera's. A
    sensitivity of the verdicts to one parameter at a time, not a refit."""
    from sitcov.hyperspace._situation import approach_side
    from sitcov.perception import PEMSensor
    from sitcov.sim.embedded import EmbeddedBackend

    with open(rows, encoding="utf-8") as fh:
        by = {(r["stack"], r["perception"], r["stream"], int(r["index"])): r
              for r in csv.DictReader(fh) if int(r["seed"]) == seed}  # fmt: skip
    rng = np.random.default_rng([seed, 0x57484154])
    plan = {
        stack: [(i, rng.integers(0, 2**32, size=n))
                for i in sorted(k[3] for k in by if k[:3] == (stack, "camera", "A"))]
        for stack in stacks
    }  # fmt: skip
    sides = {i: approach_side(sim.situation(i).bins, sim.situation(i).values)
             for items in plan.values() for i, _ in items}  # fmt: skip
    out: dict[str, Any] = {}
    for name, over in (("shipped", {}), *variants):
        backend = EmbeddedBackend(perception="pem", sensor=PEMSensor(over or None))
        res: dict[str, Any] = {"overrides": over}
        for stack in stacks:
            exp = major = 0.0
            fails: dict[str, list[float]] = defaultdict(list)
            cams: dict[str, list[float]] = defaultdict(list)
            for i, seeds in plan[stack]:
                cam = by[stack, "camera", "A", i]["failed"] == "True"
                verdicts = sim.pem_verdicts(i, stack, seeds, backend)
                share = float(np.mean([v == cam for v in verdicts]))
                exp += share
                major += 1.0 if share > 0.5 else (0.5 if share == 0.5 else 0.0)
                fails[sides[i]].append(float(np.mean(verdicts)))
                cams[sides[i]].append(float(cam))
            m = max(len(plan[stack]), 1)
            res[STACKS.get(stack, stack)] = {
                "expected_agreement": round(exp / m, 3),
                "majority_agreement": round(major / m, 3),
                "pem_fail_left": round(float(np.mean(fails["left"])), 3),
                "pem_fail_right": round(float(np.mean(fails["right"])), 3),
                "camera_fail_left": round(float(np.mean(cams["left"])), 3),
                "camera_fail_right": round(float(np.mean(cams["right"])), 3),
            }
        out[name] = res
        print(name, json.dumps(res), flush=True)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--rows",
        default="docs/data/agreement-ceiling-seed8-100.csv",
        help="agreement rows file naming the flips (camera@A vs PEM@A)",
    )
    parser.add_argument("--seed", type=int, default=8, help="evaluation seed")
    parser.add_argument("--stack", action="append", help="stacks (default: the four)")
    parser.add_argument("--limit", type=int, default=0, help="at most this many flips per stack")
    parser.add_argument(
        "--perception-seeds",
        type=int,
        default=20,
        help="PEM runs per flip with other perception seeds (class d)",
    )
    parser.add_argument(
        "--cells",
        default="docs/data/pem-frames-seed2.jsonl.gz",
        help="held-out frames file for the per-cell rates",
    )
    parser.add_argument(
        "--observe",
        type=int,
        default=0,
        help="also run situations 0..N-1 in both modes, never braking",
    )
    parser.add_argument("--frames", action="store_true", help="store every flip's frames")
    parser.add_argument("--no-flips", action="store_true", help="skip the flips")
    parser.add_argument(
        "--whatif",
        action="append",
        default=[],
        help="NAME:key=value,... PEM parameter overrides to score (with --whatif-seeds)",
    )
    parser.add_argument("--whatif-seeds", type=int, default=10, help="PEM runs per situation")
    parser.add_argument("--observe-frames", help="write the observe runs' frames here (.json.gz)")
    parser.add_argument(
        "--resummarise", action="store_true", help="only recompute --out's summary (no runs)"
    )
    parser.add_argument(
        "--modal",
        type=int,
        default=0,
        help="also run every situation's world A with N PEM perception seeds, per stack",
    )
    parser.add_argument("--out", required=True, help="JSON file to write")
    args = parser.parse_args()  # fmt: skip
    if args.resummarise:
        resummarise(args.out)
        return
    wall0 = time.perf_counter()
    flips = read_flips(args.rows, args.seed)
    stacks = args.stack or list(STACKS)
    sim = Simulator(args.seed)
    rng = np.random.default_rng([args.seed, 0x464C4950])
    thresholds = sorted({0.5, 0.7})
    cells = cell_rates(args.cells, thresholds)
    records, cpu_camera = [], 0.0
    from sitcov._seeding import run_seed
    from sitcov.hyperspace._situation import approach_side

    observe, cells_top = None, None
    if args.observe:  # first: its frames give the per-cell rates of the top score
        runs = []
        for index in range(args.observe):
            sit = sim.situation(index)
            _, cam, c1 = sim.run(index, "reference", "camera", observe=True)
            _, pem, _ = sim.run(index, "reference", "pem", observe=True)
            cpu_camera += c1
            runs.append({"index": index, "side": approach_side(sit.bins, sit.values),
                         "camera": cam, "pem": pem})  # fmt: skip
            print(f"observe {index}", flush=True)
        observe = observe_stats(runs, thresholds)
        cells_top = cell_rates_of_runs(runs, thresholds)
        if args.observe_frames:
            import gzip

            with gzip.open(args.observe_frames, "wt", encoding="utf-8") as fh:
                json.dump(runs, fh)
        del runs

    for stack in stacks:
        make = STACKS.get(stack, stack)
        need = 3 if make == "three-frames" else 1
        items = [] if args.no_flips else flips.get(stack, [])
        if args.limit:
            items = items[: args.limit]
        for index, cam_failed, pem_failed, ab_failed in items:
            oc, cam, c1 = sim.run(index, stack, "camera")
            op, pem, _ = sim.run(index, stack, "pem")
            cpu_camera += c1
            seeds = rng.integers(0, 2**32, size=args.perception_seeds)
            verdicts = sim.pem_verdicts(index, stack, seeds)
            sit = sim.situation(index)
            values = sit.values
            theta = 0.7 if make == "threshold-0.7" else 0.5
            flip = {
                "stack": make,
                "index": index,
                "situation_id": sit.id,
                "side": approach_side(sit.bins, values),
                "camera_failed": bool(oc.failed),
                "pem_failed": bool(op.failed),
                "stored_camera_failed": cam_failed,
                "stored_pem_failed": pem_failed,
                "camera_ab_failed": ab_failed,
                "aeb_camera": oc.aeb_time,
                "aeb_pem": op.aeb_time,
                "pem_agree_share": round(float(np.mean([v == oc.failed for v in verdicts])), 3),
                "threshold": theta,
            }
            flip.update(classify(flip, cam, pem, need, cells[theta]))
            if cells_top is not None:  # the same with the seed's own top-score cells
                alt = classify(flip, cam, pem, need, cells_top[theta])
                flip["pem_fire_cellfixed_top"] = alt["pem_fire_cellfixed"]
                flip["class_top_cells"] = alt["class"]
            end = flip["window_end"] if flip["window_end"] is not None else math.inf
            window = [f for f in cam if f["t"] <= end + 1e-6]
            flip["scene"] = _scene(values, window, run_seed(args.seed, index))
            if args.frames:
                flip["frames_camera"], flip["frames_pem"] = cam, pem
            records.append(flip)
            print(f"{make:14s} {index:3d} {flip['class']:10s} cam {oc.failed!s:5s} "
                  f"aeb {oc.aeb_time} pem {op.failed!s:5s} aeb {op.aeb_time} "
                  f"agree {flip['pem_agree_share']:.2f} E {flip['pem_expected_hits']} "
                  f"cam_hits {flip['camera_hits']}", flush=True)  # fmt: skip
    whatif = None
    if args.whatif:
        variants = [parse_whatif(w) for w in args.whatif]
        whatif = whatif_agreement(sim, args.rows, args.seed, stacks, args.whatif_seeds, variants)
    modal = None
    if args.modal:
        modal = modal_agreement(sim, args.rows, args.seed, stacks, args.modal, rng)
        print(json.dumps(modal, indent=1), flush=True)
    summary = summarise(records)
    payload = {
        "command": "python benchmarks/pem_flip_diagnosis.py " + " ".join(_argv()),
        "seed": args.seed,
        "rows": args.rows,
        "wall_s": round(time.perf_counter() - wall0, 1),
        "camera_cpu_s": round(cpu_camera, 1),
        "summary": summary,
        "observe": observe,
        "modal": modal,
        "whatif": whatif,
        "flips": records,
    }
    Path(args.out).write_text(json.dumps(payload, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(summary, indent=1))
    if observe:
        print(json.dumps(observe, indent=1))


def _argv() -> list[str]:
    import sys

    return sys.argv[1:]


def _scene(values: dict[str, Any], frames: list[dict], seed: int) -> dict[str, Any]:
    """What the PEM's cells do not carry, in the decisive window's frames: the OV's colour,
    the weather, the most a nearer road user covers, the truncation and image position of
    the frames whose true box passes the stack's geometry."""
    occl = max((a["occl"] for f in frames for a in f["actors"]), default=0.0)
    trunc = max((a["trunc"] for f in frames for a in f["actors"] if a["geo"]), default=0.0)
    weather = {k: values.get(k) for k in ("precipitation", "fog_density", "fog_distance",
                                          "cloudiness", "wetness")}  # fmt: skip
    cx = [a["cx"] for f in frames for a in f["actors"] if a["geo"]]
    return {"weather": weather, "max_occlusion": occl, "max_trunc_in_test": trunc,
            "cx_in_test": [min(cx), max(cx)] if cx else None,
            "color": _COLOR_NAMES.get(tuple(ov_color(values, seed)), "other")}  # fmt: skip


def summarise(records: list[dict[str, Any]]) -> dict[str, Any]:
    """Class counts per stack and the numbers behind them: per class (pooled over the
    stacks) the box-height bands of the windows (detector's mean score and share >= θ
    against the PEM's median score and mean P(score >= θ)), the direction of the flips
    and what the scenes of the ``c`` classes share."""
    out: dict[str, Any] = {"stacks": {}, "classes": {}}
    for stack in dict.fromkeys(r["stack"] for r in records):
        rs = [r for r in records if r["stack"] == stack]
        out["stacks"][stack] = {
            "flips": len(rs),
            "classes": dict(Counter(r["class"] for r in rs)),
            "reproduced": sum(
                r["camera_failed"] == r["stored_camera_failed"]
                and r["pem_failed"] == r["stored_pem_failed"]
                for r in rs
            ),
            "not_flips_now": sum(r["camera_failed"] == r["pem_failed"] for r in rs),
            "classes_top_cells": dict(Counter(r.get("class_top_cells", "-") for r in rs)),
            "pem_fails_more": sum(r["pem_failed"] and not r["camera_failed"] for r in rs),
            "by_side": dict(Counter(f"{r['side']} {r['class']}" for r in rs)),
        }
    # the systematic flips by direction, at the first-firing mode's firing frame
    sysf = [r for r in records if r["class"] not in ("d-noise", "none")]
    under = [r for r in sysf if not r["pem_fired_first"] and r.get("fire_frame")]
    over = [r for r in sysf if r["pem_fired_first"]]
    out["systematic"] = {
        "flips": len(sysf),
        "camera_fired_first": len(under),
        "camera_first_by_stack": dict(Counter(r["stack"] for r in under)),
        "camera_first_sides": dict(Counter(r["side"] for r in under)),
        "camera_first_within_10_7_m": sum(r["fire_frame"]["dist"] <= 10.7 for r in under),
        "camera_first_truncated_ge015": sum(r["fire_frame"]["trunc"] >= 0.15 for r in under),
        "camera_first_best_overlap_below_theta": sum(
            r["fire_frame"]["score_iou"] < r["threshold"] for r in under
        ),
        "camera_first_pem_p_at_fire_median": round(
            float(np.median([r["fire_frame"]["pt"] for r in under])), 3
        )
        if under
        else None,
        "pem_fired_first": len(over),
        "pem_first_frames": [
            {k: r["fire_frame"][k] for k in ("dist", "h", "view")}
            | {"stack": r["stack"], "index": r["index"], "class": r["class"]}
            for r in over
            if r.get("fire_frame")
        ],  # fmt: skip
    }
    for cls in sorted({r["class"] for r in records}):
        rs = [r for r in records if r["class"] == cls]
        bands: dict[str, list[float]] = defaultdict(lambda: [0, 0.0, 0.0, 0, 0.0])
        for r in rs:
            for k, row in r.get("bands", {}).items():
                acc = bands[k]
                for j in range(5):
                    acc[j] += row[j]
        scenes = [r["scene"] for r in rs]
        out["classes"][cls] = {
            "flips": len(rs),
            "pem_fails_more": sum(r["pem_failed"] and not r["camera_failed"] for r in rs),
            "pem_fired_first": sum(bool(r.get("pem_fired_first")) for r in rs),
            "sides": dict(Counter(r["side"] for r in rs)),
            "colors": dict(Counter(sc["color"] for sc in scenes)),
            "rain_ge60": sum((sc["weather"]["precipitation"] or 0) >= 60 for sc in scenes),
            "truncated_ge02_in_test": sum(sc["max_trunc_in_test"] >= 0.2 for sc in scenes),
            "camera_fire_stray": sum(bool(r.get("camera_fire_stray")) for r in rs),
            "median_pem_agree_share": round(
                float(np.median([r["pem_agree_share"] for r in rs])), 3
            ),
            "median_pem_fire_indep": round(float(np.median([r["pem_fire_indep"] for r in rs])), 3),
            "median_pem_fire_cellfixed": round(
                float(np.median([r["pem_fire_cellfixed"] for r in rs])), 3
            ),
            "bands": {
                k: {
                    "frames": int(v[0]),
                    "detector_mean_score": round(v[1] / v[0], 3),
                    "pem_median_score": round(v[2] / v[0], 3),
                    "detector_ge_theta": round(v[3] / v[0], 3),
                    "pem_p_ge_theta": round(v[4] / v[0], 3),
                }
                for k, v in sorted(bands.items(), key=lambda kv: _band_order(kv[0]))
                if v[0]
            },
        }
    return out


def _band_order(key: str) -> tuple[int, str]:
    return int(key.split("-")[0]), key


def resummarise(path: str) -> None:
    """Recompute the summary of a written JSON file (``--from``) in place."""
    data = json.loads(Path(path).read_text(encoding="utf-8"))
    data["summary"] = summarise(data["flips"])
    Path(path).write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    print(json.dumps(data["summary"], indent=1))


if __name__ == "__main__":
    main()
