"""Render the ego's dash-cam view of a situation at a given time (``sitcov render``)."""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from sitcov.errors import ConfigError
from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._renderer import render_frame


def parse_situation(text: str) -> Any:
    """A Situation from a JSON object or JSON line as printed by ``sitcov generate``.

    ``text`` starting with ``@`` names a file whose first non-empty line is used.

    Raises:
        ConfigError: not JSON, or no ``bins``/``values``.
    """
    from sitcov.hyperspace import Situation

    source = "--situation"
    if text.startswith("@"):
        source = text[1:]
        try:
            lines = [ln for ln in Path(source).read_text().splitlines() if ln.strip()]
        except OSError as exc:
            raise ConfigError(f"{source}: cannot read the situation: {exc}") from None
        text = lines[0] if lines else ""
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ConfigError(
            file=source, field="(json)", value=text[:40], expected=f"a situation JSON ({exc.msg})"
        ) from None
    if not isinstance(data, dict) or "bins" not in data or "values" not in data:
        raise ConfigError(file=source, field="(json)", expected='an object with "bins", "values"')
    try:
        return Situation.from_dict(data)
    except (TypeError, ValueError, KeyError) as exc:
        raise ConfigError(
            file=source, field="(json)", expected=f"a valid situation ({exc})"
        ) from None


def _row_at(rows: list[tuple[float, ...]], t: float) -> tuple[float, ...] | None:
    if not rows:
        return None
    best = min(rows, key=lambda r: abs(r[0] - t))
    return best if abs(best[0] - t) <= 0.051 else None


def render_situation(
    situation: Any,
    time: float,
    out: str | Path | None = None,
    *,
    seed: int = 0,
    backend_options: dict[str, Any] | None = None,
) -> tuple[np.ndarray, dict[str, Any]]:
    """Re-simulate ``situation`` on the embedded backend and render the ego's view at ``time``.

    The run uses the reference stack in PEM mode (as a default campaign does) and records
    its trace; the frame shows the recorded poses at the trace row nearest ``time``.

    Args:
        situation: a Situation.
        time: simulated time [s]; clamped to the end of the run.
        out: PNG path to write (None: only return the image).
        seed: run seed (the seed stored with a campaign run reproduces it).
        backend_options: extra ``EmbeddedBackend`` options.

    Returns:
        The image and a dict with the time used, the run's status and the OV's box.

    Raises:
        ConfigError: negative time.
    """
    from sitcov.av import ReferenceStack
    from sitcov.perception._camera import project_box
    from sitcov.perception._colors import ov_color
    from sitcov.sim import conditions_from_values
    from sitcov.sim.embedded import EmbeddedBackend

    if not time >= 0:
        raise ConfigError(field="--time", value=time, expected="a time >= 0 [s]")
    backend = EmbeddedBackend(**(backend_options or {}))
    outcome = backend.run(situation, ReferenceStack(), int(seed), record=True)
    trace = outcome.trace
    if trace is None or not trace.ego:
        raise ConfigError(f"the run recorded no trace (status {outcome.status})")
    t = min(float(time), trace.ego[-1][0])
    ego_row = min(trace.ego, key=lambda r: abs(r[0] - t))
    t = ego_row[0]
    ov_row = _row_at(trace.ov, t)
    vp = backend.vehicle
    actors = ()
    if ov_row is not None:
        color = ov_color(situation.values, int(seed))  # the run's colour, as the backend drew it
        actors = (ActorView(Pose(ov_row[1], ov_row[2], ov_row[3]), vp.length, vp.width,
                            vp.height, ov_row[4], color),)  # fmt: skip
    wind_dir = float(outcome.metrics.get("wind_direction", 0.0) or 0.0)
    conditions = conditions_from_values(situation.values, wind_direction=wind_dir)
    camera = CameraSpec()
    ego = Pose(ego_row[1], ego_row[2], ego_row[3])
    rng = np.random.default_rng([int(seed), int(round(t * 1000))])
    image = render_frame(camera, ego, actors, conditions, backend.map.render_geometry(), rng)
    box = None
    if actors:
        proj = project_box(camera, ego, actors[0])
        if proj is not None and proj.visible:
            box = [round(v, 1) for v in proj.box]
    if out is not None:
        from PIL import Image

        Image.fromarray(image).save(str(out))
    info = {
        "time": t,
        "status": outcome.status,
        "end_reason": outcome.end_reason,
        "sim_time": outcome.sim_time,
        "ov_box": box,
        "ov_distance": (
            math.hypot(ov_row[1] - ego_row[1], ov_row[2] - ego_row[2]) if ov_row else None
        ),
    }
    return image, info
