"""Animations of a recorded run: top-down view of every actor, the ego's speed over time,
and for runs of camera-mode campaigns a dash-cam strip under them: the ego's camera view
at each frame with the detector's boxes (:mod:`sitcov.report._dashcam`).

One simulation at most: the stored trace is used when the run has one, else the run is
simulated once again with ``record=True`` from its stored situation, seed and campaign
configuration (runs are deterministic per seed). Every frame is drawn from that trace, so
an animation costs drawing time only, not a simulation per frame.

Formats: ``.gif`` (Pillow, plays anywhere offline), ``.html`` (a small player with the
frames embedded as JPEG: offline, with play/pause and a slider) and ``.mp4`` (needs
``ffmpeg`` on PATH; one clear error when it is missing).
"""

from __future__ import annotations

import base64
import html
import json
import math
import shutil
import subprocess
from pathlib import Path
from typing import Any

from sitcov.errors import ConfigError
from sitcov.sim import Outcome

#: frames per second of the animation (10 = every second step at the default dt 0.05 s)
FPS = 10
#: at most this many frames (long runs are sampled more sparsely)
MAX_FRAMES = 200
#: seconds of trajectory drawn behind each actor
TRAIL = 3.0
FORMATS = (".gif", ".html", ".mp4")


def _frame_steps(times: list[float], fps: int, max_frames: int) -> list[int]:
    """Indices of the trace rows to draw: ``fps`` per simulated second, at most
    ``max_frames``, always ending on the last row (the moment the run ended)."""
    if not times:
        return []
    dt = (times[-1] - times[0]) / max(1, len(times) - 1) or 0.05
    every = max(1, round(1.0 / (fps * dt)))
    every = max(every, math.ceil(len(times) / max_frames))
    steps = list(range(0, len(times), every))
    if steps[-1] != len(times) - 1:
        steps.append(len(times) - 1)
    return steps


def _closing(ego: list, other: list) -> tuple[list[float], list[float]]:
    """Distance [m] between ego and another actor per row, and the time to collision [s]
    at constant velocities (inf when they do not close), centre to centre."""
    dist, ttc = [], []
    for e, o in zip(ego, other, strict=False):
        dx, dy = o[1] - e[1], o[2] - e[2]
        vx = o[4] * math.cos(o[3]) - e[4] * math.cos(e[3])
        vy = o[4] * math.sin(o[3]) - e[4] * math.sin(e[3])
        d = math.hypot(dx, dy)
        rate = (dx * vx + dy * vy) / d if d > 0 else 0.0  # d(distance)/dt
        dist.append(d)
        ttc.append(d / -rate if rate < -1e-6 else math.inf)
    return dist, ttc


def focus_actor(outcome: Outcome) -> str | None:
    """The actor the story is about: the one hit, else the primary OV, else the first."""
    trace = outcome.trace
    names = list((trace.actors or {}) if trace else {}) or (["ov"] if trace and trace.ov else [])
    hit = (outcome.metrics or {}).get("collision_actor")
    if hit in names:
        return hit
    return "ov" if "ov" in names else (names[0] if names else None)


def actor_kind(outcome: Outcome, name: str) -> str:
    """The kind of actor ``name`` in the run's trace (``car`` when the trace does not say)."""
    meta = (outcome.trace.meta if outcome.trace else None) or {}
    return str((meta.get("actors") or {}).get(name, {}).get("kind", "car"))


def _rows(trace: Any, name: str) -> list:
    return trace.ov if name == "ov" and not (trace.actors or {}).get("ov") else trace.actors[name]


def animate_outcome(
    outcome: Outcome,
    path: str | Path,
    *,
    title: str = "",
    fps: int = FPS,
    max_frames: int = MAX_FRAMES,
    dpi: int = 72,
    dashcam: Any = None,
    road: Any = None,
) -> Path:
    """Write the animation of a run recorded with ``record=True``.

    Args:
        outcome: the run's outcome with its trace.
        path: ``.gif``, ``.html`` or ``.mp4``.
        title: the heading (e.g. ``campaign:index``).
        fps, max_frames, dpi: frame rate, most frames, resolution.
        dashcam: a :class:`~sitcov.report._dashcam.DashCam` of the run (camera mode): its
            view is drawn under the top-down one in every frame; None: no strip.
        road: the road drawn under the actors (``sitcov.report._road.road_drawing``: an
            embedded map or an OpenDRIVE file); None: the map named in the trace.

    Raises:
        ConfigError: no trace, an unknown format, or ``.mp4`` without ffmpeg.
    """
    out = Path(path)
    if out.suffix.lower() not in FORMATS:
        raise ConfigError(
            field="--out", value=str(out), expected=f"a file ending in {', '.join(FORMATS)}"
        )
    trace = outcome.trace
    if trace is None or not trace.ego:
        raise ConfigError("animate: the outcome has no trace; run it with record=True")
    import matplotlib

    matplotlib.use("Agg", force=False)
    suffix = out.suffix.lower()
    ffmpeg = shutil.which("ffmpeg")
    if suffix == ".mp4" and ffmpeg is None:
        raise ConfigError(
            field="--out",
            value=str(out),
            expected="ffmpeg on PATH for .mp4 (or write .gif / .html)",
        )
    frames = render_frames(
        outcome, title=title, fps=fps, max_frames=max_frames, dpi=dpi, dashcam=dashcam, road=road
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    if suffix == ".gif":
        _write_gif(frames, out, fps)
    elif suffix == ".mp4":
        _write_mp4(frames, out, fps, ffmpeg)
    else:
        out.write_text(html_player(frames, fps, title=title))
    return out


def render_frames(
    outcome: Outcome,
    *,
    title: str = "",
    fps: int = FPS,
    max_frames: int = MAX_FRAMES,
    dpi: int = 72,
    dashcam: Any = None,
    road: Any = None,
) -> list[Any]:
    """The animation's frames as RGB arrays (height x width x 3, uint8).

    The static parts (map, axes, curves, legends) are drawn once and restored for every
    frame; only the moving artists are drawn again (blitting), so a frame costs a few ms
    (plus the dash-cam frame's rendering with ``dashcam``, see :func:`animate_outcome`).
    """
    import matplotlib.pyplot as plt
    import numpy as np

    fig, update, steps, moving = _figure(outcome, title, fps, max_frames, dpi, dashcam, road)
    try:
        for artist in moving:
            artist.set_animated(True)
        canvas = fig.canvas
        canvas.draw()
        background = canvas.copy_from_bbox(fig.bbox)
        frames = []
        for i in steps:
            update(i)
            canvas.restore_region(background)
            for artist in moving:
                artist.axes.draw_artist(artist)
            frames.append(np.asarray(canvas.buffer_rgba())[:, :, :3].copy())
        return frames
    finally:
        plt.close(fig)


def _write_gif(frames: list[Any], out: Path, fps: int) -> None:
    out.write_bytes(gif_bytes(frames, fps))


def gif_bytes(frames: list[Any], fps: int) -> bytes:
    """The frames as an animated GIF that loops (128-colour palette per frame)."""
    import io

    from PIL import Image

    buf = io.BytesIO()
    images = [
        Image.fromarray(f).quantize(colors=128, method=Image.Quantize.MEDIANCUT) for f in frames
    ]
    images[0].save(
        buf,
        format="GIF",
        save_all=True,
        append_images=images[1:],
        duration=round(1000 / fps),
        loop=0,
    )
    return buf.getvalue()


def _write_mp4(frames: list[Any], out: Path, fps: int, ffmpeg: str) -> None:
    h, w = frames[0].shape[:2]
    command = [
        ffmpeg,
        "-y",
        "-loglevel",
        "error",
        "-f",
        "rawvideo",
        "-pix_fmt",
        "rgb24",
        "-s",
        f"{w}x{h}",
        "-r",
        str(fps),
        "-i",
        "-",
        "-pix_fmt",
        "yuv420p",
        "-vf",
        "pad=ceil(iw/2)*2:ceil(ih/2)*2",
        str(out),
    ]
    done = subprocess.run(
        command, input=b"".join(f.tobytes() for f in frames), check=False, capture_output=True
    )
    if done.returncode != 0:
        tail = done.stderr.decode(errors="replace")[-200:]
        raise ConfigError(field="--out", value=str(out), expected=f"ffmpeg to encode it ({tail})")


def jpeg_frames(frames: list[Any], quality: int = 70) -> list[str]:
    """Frames as base64 JPEG strings (for HTML players)."""
    import io

    from PIL import Image

    out = []
    for frame in frames:
        buf = io.BytesIO()
        Image.fromarray(frame).save(buf, format="JPEG", quality=quality)
        out.append(base64.b64encode(buf.getvalue()).decode("ascii"))
    return out


#: a minimal offline player: the frames are in the page, play/pause and a slider
_PLAYER = """<div class="sitcov-anim" id="{uid}">
<img alt="{alt}" style="max-width:100%" src="data:image/jpeg;base64,{first}">
<div><button type="button">pause</button> <input type="range" min="0" max="{last}" value="0"
 style="width:60%"> <span></span></div>
<script>(function(){{var root=document.getElementById("{uid}"),img=root.querySelector("img"),
btn=root.querySelector("button"),bar=root.querySelector("input"),
txt=root.querySelector("span"),f={frames},i=0,on=true;
function show(k){{i=k;img.src="data:image/jpeg;base64,"+f[k];bar.value=k;
txt.textContent=(k+1)+"/"+f.length;}}
btn.onclick=function(){{on=!on;btn.textContent=on?"pause":"play";}};
bar.oninput=function(){{on=false;btn.textContent="play";show(+bar.value);}};
setInterval(function(){{if(on){{show((i+1)%f.length);}}}},{interval});show(0);}})();
</script></div>"""


def html_player(frames: list[Any], fps: int, *, title: str = "", uid: str = "run") -> str:
    """A self-contained HTML fragment that plays ``frames`` offline (no network, no
    library): a standalone page when written alone, embeddable in the report."""
    encoded = jpeg_frames(frames)
    safe = "".join(c if c.isalnum() else "-" for c in uid)
    player = _PLAYER.format(
        uid=f"anim-{safe}",
        alt=html.escape(title, quote=True),
        first=encoded[0],
        last=len(encoded) - 1,
        frames=json.dumps(encoded),
        interval=round(1000 / fps),
    )
    return (
        f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>"
        f"{html.escape(title)}</title></head><body>{player}</body></html>"
    )


def _figure(  # noqa: PLR0915
    outcome: Outcome,
    title: str,
    fps: int,
    max_frames: int,
    dpi: int,
    dashcam: Any = None,
    road: Any = None,
) -> tuple:
    """The figure, its per-frame update function and the frame indices (and, with
    ``dashcam``, a row below with the ego's camera view)."""
    import matplotlib.pyplot as plt
    import numpy as np
    from matplotlib.patches import Polygon

    from sitcov.report._road import road_drawing
    from sitcov.sim.embedded._render import drawn_actors, outline

    trace = outcome.trace
    meta = dict(trace.meta or {})
    if not meta.get("collision_point") and (outcome.metrics or {}).get("collision_point"):
        meta["collision_point"] = outcome.metrics["collision_point"]  # esmini keeps it there
    times = [row[0] for row in trace.ego]
    steps = _frame_steps(times, fps, max_frames)
    if dashcam is None:
        fig = plt.figure(figsize=(9.6, 5.4), dpi=dpi)
        grid = fig.add_gridspec(2, 2, width_ratios=[1.25, 1])
    else:
        fig = plt.figure(figsize=(9.6, 9.0), dpi=dpi)
        grid = fig.add_gridspec(3, 2, width_ratios=[1.25, 1], height_ratios=[1, 1, 1.55])
    ax = fig.add_subplot(grid[:2, 0])
    ax_speed, ax_gap = fig.add_subplot(grid[0, 1]), fig.add_subplot(grid[1, 1])
    camera_image = None
    if dashcam is not None:
        ax_cam = fig.add_subplot(grid[2, :])
        camera_image = ax_cam.imshow(np.zeros((*dashcam.shape, 3), dtype=np.uint8))
        ax_cam.set_xticks([])
        ax_cam.set_yticks([])
        ax_cam.grid(False)
        ax_cam.set_title(
            "ego dash-cam (camera perception)"
            + (": detector boxes" if dashcam.detector is not None else ""),
            fontsize=9,
        )
    if road is None:
        road = road_drawing(str(meta.get("map", "t-junction")))
    limits = road.view(trace)
    _background(ax, road, limits)
    ax.tick_params(labelsize=7)
    actors = drawn_actors(trace, meta)
    patches, trails = [], []
    for actor in actors:
        patch = Polygon(
            [(0, 0)] * 3,
            closed=True,
            facecolor=actor["color"],
            edgecolor="black",
            linewidth=0.7,
            zorder=5,
            label=actor["label"],
        )
        ax.add_patch(patch)
        patches.append(patch)
        (trail,) = ax.plot([], [], color=actor["color"], linewidth=1.6, zorder=4)
        trails.append(trail)
    if meta.get("conflict_point"):
        ax.plot(
            *meta["conflict_point"],
            marker="X",
            color="#212121",
            ms=7,
            ls="",
            zorder=6,
            label="conflict point",
        )
    (crash,) = ax.plot([], [], marker="*", color="black", ms=16, ls="", zorder=7, label="collision")
    ax.legend(loc="upper right", fontsize=7, framealpha=0.9)
    status = ax.text(
        0.02,
        0.02,
        "",
        transform=ax.transAxes,
        fontsize=9,
        zorder=8,
        bbox={"facecolor": "white", "alpha": 0.85, "edgecolor": "none"},
    )
    cursors, label_focus = _time_panels(ax_speed, ax_gap, outcome, times)
    fig.suptitle(title or "run", fontsize=10)
    fig.tight_layout()
    collision_time = outcome.collision_time
    aeb_time = outcome.aeb_time if outcome.aeb_fired else None
    trail_rows = max(1, round(TRAIL / max(1e-9, (times[-1] - times[0]) / max(1, len(times) - 1))))

    def update(i: int) -> list:
        t = times[i]
        for actor, patch, trail in zip(actors, patches, trails, strict=True):
            rows = actor["rows"]
            if not rows:
                continue
            j = min(i, len(rows) - 1)
            patch.set_xy(outline(actor["kind"], rows[j], *actor["size"]))
            lo = max(0, j - trail_rows)
            trail.set_data([r[1] for r in rows[lo : j + 1]], [r[2] for r in rows[lo : j + 1]])
        for cursor in cursors:
            cursor.set_xdata([t, t])
        words = [f"t = {t:5.2f} s", f"ego {trace.ego[i][4]:4.1f} m/s"]
        if aeb_time is not None and t >= aeb_time:
            words.append("AEB braking")
        # a trace may end on the step before contact (esmini's rows precede each step)
        hit = outcome.end_reason == "collision" and i == len(times) - 1
        if collision_time is not None and (t >= collision_time - 1e-9 or hit):
            words.append(f"COLLISION with {label_focus}")
            if meta.get("collision_point"):
                crash.set_data([meta["collision_point"][0]], [meta["collision_point"][1]])
        elif i == len(times) - 1:
            words.append(f"end: {outcome.end_reason}")
        status.set_text("   ".join(words))
        if camera_image is not None:
            camera_image.set_data(dashcam.frame(i))
        return [*patches, *trails, *cursors, status, crash]

    moving = [*trails, *patches, crash, *cursors, status]
    return fig, update, steps, moving + ([camera_image] if camera_image is not None else [])


def _background(ax: Any, road: Any, limits: Any) -> None:
    """The road (a ``sitcov.report._road`` drawing) drawn once into a raster image shown
    behind the actors: redrawing its hundreds of polygons and markings in every frame
    would cost most of the drawing time."""
    import matplotlib.pyplot as plt
    import numpy as np

    (x0, x1), (y0, y1) = limits if limits is not None else ((-60, 60), (-60, 60))
    side = 8.0  # [in] at 100 dpi: 800 px over the view
    bg = plt.figure(figsize=(side, side * (y1 - y0) / (x1 - x0)), dpi=100)
    try:
        bax = bg.add_axes((0, 0, 1, 1))
        road.draw(bax, ((x0, x1), (y0, y1)))
        bax.set_xlim(x0, x1)
        bax.set_ylim(y0, y1)
        bax.set_aspect("auto")
        bax.set_xticks([])
        bax.set_yticks([])
        for spine in bax.spines.values():
            spine.set_visible(False)
        bg.canvas.draw()
        image = np.asarray(bg.canvas.buffer_rgba()).copy()
    finally:
        plt.close(bg)
    ax.imshow(image, extent=(x0, x1, y0, y1), origin="upper", zorder=0, interpolation="bilinear")
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")


def _time_panels(
    ax_speed: Any, ax_gap: Any, outcome: Outcome, times: list[float]
) -> tuple[list[Any], str]:
    """The ego's speed (top) and the distance / TTC to the focus actor (bottom) over time,
    with the AEB and collision instants; returns (the two time cursors, the focus label)."""
    trace = outcome.trace
    ax_speed.plot(times, [r[4] for r in trace.ego], color="#1e88e5", label="ego speed [m/s]")
    focus = focus_actor(outcome)
    label = "nobody"
    if focus is not None:
        label = f"{'OV' if focus == 'ov' else focus} ({actor_kind(outcome, focus)})"
        dist, ttc = _closing(trace.ego, _rows(trace, focus))
        ax_gap.plot(times[: len(dist)], dist, color="#e53935", label=f"distance to {label} [m]")
        ax_gap.plot(
            times[: len(ttc)],
            [min(x, 30.0) for x in ttc],
            color="#8e24aa",
            ls="--",
            label=f"TTC to {label} [s]",
        )
        ax_gap.set_ylim(0, 30)
    for ax in (ax_speed, ax_gap):
        if outcome.aeb_fired and outcome.aeb_time is not None:
            ax.axvline(outcome.aeb_time, color="#fb8c00", lw=1, label="AEB fired")
        if outcome.collision_time is not None:
            ax.axvline(outcome.collision_time, color="black", lw=1.2, label="collision")
        ax.tick_params(labelsize=7)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="upper left")
    ax_speed.set_ylim(bottom=0)
    ax_gap.set_xlabel("time [s]", fontsize=8)
    return [ax.axvline(times[0], color="#424242", lw=0.8) for ax in (ax_speed, ax_gap)], label


def animate_run(db: str | Path, run_id: str, out: str | Path, **options: Any) -> Path:
    """Animate the stored run ``CAMPAIGN:INDEX`` of database ``db`` into ``out``.

    Options are those of :func:`animate_outcome`; the title names the run and its verdict.
    """
    from sitcov.campaign._console import existing_store
    from sitcov.campaign._replay import parse_run_id
    from sitcov.report._traces import close_builders, traced_outcome

    builders: dict = {}
    with existing_store(Path(db)) as store:
        campaign, index = parse_run_id(store, run_id)
        run = store.get_run(campaign, index, with_trace=False)
        if run.outcome is None:
            raise ConfigError(
                file=str(db),
                field="run",
                value=run_id,
                expected="a finished run (this one is pending)",
            )
        try:
            outcome = traced_outcome(store, run, builders)
        finally:
            close_builders(builders)
    title = f"{campaign}:{index}  {run.status} ({outcome.kind.replace('_', ' ')})  " + ", ".join(
        f"{k}={v}" for k, v in run.bins.items()
    )
    values = run.situation.to_dict()["values"]
    dashcam = run_dashcam(run.config, values, run.seed, outcome, boxes=True)
    try:
        from sitcov.report._road import road_drawing, run_road

        meta = outcome.trace.meta if outcome.trace else None
        road = road_drawing(run_road(run.config, meta, outcome.metrics))
        return animate_outcome(
            outcome, out, title=_wrap(title), dashcam=dashcam, road=road, **options
        )
    finally:
        if dashcam is not None:
            dashcam.close()


def run_dashcam(
    config: Any, values: dict[str, Any], seed: int, outcome: Outcome, *, boxes: bool
) -> Any:
    """The run's :class:`~sitcov.report._dashcam.DashCam` when its campaign (stored
    ``config``) ran with camera perception on the embedded backend, else None (PEM runs
    have no camera frames). ``values``: the run's situation values; ``seed``: its seed."""
    from sitcov.report._dashcam import DashCam, camera_mode

    config = dict(config or {})
    if config.get("backend", "embedded") != "embedded" or not camera_mode(config):
        return None
    if outcome.trace is None or not outcome.trace.ego:
        return None
    return DashCam(outcome, values, seed, boxes=boxes)


def _wrap(text: str, width: int = 110) -> str:
    import textwrap

    return "\n".join(textwrap.wrap(text, width)) or text
