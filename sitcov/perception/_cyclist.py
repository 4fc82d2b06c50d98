"""Cyclists for the dash-cam renderer: a bicycle (two wheels, frame, bars) with a rider.

The bicycle lies along the actor's length: wheels are circles in the bike's vertical plane,
drawn as thick rings (a tyre) around a thin rim, so from the side they are round and from
behind thin; frame tubes, fork, bars and saddle are thin capsules. The rider is the
pedestrian body of :mod:`sitcov.perception._person`, seated: hips on the saddle, torso
leaning to the bars, hands on the grips, feet on pedals that turn with the distance
ridden (so the legs move as the cyclist rides). All parts go through the same sphere-hull
projection, fog and depth sort as pedestrians.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._person import (
    ActorFrame,
    Poly,
    Sphere,
    Vec3,
    appearance,
    parts_polygons,
    shadow_polygon,
)

#: Bicycle frame colours (RGB), picked like the rider's clothes.
FRAMES = ((20, 20, 22), (180, 30, 30), (30, 60, 150), (200, 200, 205), (40, 110, 60))
TYRE = (18, 18, 20)
METAL = (150, 150, 155)
#: Distance ridden per crank turn [m] (a mid gear).
PER_CRANK_TURN = 4.5


def _knee(hip: Vec3, foot: Vec3, thigh: float, shin: float) -> Vec3:
    """Knee of a two-link leg from hip to foot, bent forward (+x), in the x-z plane."""
    dx, dz = foot[0] - hip[0], foot[2] - hip[2]
    d = min(math.hypot(dx, dz), thigh + shin - 1e-6)
    a = math.acos(max(-1.0, min(1.0, (thigh**2 + d**2 - shin**2) / (2 * thigh * d))))
    base = math.atan2(dz, dx)
    ang = base + a  # rotate towards +z/+x: the knee points forward and up
    return (hip[0] + thigh * math.cos(ang), hip[1], hip[2] + thigh * math.sin(ang))


def bike_geometry(length: float) -> dict[str, Vec3]:
    """Key points of the bicycle in the actor frame [m] (x forward, z up)."""
    k = length / 1.8
    r = 0.34 * k
    return {
        "rear": (-0.52 * k, 0.0, r), "front": (0.52 * k, 0.0, r), "bb": (0.0, 0.0, 0.3 * k),
        "seat": (-0.17 * k, 0.0, 0.9 * k), "head": (0.38 * k, 0.0, 0.92 * k),
        "bars": (0.36 * k, 0.0, 1.0 * k), "radius": (r, 0.0, 0.0),
    }  # fmt: skip


def _wheel_ring(frame: ActorFrame, centre: Vec3, r: float, near: float, n: int = 20):
    """Screen points of a wheel's circle and its mean distance (None when behind)."""
    qs = [
        frame.to_cam((centre[0] + r * math.cos(2 * math.pi * i / n), 0.0,
                      centre[2] + r * math.sin(2 * math.pi * i / n)))
        for i in range(n)
    ]  # fmt: skip
    if min(q[0] for q in qs) < near:
        return None
    d = sum(math.hypot(q[0], q[1]) for q in qs) / n
    return [frame.screen(q) for q in qs], d


def bike_parts(
    b: dict[str, Vec3], color: tuple[int, int, int]
) -> list[tuple[list[Sphere], tuple[int, int, int]]]:
    """Frame tubes, fork, saddle and handlebar as capsules."""
    t = 0.025
    tubes = [("rear", "bb"), ("rear", "seat"), ("bb", "seat"), ("bb", "head"), ("seat", "head")]
    parts = [([(b[a], t), (b[c], t)], color) for a, c in tubes]
    parts.append(([(b["head"], t), (b["front"], t)], METAL))
    parts.append(([(b["head"], t), (b["bars"], t)], METAL))
    bx, _, bz = b["bars"]
    parts.append(([((bx, 0.27, bz), 0.02), ((bx, -0.27, bz), 0.02)], TYRE))
    sx, _, sz = b["seat"]
    parts.append(([((sx - 0.08, 0.0, sz + 0.03), 0.04), ((sx + 0.1, 0.0, sz + 0.03), 0.03)], TYRE))
    return parts


def rider_parts(
    actor: ActorView, b: dict[str, Vec3], phase: float
) -> list[tuple[list[Sphere], tuple[int, int, int]]]:
    """The seated rider: legs to the pedals, torso leaning to the bars, arms to the grips."""
    s = actor.height / 1.7
    col = appearance(actor)
    sx, _, sz = b["seat"]
    bx, _, bz = b["bars"]
    hip_z = sz + 0.08
    sh_x, sh_z = sx + 0.32 * s, actor.height - 0.32 * s  # the hair's top at the box top
    crank = 0.17
    parts: list[tuple[list[Sphere], tuple[int, int, int]]] = []
    for sign, ph in ((1.0, phase), (-1.0, phase + math.pi)):
        y = sign * 0.11
        hip = (sx, y, hip_z)
        foot = (b["bb"][0] + crank * math.cos(ph), y, b["bb"][2] + crank * math.sin(ph))
        knee = _knee(hip, foot, 0.45 * s, 0.47 * s)
        sh = (sh_x, sign * 0.19 * s, sh_z)
        grip = (bx - 0.02, sign * 0.24, bz + 0.02)
        elbow = ((sh[0] + grip[0]) / 2 - 0.02, sign * 0.23, (sh[2] + grip[2]) / 2 - 0.06)
        parts += [
            ([(hip, 0.09 * s), (knee, 0.07 * s)], col["trousers"]),
            ([(knee, 0.065 * s), (foot, 0.05 * s)], col["trousers"]),
            ([(foot, 0.05 * s), ((foot[0] + 0.14, y, foot[2]), 0.04 * s)], col["shoe"]),
            ([(sh, 0.06 * s), (elbow, 0.05 * s)], col["shirt"]),
            ([(elbow, 0.045 * s), (grip, 0.04 * s)], col["skin"]),
        ]
    torso = [
        ((sh_x, 0.15 * s, sh_z - 0.02), 0.09 * s), ((sh_x, -0.15 * s, sh_z - 0.02), 0.09 * s),
        ((sx, 0.09 * s, hip_z + 0.05), 0.1 * s), ((sx, -0.09 * s, hip_z + 0.05), 0.1 * s),
    ]  # fmt: skip
    head = (sh_x + 0.1 * s, 0.0, sh_z + 0.17 * s)
    parts += [
        (torso, col["shirt"]),
        ([((sh_x + 0.02, 0.0, sh_z + 0.05), 0.05 * s), (head, 0.05 * s)], col["skin"]),
        ([(head, 0.11 * s)], col["skin"]),
        ([((head[0] - 0.02, 0.0, head[2] + 0.035 * s), 0.105 * s)], col["hair"]),
    ]
    return parts


def cyclist_polygons(
    camera: CameraSpec,
    ego: Pose,
    actor: ActorView,
    weather: dict[str, float],
    fog_color: Sequence[float],
    far: float,
    shadow: Callable[[float], Sequence[float]],
    near: float,
) -> list[Poly]:
    """Screen polygons (far to near) and final colours for one cyclist; wheels are rings
    (a polygon with a trailing outline width, see :func:`draw_supersampled`)."""
    frame = ActorFrame(camera, ego, actor, weather, fog_color, far)
    if frame.to_cam((0.0, 0.0, 0.0))[0] < -actor.length:
        return []
    b = bike_geometry(actor.length)
    p = actor.pose
    phase = 2 * math.pi * (p.x * math.cos(p.yaw) + p.y * math.sin(p.yaw)) / PER_CRANK_TURN
    h = appearance(actor)["hair"][0] + round(actor.height * 100)
    frame_col = FRAMES[h % len(FRAMES)]
    cloud = weather["cloud"]
    items: list[tuple[float, list[tuple[float, float]], tuple[int, int, int], float]] = []
    for d, pts, col in parts_polygons(
        frame, bike_parts(b, frame_col) + rider_parts(actor, b, phase), cloud, near
    ):
        items.append((d, pts, col, 0.0))
    r = b["radius"][0]
    for hub in (b["rear"], b["front"]):
        ring = _wheel_ring(frame, hub, r, near)
        if ring is None:
            continue
        pts, d = ring
        depth = frame.to_cam(hub)[0]
        width = max(1.0, camera.focal_px * 0.05 / depth)
        items.append((d + 0.05, pts, frame.final(TYRE, d), width))
        inner = _wheel_ring(frame, hub, r - 0.05, near)
        if inner is not None:
            items.append((d + 0.04, inner[0], frame.final(METAL, d), max(1.0, 0.3 * width)))
    items.sort(key=lambda x: -x[0])
    out: list[Poly] = []
    sh = shadow_polygon(frame, 0.5 * actor.length, 0.3, shadow(cloud), near)
    if sh is not None:
        out.append(sh)
    for _, pts, col, width in items:
        out.append((pts, col, width) if width > 0 else (pts, col))  # type: ignore[arg-type]
    return out
