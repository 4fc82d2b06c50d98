"""Is the detector's left/right asymmetry the renderer's sun or the detector? (docs/pem.md)

The PEM fails road users from the ego's left more often than the camera does
(``benchmarks/pem_side_check.py``). Two candidate causes: (a) the renderer lights cars with a
fixed sun (:data:`sitcov.perception._vehicle.SUN`), so a car showing its left side is lit
unlike one showing its right side; (b) the SSD detector is not mirror-symmetric. This renders
the same car poses (the ego at the start of each entry leg of the T-junction, so the sun
stands differently to the camera; distances, bearings, colours; each car seen showing its
left side, heading +90 or +135 deg from the line of sight, i.e. moving right-to-left in the
image, side-on or approaching, and the mirror pose showing its right side, -90 or -135 deg)
three ways, and scores the detection matching the projected box:

- ``as_is``: the frame as rendered;
- ``flipped``: the same frame mirrored left-right (``np.fliplr``; the box mirrored too). A
  mirror-symmetric detector gives every frame the same score: this tests (b);
- ``sun_mirrored``: rendered with the sun's lateral component (across the ego's heading)
  negated. If the sun is the cause, the left/right gap reverses: this tests (a).

A car that comes from the ego's left and crosses its path shows its right side (and front);
one from the right shows its left side.

    python benchmarks/bench_side_symmetry.py [--colors white,grey,red,black] [--json out.json]

Seeded (the renderer's only randomness is rain, absent here); prints a table and JSON.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from sitcov.calibration._camera_runs import match
from sitcov.perception import ActorView, CameraSpec, Pose, _vehicle, project_box, render_frame
from sitcov.perception._colors import PALETTE
from sitcov.weather import conditions_from_values

LEGS = ("B", "L", "R")
DISTANCES = (8.0, 12.0, 16.0, 20.0)
BEARINGS = (-15.0, 0.0, 15.0)
COLORS = ("white", "grey", "red", "black")
#: Heading of the car relative to the line of sight [deg] (side-on, approaching) per side
#: the camera sees.
SIDES = {"left side": (90.0, 135.0), "right side": (-90.0, -135.0)}
MODES = ("as_is", "flipped", "sun_mirrored")


def _mirrored_sun(ego_yaw: float) -> tuple[float, float, float]:
    """The sun reflected in the ego's vertical plane along its heading (lateral part negated)."""
    sx, sy, sz = _vehicle.SUN
    fx, fy = math.cos(ego_yaw), math.sin(ego_yaw)
    along = sx * fx + sy * fy
    lx, ly = -fy, fx  # the ego's left
    lat = sx * lx + sy * ly
    return (along * fx - lat * lx, along * fy - lat * ly, sz)


def _ego(leg: str) -> tuple[Pose, Any]:
    """The ego at the start of entry leg ``leg`` of the T-junction, and the road geometry."""
    from sitcov.sim.embedded._map import load_map

    jmap = load_map("t-junction")
    to = next(m.split("-")[1] for m in ("B-L", "L-R", "R-B") if m.startswith(leg))
    x, y, h = jmap.route(leg, to).point_at(0.0)
    return Pose(x, y, h), jmap.render_geometry()


def sun_light(yaw: float, cam_dx: float, cam_dy: float, sun: Sequence[float]) -> float:
    """The direct sun's Lambert shading of a car's vertical faces as the camera sees them:
    the mean over front, rear, left and right of ``max(0, n . sun)``, weighted by each face's
    visible area (``max(0, n . v)`` times its size, ``v`` the unit vector to the camera,
    ``(cam_dx, cam_dy)`` from the car) [-]; a 4.5 x 1.9 m car."""
    norm = math.hypot(cam_dx, cam_dy) or 1.0
    vx, vy = cam_dx / norm, cam_dy / norm
    c, s = math.cos(yaw), math.sin(yaw)
    total = weight = 0.0
    for nx, ny, size in ((c, s, 1.9), (-c, -s, 1.9), (-s, c, 4.5), (s, -c, 4.5)):
        w = max(0.0, nx * vx + ny * vy) * size
        total += w * max(0.0, nx * sun[0] + ny * sun[1])
        weight += w
    return total / weight if weight > 0.0 else 0.0


def side_scores(
    detector: Callable[[np.ndarray], Sequence[Any]],
    *,
    legs: Sequence[str] = LEGS,
    distances: Sequence[float] = DISTANCES,
    bearings: Sequence[float] = BEARINGS,
    colors: Sequence[str] = COLORS,
    seed: int = 0,
) -> list[dict[str, Any]]:
    """One row per (leg, colour, distance, bearing, side, heading): the matched score in
    each mode and the sun's shading of the car as seen (:func:`sun_light`), as is and with
    the sun mirrored."""
    cam = CameraSpec()
    cond = conditions_from_values({})
    egos = {leg: _ego(leg) for leg in legs}
    rows = []
    for leg, color, dist, bearing, (side, yaw_offs) in itertools.product(
        legs, colors, distances, bearings, SIDES.items()
    ):
        ego, geometry = egos[leg]
        cx = ego.x + cam.mount_x * math.cos(ego.yaw)
        cy = ego.y + cam.mount_x * math.sin(ego.yaw)
        sun, sun_m = _vehicle.SUN, _mirrored_sun(ego.yaw)
        rgb = PALETTE[color][0]
        for yaw_off in yaw_offs:
            los = ego.yaw + math.radians(bearing)
            pose = Pose(cx + dist * math.cos(los), cy + dist * math.sin(los),
                        los + math.radians(yaw_off))  # fmt: skip
            actor = ActorView(pose, 4.5, 1.9, 1.5, 0.0, rgb)
            proj = project_box(cam, ego, actor)
            if proj is None:
                continue
            box = proj.box
            img = render_frame(cam, ego, (actor,), cond, geometry, np.random.default_rng(seed))
            flipped_box = (cam.width - box[2], box[1], cam.width - box[0], box[3])
            flip = np.ascontiguousarray(np.fliplr(img))
            try:
                _vehicle.SUN = sun_m
                img_m = render_frame(cam, ego, (actor,), cond, geometry,
                                     np.random.default_rng(seed))  # fmt: skip
            finally:
                _vehicle.SUN = sun
            back = (cx - pose.x, cy - pose.y)
            rows.append({
                "leg": leg, "color": color, "distance": dist, "bearing": bearing,
                "side": side, "heading": yaw_off,
                "lit": sun_light(pose.yaw, *back, sun),
                "lit_mirrored": sun_light(pose.yaw, *back, sun_m),
                "as_is": match(box, detector(img))[0],
                "flipped": match(flipped_box, detector(flip))[0],
                "sun_mirrored": match(box, detector(img_m))[0],
            })  # fmt: skip
    return rows


def summary(rows: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """Per mode and side: mean score and share >= 0.5; the left-minus-right gaps; and the
    mean absolute per-frame score change of each mode against ``as_is``."""
    out: dict[str, Any] = {"frames": len(rows), "modes": {}}
    for mode in MODES:
        per = {}
        for side in SIDES:
            s = np.asarray([r[mode] for r in rows if r["side"] == side])
            per[side] = {"mean": float(s.mean()), "p05": float((s >= 0.5).mean()), "n": int(s.size)}
        per["gap_mean"] = per["left side"]["mean"] - per["right side"]["mean"]
        per["gap_p05"] = per["left side"]["p05"] - per["right side"]["p05"]
        per["mean_abs_change"] = float(np.mean([abs(r[mode] - r["as_is"]) for r in rows]))
        out["modes"][mode] = per
    # the sun's effect: score change against the change of the sun's shading as seen
    d_lit = np.asarray([r["lit_mirrored"] - r["lit"] for r in rows])
    d_score = np.asarray([r["sun_mirrored"] - r["as_is"] for r in rows])
    moved = np.abs(d_lit) > 0.05
    out["sun"] = {
        "frames_whose_shading_changes": int(moved.sum()),
        "mean_abs_change_there": float(np.abs(d_score[moved]).mean()) if moved.any() else 0.0,
        "score_per_unit_shading": float(np.polyfit(d_lit, d_score, 1)[0]) if moved.any() else 0.0,
        "correlation": float(np.corrcoef(d_lit, d_score)[0, 1]) if moved.any() else 0.0,
    }
    lit = np.asarray([r["lit"] for r in rows])
    out["lit_by_side"] = {
        side: float(np.mean([r["lit"] for r in rows if r["side"] == side])) for side in SIDES
    }
    out["lit_range"] = [float(lit.min()), float(lit.max())]
    return out


def table(s: dict[str, Any]) -> str:
    lines = [f"{s['frames']} frames (cars, clear noon)",
             f"{'mode':>13} {'left side':>16} {'right side':>16} {'gap L-R':>14} {'|change|':>9}",
             f"{'':>13} {'mean  >=0.5':>16} {'mean  >=0.5':>16} {'mean  >=0.5':>14}"]  # fmt: skip
    for mode, m in s["modes"].items():
        lft, rgt = m["left side"], m["right side"]
        lines.append(
            f"{mode:>13} {lft['mean']:8.3f} {lft['p05']:6.2f}  {rgt['mean']:8.3f} {rgt['p05']:6.2f}"
            f"  {m['gap_mean']:+7.3f} {m['gap_p05']:+5.2f} {m['mean_abs_change']:9.3f}"
        )
    sun = s["sun"]
    lines.append(
        f"sun mirrored: {sun['frames_whose_shading_changes']} frames whose seen shading changes"
        f" by > 0.05, mean |score change| there {sun['mean_abs_change_there']:.3f}; score per"
        f" unit of shading {sun['score_per_unit_shading']:+.3f} (r = {sun['correlation']:+.2f})"
    )
    return "\n".join(lines)


def main() -> None:
    from sitcov.perception import SSDDetector

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--colors", default=",".join(COLORS), help="palette colours")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json", default=None, help="also write the rows and summary here")
    args = parser.parse_args()
    rows = side_scores(SSDDetector(min_score=0.05), colors=args.colors.split(","), seed=args.seed)
    s = summary(rows)
    print(table(s))
    print(json.dumps(s, indent=1))
    if args.json:
        with open(args.json, "w") as fh:
            json.dump({"summary": s, "rows": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
