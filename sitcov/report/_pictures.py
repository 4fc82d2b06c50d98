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


def _pick(runs: Sequence[Any], n: int) -> list[Any]:
    """Up to ``n`` failing runs, preferring different intersection situations (then order)."""
    failing = [r for r in runs if r.status == "fail"]
    chosen, seen = [], set()
    for run in failing:
        key = run.bins.get("intsit")
        if key not in seen:
            chosen.append(run)
            seen.add(key)
        if len(chosen) == n:
            return chosen
    for run in failing:
        if len(chosen) == n:
            break
        if run not in chosen:
            chosen.append(run)
    return chosen


def _complete(trace: Any) -> bool:
    """Whether a stored trace has every actor's rows (stores before this kept the ego's and
    the primary OV's only, so such a run is simulated again to draw the others)."""
    if trace is None:
        return False
    actors = (trace.meta or {}).get("actors") or {}
    return len(actors) <= 1 or set(actors) <= set(trace.actors or {})


def _trace_outcome(store: Any, run: Any, builders: dict) -> Any:
    stored = store.get_run(run.campaign, run.index, with_trace=True)
    if stored.outcome is not None and _complete(stored.outcome.trace):
        return stored.outcome
    from sitcov.campaign._build import build_backend, build_stack
    from sitcov.campaign._config import CampaignConfig

    key = run.campaign
    if key not in builders:
        known = set(CampaignConfig.model_fields)
        config = CampaignConfig(**{k: v for k, v in dict(run.config).items() if k in known})
        builders[key] = (build_backend(config), build_stack(config))
    backend, stack = builders[key]
    from sitcov.sim import Judge

    judge = Judge.from_spec(run.config.get("judge", "paper"))  # stored before judges: paper
    return judge(backend.run(stored.situation, stack, run.seed, record=True))


def failure_pictures(
    store: Any, db: str, runs: Sequence[Any], fig_dir: Path, n: int
) -> tuple[list[dict[str, str]], str]:
    """Draw up to ``n`` failing runs of ``runs``; returns (picture dicts, a note for the page)."""
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
                outcome = _trace_outcome(store, run, builders)
                safe = "".join(c if c.isalnum() else "_" for c in ref)
                path = fig_dir / f"failure_{safe}.png"
                render_topdown(outcome, path)
                data = path.read_bytes()
            except (SitcovError, ValueError, TypeError, OSError) as exc:
                problems.append(f"{ref}: {exc}")
                continue
            detail = [outcome.kind.replace("_", " ")]
            if outcome.collision_speed is not None:
                detail.append(f"impact {outcome.collision_speed:.1f} m/s")
            if outcome.collision_time is not None:
                detail.append(f"at t = {outcome.collision_time:.1f} s")
            detail.append("AEB fired" if outcome.aeb_fired else "AEB did not fire")
            if outcome.status != run.status:
                detail.append(f"re-simulation gave {outcome.status}, stored {run.status}")
            pictures.append(
                {
                    "png": base64.b64encode(data).decode("ascii"),
                    "run": ref,
                    "bins": ", ".join(f"{k}={v}" for k, v in run.bins.items()),
                    "detail": "; ".join(detail),
                    "command": f"sitcov replay --db {shlex.quote(db)} {shlex.quote(ref)}",
                }
            )
    finally:
        for backend, stack in builders.values():
            for obj in (stack, backend):
                close = getattr(obj, "close", None)
                if close is not None:
                    close()
    note = (
        "Top-down views drawn by the embedded backend's renderer. Runs without a stored trace were "
        "simulated again from their stored situation, seed and campaign config."
    )
    if problems:
        note += " Not drawn: " + "; ".join(problems)
    return pictures, note
