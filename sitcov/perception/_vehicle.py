"""Vehicles for the dash-cam renderer: a car built from convex solids, drawn as polygons.

A car is a lower body with a sloping hood, a cabin frustum and four wheels, painted with
decals (windows, lights, plate, bumpers, round wheels and rims) and shaded per face by a
fixed sun (direct light fades with cloud). Faces are back-face culled, clipped at the near
plane, projected with the pinhole model of :func:`sitcov.perception.project_box` and sorted
far to near (painter's algorithm). Fog is applied per polygon by its mean distance.
Polygons are filled at 3x resolution in the vehicles' screen region and box-filtered
down, which anti-aliases the edges the detector keys on.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from PIL import Image, ImageDraw

from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.perception._camera import NEAR
from sitcov.weather import fog_transmittance

Vec3 = tuple[float, float, float]
Poly = tuple[list[tuple[float, float]], tuple[int, int, int]]

#: Default body colour of rendered vehicles (RGB).
BODY = (150, 30, 35)
GLASS = (38, 48, 60)
GLASS_SKY = (95, 110, 128)
TYRE = (20, 20, 22)
RIM = (135, 135, 140)
TAIL = (190, 25, 25)
HEAD = (240, 236, 215)
PLATE = (225, 225, 215)
TRIM = (38, 38, 42)
SHADOW = (26, 26, 28)
_ASPHALT = (92, 92, 96)  # the road colour of sitcov/perception/_texture.py
_DARK = (0, 0, 1)  # marker: the body colour, darkened (lower panels)
#: Direction towards the sun (world frame, unit vector).
SUN = (0.35 / 1.0, 0.45 / 1.0, 0.82 / 1.0)
_n = math.sqrt(sum(c * c for c in SUN))
SUN = (SUN[0] / _n, SUN[1] / _n, SUN[2] / _n)
#: Supersampling factor for the vehicles' region.
SUPERSAMPLE = 3

# Faces of an 8-vertex hexahedron (bottom 0-3, top 4-7) as (bottom-a, top-a, top-b,
# bottom-b), counter-clockwise seen from outside.
_FACES = (
    ((0, 4, 5, 1), "front"),
    ((2, 6, 7, 3), "rear"),
    ((3, 7, 4, 0), "left"),
    ((1, 5, 6, 2), "right"),
    ((4, 7, 6, 5), "top"),
)


def _solids(actor: ActorView) -> list[tuple[list[Vec3], str]]:
    """Convex solids of a car in its own frame (x forward, y left, z up) [m]."""
    L, W, H = actor.length, actor.width, actor.height
    hl, hw = 0.5 * L, 0.5 * W
    z0, z1 = 0.3, 0.6 * H
    hood = z1 - 0.1 * H
    body = [
        (hl, hw, z0), (hl, -hw, z0), (-hl, -hw, z0), (-hl, hw, z0),
        (hl, hw, hood), (hl, -hw, hood), (-hl, -hw, z1), (-hl, hw, z1),
    ]  # fmt: skip
    cb0, cb1, ct0, ct1 = -0.4 * L, 0.17 * L, -0.3 * L, 0.0
    wb, wt = 0.95 * hw, 0.8 * hw
    cabin = [
        (cb1, wb, z1), (cb1, -wb, z1), (cb0, -wb, z1), (cb0, wb, z1),
        (ct1, wt, H), (ct1, -wt, H), (ct0, -wt, H), (ct0, wt, H),
    ]  # fmt: skip
    return [(body, "body"), (cabin, "cabin")]


def _wheel_radius(actor: ActorView) -> float:
    return min(0.36, 0.24 * actor.height)


def _lerp(a: Vec3, b: Vec3, t: float) -> Vec3:
    return (a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t)


def _sub(quad: Sequence[Vec3], u0: float, u1: float, v0: float, v1: float) -> list[Vec3]:
    """The part [u0, u1] x [v0, v1] of a face (u along the bottom edge, v upwards)."""
    a0, a1, b1, b0 = quad

    def at(u: float, v: float) -> Vec3:
        return _lerp(_lerp(a0, b0, u), _lerp(a1, b1, u), v)

    return [at(u0, v0), at(u0, v1), at(u1, v1), at(u1, v0)]


def _circle(cx: float, y: float, cz: float, r: float, n: int = 14) -> list[Vec3]:
    return [
        (cx + r * math.cos(2 * math.pi * k / n), y, cz + r * math.sin(2 * math.pi * k / n))
        for k in range(n)
    ]


def _decals(kind: str, name: str, quad: Sequence[Vec3], actor: ActorView):
    """(polygon, colour, shaded) painted over a face, back to front."""
    out: list[tuple[list[Vec3], tuple[int, int, int], bool]] = []
    if kind == "body" and name in ("front", "rear"):
        out.append((_sub(quad, 0.0, 1.0, 0.8, 1.0), BODY, True))
    if kind == "cabin" and name in ("front", "rear"):
        out.append((_sub(quad, 0.05, 0.95, 0.06, 0.9), GLASS, True))
        out.append((_sub(quad, 0.05, 0.95, 0.6, 0.9), GLASS_SKY, True))
    elif kind == "cabin" and name in ("left", "right"):
        for u0, u1 in ((0.05, 0.47), (0.53, 0.95)):
            out.append((_sub(quad, u0, u1, 0.08, 0.88), GLASS, True))
            out.append((_sub(quad, u0, u1, 0.6, 0.88), GLASS_SKY, True))
    elif kind == "body" and name in ("front", "rear"):
        out.append((_sub(quad, 0.0, 1.0, 0.0, 0.25), TRIM, True))
        lamp = TAIL if name == "rear" else HEAD
        out.append((_sub(quad, 0.03, 0.22, 0.55, 0.85), lamp, False))
        out.append((_sub(quad, 0.78, 0.97, 0.55, 0.85), lamp, False))
        if name == "rear":
            out.append((_sub(quad, 0.38, 0.62, 0.3, 0.55), PLATE, False))
        else:
            out.append((_sub(quad, 0.28, 0.72, 0.38, 0.66), TRIM, True))
    elif kind == "body" and name in ("left", "right"):
        out.append((_sub(quad, 0.0, 1.0, 0.18, 0.5), _DARK, True))
        out.append((_sub(quad, 0.0, 1.0, 0.0, 0.18), TRIM, True))
        out.append((_sub(quad, 0.0, 1.0, 0.85, 1.0), BODY, True))
        r = _wheel_radius(actor)
        y = quad[0][1] + (0.01 if quad[0][1] > 0 else -0.01)
        for wx in (0.32 * actor.length, -0.32 * actor.length):
            out.append((_circle(wx, y, r, r * 1.12), TRIM, True))
            out.append((_circle(wx, y, r, r), TYRE, True))
            out.append((_circle(wx, y, r, r * 0.55), RIM, True))
    return out


def _tint(color: Sequence[float], k: float) -> tuple[int, int, int]:
    return (int(min(255, color[0] * k)), int(min(255, color[1] * k)), int(min(255, color[2] * k)))


def contact_shadow(cloud: float) -> tuple[float, float, float]:
    """The ground under the car: a hard, dark sun shadow in clear weather, a softer
    ambient-occlusion shade (half-way to lit asphalt) under a full overcast."""
    k = 0.5 * cloud
    return tuple(s * (1 - k) + 0.55 * a * k for s, a in zip(SHADOW, _ASPHALT, strict=True))  # type: ignore[return-value]


def _shade(color: Sequence[float], normal: Vec3, cloud: float) -> tuple[float, float, float]:
    lam = max(0.0, normal[0] * SUN[0] + normal[1] * SUN[1] + normal[2] * SUN[2])
    k = 0.5 + 0.6 * (1.0 - 0.8 * cloud) * lam + 0.15 * max(0.0, normal[2])
    return (min(255.0, color[0] * k), min(255.0, color[1] * k), min(255.0, color[2] * k))


def vehicle_polygons(
    camera: CameraSpec,
    ego: Pose,
    actor: ActorView,
    body_color: Sequence[int],
    weather: dict[str, float],
    fog_color: Sequence[float],
    far: float,
) -> list[Poly]:
    """Screen polygons (far to near) and their final colours for one vehicle."""
    c, s = math.cos(ego.yaw), math.sin(ego.yaw)
    cam_x, cam_y = ego.x + camera.mount_x * c, ego.y + camera.mount_x * s
    ap = actor.pose
    ac, as_ = math.cos(ap.yaw), math.sin(ap.yaw)
    if (ap.x - cam_x) * c + (ap.y - cam_y) * s < -actor.length:
        return []
    f, cx, cy = camera.focal_px, 0.5 * camera.width, 0.5 * camera.height
    beta, start, cloud = weather["beta"], weather["fog_start"], weather["cloud"]

    def to_cam(p: Vec3) -> Vec3:
        dx = ap.x + p[0] * ac - p[1] * as_ - cam_x
        dy = ap.y + p[0] * as_ + p[1] * ac - cam_y
        return (dx * c + dy * s, dx * s - dy * c, p[2] - camera.mount_z)

    def project(poly: Sequence[Vec3]):
        pts = _clip([to_cam(p) for p in poly])
        if len(pts) < 3:
            return None, 0.0
        d = sum(math.sqrt(p[0] ** 2 + p[1] ** 2) for p in pts) / len(pts)
        return [(cx + f * p[1] / p[0], cy - f * p[2] / p[0]) for p in pts], d

    def final(color: Sequence[float], dist: float) -> tuple[int, int, int]:
        t = fog_transmittance(beta, start, dist) if beta > 0 else 1.0
        t *= 1.0 - min(1.0, max(0.0, (dist - 0.5 * far) / (0.5 * far)))
        return tuple(int(color[k] * t + fog_color[k] * (1 - t)) for k in range(3))  # type: ignore[return-value]

    out: list[Poly] = []
    hl, hw = 0.5 * actor.length + 0.15, 0.5 * actor.width + 0.08
    pts, d = project([(hl, hw, 0.0), (hl, -hw, 0.0), (-hl, -hw, 0.0), (-hl, hw, 0.0)])
    if pts:
        out.append((pts, final(contact_shadow(cloud), d)))
    # Under-body darkness between the wheels (seen from any side below the sills).
    r = _wheel_radius(actor)
    ul, uw = 0.5 * actor.length - 0.1, 0.5 * actor.width - 0.05
    under = [(ul, uw, 0.0), (ul, -uw, 0.0), (-ul, -uw, 0.0), (-ul, uw, 0.0)]
    for a, b in ((0, 1), (1, 2), (2, 3), (3, 0)):
        wall = [under[a], (*under[a][:2], 0.32), (*under[b][:2], 0.32), under[b]]
        pts, d = project(wall)
        if pts:
            out.append((pts, final(TYRE, d)))
    for wx in (0.32 * actor.length, -0.32 * actor.length):
        for side in (1.0, -1.0):
            y = side * (uw + 0.03)
            blob = [(wx + r, y, 0.0), (wx - r, y, 0.0), (wx - r, y, 2 * r), (wx + r, y, 2 * r)]
            pts, d = project(blob)
            if pts:
                out.append((pts, final(TYRE, d)))
    faces = []
    for verts, kind in _solids(actor):
        for idx, name in _FACES:
            quad = [verts[i] for i in idx]
            nw, visible = _normal(quad, ap, ac, as_, (cam_x, cam_y, camera.mount_z))
            if not visible:
                continue
            pts, d = project(quad)
            if pts is None:
                continue
            faces.append((d, kind, name, quad, pts, nw))
    faces.sort(key=lambda x: -x[0])
    for d, kind, name, quad, pts, nw in faces:
        out.append((pts, final(_shade(body_color, nw, cloud), d)))
        for decal, color, shaded in _decals(kind, name, quad, actor):
            dp, dd = project(decal)
            if dp is not None:
                col = _shade(color, nw, cloud) if shaded else color
                if color is BODY:
                    col = _shade(_tint(body_color, 1.3), nw, cloud)
                elif color is _DARK:
                    col = _shade(_tint(body_color, 0.8), nw, cloud)
                out.append((dp, final(col, dd)))
    return out


def _normal(quad, ap: Pose, ac: float, as_: float, cam: Vec3) -> tuple[Vec3, bool]:
    """World normal of a face and whether it faces the camera."""
    a, b, c3 = quad[0], quad[1], quad[2]
    u = (b[0] - a[0], b[1] - a[1], b[2] - a[2])
    v = (c3[0] - a[0], c3[1] - a[1], c3[2] - a[2])
    n = (u[1] * v[2] - u[2] * v[1], u[2] * v[0] - u[0] * v[2], u[0] * v[1] - u[1] * v[0])
    ln = math.sqrt(n[0] ** 2 + n[1] ** 2 + n[2] ** 2) or 1.0
    n = (n[0] / ln, n[1] / ln, n[2] / ln)
    nw = (n[0] * ac - n[1] * as_, n[0] * as_ + n[1] * ac, n[2])
    ctr = [sum(p[k] for p in quad) / 4 for k in range(3)]
    wx = ap.x + ctr[0] * ac - ctr[1] * as_
    wy = ap.y + ctr[0] * as_ + ctr[1] * ac
    view = (cam[0] - wx, cam[1] - wy, cam[2] - ctr[2])
    return nw, nw[0] * view[0] + nw[1] * view[1] + nw[2] * view[2] > 0


def _clip(pts: list[Vec3]) -> list[Vec3]:
    """Sutherland-Hodgman clip of a camera-frame polygon to depth >= NEAR."""
    out: list[Vec3] = []
    n = len(pts)
    for i in range(n):
        a, b = pts[i], pts[(i + 1) % n]
        ina, inb = a[0] >= NEAR, b[0] >= NEAR
        if ina:
            out.append(a)
        if ina != inb:
            out.append(_lerp(a, b, (NEAR - a[0]) / (b[0] - a[0])))
    return out


def draw_supersampled(image: Image.Image, polys: list[Poly], factor: int = SUPERSAMPLE) -> None:
    """Fill ``polys`` into ``image`` in place, anti-aliased by supersampling their region.

    An entry ``(points, colour)`` is a filled polygon; ``(points, colour, width)`` with a
    width [px] is a closed outline of that width (a wheel's tyre).
    """
    xs = [x for item in polys for x, _ in item[0]]
    ys = [y for item in polys for _, y in item[0]]
    x0 = max(0, int(math.floor(min(xs))) - 1)
    y0 = max(0, int(math.floor(min(ys))) - 1)
    x1 = min(image.width, int(math.ceil(max(xs))) + 1)
    y1 = min(image.height, int(math.ceil(max(ys))) + 1)
    if x1 <= x0 or y1 <= y0:
        return
    region = image.crop((x0, y0, x1, y1))
    big = region.resize((region.width * factor, region.height * factor), Image.NEAREST)
    draw = ImageDraw.Draw(big)
    for item in polys:
        pts = [((x - x0) * factor, (y - y0) * factor) for x, y in item[0]]
        width = item[2] if len(item) > 2 else 0.0  # type: ignore[misc]
        if width > 0:
            draw.line([*pts, pts[0], pts[1]], fill=item[1], width=max(1, round(width * factor)),
                      joint="curve")  # fmt: skip
        else:
            draw.polygon(pts, fill=item[1])
    image.paste(big.reduce(factor), (x0, y0))
