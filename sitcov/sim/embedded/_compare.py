"""Two junction maps side by side: legs, spawns, goals, routes and conflict points in metres.

Both maps are placed in one frame: a map imported from OpenDRIVE (``layout: lanes``) at the
place its ``frame`` records (the file's coordinates), any other map at ``at`` (x, y [m],
rotation [deg]), e.g. the shipped t-junction at the point of Town03 it copies. Written for
``sitcov map compare`` (``docs/roads.md``: the paper's junction from the paper's map).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from sitcov.sim._adversary import PAPER_INTSITS, TOWN03_CONFLICT_POINTS
from sitcov.sim.embedded._map import JunctionMap
from sitcov.sim.embedded._path import Path


def placement(
    jmap: JunctionMap, at: tuple[float, float, float] | None
) -> tuple[float, float, float]:
    """Where the map's frame lies in the common frame: (x, y [m], rotation [deg])."""
    if at is not None:
        return at
    frame = getattr(jmap, "frame", None) or {}
    if "origin" in frame:
        # map = R(rot) (file - origin)  =>  file = R(-rot) map + origin
        return float(frame["origin"][0]), float(frame["origin"][1]), -float(frame["rotation_deg"])
    return 0.0, 0.0, 0.0


def _place(points: np.ndarray, where: tuple[float, float, float]) -> np.ndarray:
    x, y, deg = where
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    return np.column_stack([c * p[:, 0] - s * p[:, 1] + x, s * p[:, 0] + c * p[:, 1] + y])


def _deviation(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Mean and max distance from the points of ``a`` to the polyline ``b`` (dense) [m]."""
    d = np.hypot(a[:, None, 0] - b[None, :, 0], a[:, None, 1] - b[None, :, 1]).min(axis=1)
    return float(d.mean()), float(d.max())


def _dense(path: Path, where: tuple[float, float, float]) -> np.ndarray:
    return _place(np.asarray(path.resampled(0.1)), where)


def compare_maps(
    a: JunctionMap,
    b: JunctionMap,
    at_a: tuple[float, float, float] | None = None,
    at_b: tuple[float, float, float] | None = None,
) -> dict[str, Any]:
    """Differences between two maps in metres (degrees for headings), in a common frame.

    Keys: ``frames`` (where each map was placed), ``legs`` (per shared leg: outward
    heading difference, mouths), ``spawns`` (ego and OV spawn points per shared entry leg:
    distance), ``goals`` (the ego's goal per shared exit leg), ``routes`` (per shared
    movement, the ego's route from spawn to goal: lengths and the mean/max distance of
    A's route from B's), ``conflicts`` (per paper situation "EGO/OV" both maps have: the
    conflict point of each, their distance, and each one's distance to the paper's Town03
    conflict point of that situation, given in CARLA coordinates (x, -y of the frame)).
    """
    pa, pb = placement(a, at_a), placement(b, at_b)
    out: dict[str, Any] = {
        "maps": [a.name, b.name],
        "frames": {"a": list(pa), "b": list(pb)},
        "legs": {},
        "spawns": {},
        "goals": {},
        "routes": {},
        "conflicts": {},
    }
    for name in sorted(set(a.legs) & set(b.legs)):
        la, lb = a.legs[name], b.legs[name]
        ha, hb = la.heading + math.radians(pa[2]), lb.heading + math.radians(pb[2])
        out["legs"][name] = {
            "heading_diff_deg": round(math.degrees(math.remainder(ha - hb, math.tau)), 2),
            "mouth_a": round(la.mouth, 2),
            "mouth_b": round(lb.mouth, 2),
        }
    moves = sorted(set(a.movements) & set(b.movements))
    for move in moves:
        ra, rb = a.ego_path(move), b.ego_path(move)
        pts_a, pts_b = _dense(ra, pa), _dense(rb, pb)
        mean, worst = _deviation(pts_a[::10], pts_b)
        out["routes"][move] = {
            "length_a": round(ra.length, 2),
            "length_b": round(rb.length, 2),
            "mean": round(mean, 2),
            "max": round(worst, 2),
        }
        leg_in, leg_out = move.split("-")
        out["spawns"].setdefault(leg_in, {})["ego"] = round(
            float(np.hypot(*(pts_a[0] - pts_b[0]))), 2
        )
        out["goals"][leg_out] = round(float(np.hypot(*(pts_a[-1] - pts_b[-1]))), 2)
        oa, ob = (
            _place(np.asarray(a.ov_path(move).points[:1]), pa),
            _place(np.asarray(b.ov_path(move).points[:1]), pb),
        )
        out["spawns"][leg_in]["ov"] = round(float(np.hypot(*(oa[0] - ob[0]))), 2)
    for (ego, ov), label in PAPER_INTSITS.items():
        if not {ego, ov} <= set(moves):
            continue
        ca, cb = a.scenario(ego, ov).conflict, b.scenario(ego, ov).conflict
        if ca is None or cb is None:
            out["conflicts"][f"{ego}/{ov}"] = {
                "label": label,
                "a": ca is not None,
                "b": cb is not None,
            }
            continue
        qa, qb = _place(np.array(ca.point), pa)[0], _place(np.array(cb.point), pb)[0]
        cx, cy = TOWN03_CONFLICT_POINTS[label]
        paper = np.array([cx, -cy])  # CARLA (x, y) -> the maps' right-handed frame (x, -y)
        out["conflicts"][f"{ego}/{ov}"] = {
            "label": label,
            "a": [round(float(v), 2) for v in qa],
            "b": [round(float(v), 2) for v in qb],
            "distance": round(float(np.hypot(*(qa - qb))), 2),
            "a_to_paper": round(float(np.hypot(*(qa - paper))), 2),
            "b_to_paper": round(float(np.hypot(*(qb - paper))), 2),
        }
    return out


def comparison_text(result: dict[str, Any]) -> str:
    """The comparison as plain text, one line per item (metres, degrees)."""
    a, b = result["maps"]
    lines = [
        f"A = {a} placed at {result['frames']['a']}, B = {b} placed at {result['frames']['b']}"
    ]
    for name, leg in result["legs"].items():
        lines.append(
            f"leg {name}: heading A-B {leg['heading_diff_deg']:+.2f} deg, "
            f"mouth A {leg['mouth_a']:.2f} m, B {leg['mouth_b']:.2f} m"
        )
    for name, sp in result["spawns"].items():
        lines.append(f"spawn {name}: ego {sp['ego']:.2f} m apart, OV {sp['ov']:.2f} m apart")
    for name, d in result["goals"].items():
        lines.append(f"goal {name}: {d:.2f} m apart")
    for move, r in result["routes"].items():
        lines.append(
            f"route {move}: length A {r['length_a']:.1f} m, B {r['length_b']:.1f} m; A from B mean "
            f"{r['mean']:.2f} m, max {r['max']:.2f} m"
        )
    for key, c in result["conflicts"].items():
        if "distance" not in c:
            lines.append(f"conflict {key} ({c['label']}): only on {'A' if c['a'] else 'B'}")
            continue
        lines.append(
            f"conflict {key} ({c['label']}): A {tuple(c['a'])}, B {tuple(c['b'])}: "
            f"{c['distance']:.2f} m apart; to the paper's {c['label']}: "
            f"A {c['a_to_paper']:.2f} m, B {c['b_to_paper']:.2f} m"
        )
    return "\n".join(lines) + "\n"
