"""Top-down pictures of a few failing runs for the report.

A run's stored trace is drawn if it has one; otherwise the run is simulated again with
``record=True`` from its stored situation, seed and campaign config (runs are deterministic
per seed, so the picture shows the stored run).
"""

from __future__ import annotations

import base64
import shlex
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from sitcov.errors import SitcovError
from sitcov.report._road import road_drawing, run_road
from sitcov.report._traces import close_builders, traced_outcome


def _pick(runs: Sequence[Any], n: int) -> list[Any]:
    """Up to ``n`` failing runs, the failure kinds (collision, road departure, ...) in
    proportion to their counts (largest remainder, each kind at least one while slots
    last), within a kind preferring different intersection situations, then run order."""
    failing = [r for r in runs if r.status == "fail"]
    by_kind: dict[str, list[Any]] = {}
    for run in failing:
        by_kind.setdefault(str(run.failure_kind), []).append(run)
    slots = _proportional({k: len(v) for k, v in by_kind.items()}, min(n, len(failing)))
    chosen = []
    for kind, group in by_kind.items():
        chosen += _distinct(group, slots[kind])
    order = {id(r): i for i, r in enumerate(failing)}
    return sorted(chosen, key=lambda r: order[id(r)])


def _proportional(counts: dict[str, int], n: int) -> dict[str, int]:
    """``n`` slots shared by ``counts``: every kind one while slots last (most frequent
    first), the rest by largest remainder of its proportional share."""
    slots = dict.fromkeys(counts, 0)
    for kind in sorted(counts, key=lambda k: -counts[k])[:n]:
        slots[kind] = 1
    left = n - sum(slots.values())
    total = sum(counts.values())
    if left > 0 and total:
        share = {k: counts[k] * n / total - slots[k] for k in counts}
        for kind in sorted(counts, key=lambda k: -share[k]):
            extra = min(max(0, int(share[kind])), counts[kind] - slots[kind], left)
            slots[kind] += extra
            left -= extra
        for kind in sorted(counts, key=lambda k: -(share[k] - int(share[k]))):
            if left and slots[kind] < counts[kind]:
                slots[kind] += 1
                left -= 1
    return slots


def _distinct(group: Sequence[Any], n: int) -> list[Any]:
    """``n`` runs of ``group``, different intersection situations first."""
    chosen, seen = [], set()
    for run in group:
        key = run.bins.get("intsit")
        if len(chosen) < n and key not in seen:
            chosen.append(run)
            seen.add(key)
    for run in group:
        if len(chosen) >= n:
            break
        if run not in chosen:
            chosen.append(run)
    return chosen


def failure_pictures(
    store: Any, db: str, runs: Sequence[Any], fig_dir: Path, n: int, *, animate: bool = True
) -> tuple[list[dict[str, str]], str]:
    """Draw up to ``n`` failing runs of ``runs`` (and, with ``animate``, a short GIF of
    each); returns (picture dicts, a note for the page)."""
    chosen = _pick(runs, n) if n > 0 else []
    if not chosen:
        return [], ""
    try:
        from sitcov.sim.embedded import render_topdown
    except ImportError:
        return [], "Top-down pictures need the embedded backend's renderer, which is unavailable."
    pictures, problems, builders = [], [], {}
    try:
        for run in chosen:
            ref = f"{run.campaign}:{run.index}"
            try:
                outcome = traced_outcome(store, run, builders)
                safe = "".join(c if c.isalnum() else "_" for c in ref)
                path = fig_dir / f"failure_{safe}.png"
                road = road_drawing(
                    run_road(run.config, outcome.trace.meta if outcome.trace else None,
                             outcome.metrics)
                )  # fmt: skip
                render_topdown(outcome, path, road)
                data = path.read_bytes()
            except (SitcovError, ValueError, TypeError, OSError) as exc:
                problems.append(f"{ref}: {exc}")
                continue
            detail = [_what_happened(outcome)]
            if outcome.collision_speed is not None:
                detail.append(f"impact {outcome.collision_speed:.1f} m/s")
            if outcome.collision_time is not None:
                detail.append(f"at t = {outcome.collision_time:.1f} s")
            detail.append("AEB fired" if outcome.aeb_fired else "AEB did not fire")
            detail += _draws_detail(outcome)
            if outcome.status != run.status:
                detail.append(f"re-simulation gave {outcome.status}, stored {run.status}")
            pictures.append(
                {
                    "gif": _animation(outcome, ref, _dashcam(store, run, outcome), road)
                    if animate
                    else None,
                    "png": base64.b64encode(data).decode("ascii"),
                    "run": ref,
                    "bins": ", ".join(f"{k}={v}" for k, v in run.bins.items()),
                    "detail": "; ".join(detail),
                    "command": f"sitcov replay --db {shlex.quote(db)} {shlex.quote(ref)}",
                }
            )
    finally:
        close_builders(builders)
    note = (
        "Top-down views drawn by the embedded backend's renderer, on the campaign's map or, for "
        "runs on an OpenDRIVE road (esmini backend), on that road's lanes near the run. Runs "
        "without a stored trace were simulated again from their stored situation, seed and "
        "campaign config."
    )
    if problems:
        note += " Not drawn: " + "; ".join(problems)
    return pictures, note


def _draws_detail(outcome: Any) -> list[str]:
    """``failed in 9 of 15 perception draws`` for a run of a campaign with perception
    draws (how firmly the model fails the situation), else nothing."""
    metrics = outcome.metrics
    draws = metrics.get("perception_draws") or 1
    if draws <= 1:
        return []
    return [f"failed in {metrics.get('draws_failed')} of {draws} perception draws"]


def _what_happened(outcome: Any) -> str:
    """``collision with actor2 (pedestrian)``, ``road departure``, ..."""
    text = outcome.kind.replace("_", " ")
    if outcome.kind != "collision":
        return text
    from sitcov.report._animate import actor_kind, focus_actor

    actor = focus_actor(outcome)  # the actor hit (a two-car run stores no name: the OV)
    if actor is None:
        return text
    name = "the OV" if actor == "ov" else str(actor)
    kind = (outcome.metrics or {}).get("collision_kind") or actor_kind(outcome, actor)
    return f"{text} with {name} ({kind})"


#: the report's animations: short and small (every 4th step at dt 0.05 s, at most 60 frames)
REPORT_FPS, REPORT_FRAMES, REPORT_DPI = 5, 60, 60


def _dashcam(store: Any, run: Any, outcome: Any) -> Any:
    """The dash-cam strip of a run of a camera-mode campaign (no detector boxes: running the
    detector on every frame would cost most of the animation), else None."""
    from sitcov.report._animate import run_dashcam
    from sitcov.report._dashcam import camera_mode

    if not camera_mode(dict(run.config or {})):
        return None
    stored = store.get_run(run.campaign, run.index, with_trace=False)
    values = stored.situation.to_dict()["values"]
    return run_dashcam(run.config, values, run.seed, outcome, boxes=False)


def _animation(outcome: Any, ref: str, dashcam: Any = None, road: Any = None) -> str | None:
    """A small GIF of the run, base64 (None when the run has no trace to animate), with
    ``dashcam``'s strip when given, on ``road`` (a road drawing; None: the trace's map)."""
    from sitcov.report._animate import gif_bytes, render_frames

    if outcome.trace is None or not outcome.trace.ego:
        return None
    frames = render_frames(
        outcome,
        title=ref,
        fps=REPORT_FPS,
        max_frames=REPORT_FRAMES,
        dpi=REPORT_DPI,
        dashcam=dashcam,
        road=road,
    )
    return base64.b64encode(gif_bytes(frames, REPORT_FPS)).decode("ascii")
