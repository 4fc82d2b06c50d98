"""Pinhole projection of another vehicle's 3-D box into the ego's dash-cam image.

Camera frame: the camera sits ``mount_x`` ahead of the ego centre along its heading and
``mount_z`` above the road, looking along the heading with no pitch or roll. Image x grows
to the right, y downwards, the principal point is the image centre, and the focal length
[px] follows from the horizontal field of view (square pixels).

The actor is a box from the road up to its height over its footprint. Since the camera
has no pitch, a vertical edge has one depth, so near-plane clipping reduces to clipping the
2-D footprint polygon against ``depth >= NEAR``; every clipped footprint vertex then gives
two image points (bottom and top). Plain floats and ``math``: this runs every frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sitcov.perception._base import ActorView, CameraSpec, Pose

#: Near clipping plane [m]: points closer to the camera plane are cut away.
NEAR = 0.1


@dataclass(frozen=True)
class Projection:
    """An actor as the camera sees it.

    Attributes:
        box: (x0, y0, x1, y1) [px], clipped to the image (zero-area when not visible).
        raw_box: the same box before clipping to the image [px].
        truncation: fraction of ``raw_box``'s area outside the image, in [0, 1].
        distance: planar distance from the camera to the actor's centre [m].
        bearing: direction of the actor's centre seen from the camera, relative to the
            camera axis [rad], positive to the left (counter-clockwise).
        view_angle: angle between the actor's heading and the line of sight, folded to
            [0, pi/2]: 0 = seen from the rear or front, pi/2 = seen side-on [rad].
        visible: whether any part of the box lies inside the image.
        facing: cosine of the actor's heading relative to the line of sight: +1 seen from
            the rear (driving away), -1 seen from the front (coming closer), 0 side-on [-].
    """

    box: tuple[float, float, float, float]
    raw_box: tuple[float, float, float, float]
    truncation: float
    distance: float
    bearing: float
    view_angle: float
    visible: bool
    facing: float = 0.0

    @property
    def width(self) -> float:
        """Width of the clipped box [px]."""
        return self.box[2] - self.box[0]

    @property
    def height(self) -> float:
        """Height of the clipped box [px]."""
        return self.box[3] - self.box[1]


def _clip_near(pts: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Sutherland-Hodgman clip of a polygon of (depth, right) points to depth >= NEAR."""
    out: list[tuple[float, float]] = []
    n = len(pts)
    for i in range(n):
        d0, r0 = pts[i]
        d1, r1 = pts[(i + 1) % n]
        in0, in1 = d0 >= NEAR, d1 >= NEAR
        if in0:
            out.append((d0, r0))
        if in0 != in1:
            s = (NEAR - d0) / (d1 - d0)
            out.append((NEAR, r0 + s * (r1 - r0)))
    return out


def project_box(camera: CameraSpec, ego_pose: Pose, actor: ActorView) -> Projection | None:
    """Project ``actor``'s 3-D box into ``camera`` mounted on the ego at ``ego_pose``.

    Returns:
        The projection, or None when the whole box lies behind the near plane.
    """
    raw = project_raw(camera, ego_pose, actor)
    if raw is None:
        return None
    return Projection(*raw)


def project_raw(camera: CameraSpec, ego_pose: Pose, actor: ActorView) -> tuple | None:
    """:func:`project_box` as a plain tuple in :class:`Projection`'s field order (faster)."""
    c, s = math.cos(ego_pose.yaw), math.sin(ego_pose.yaw)
    cam_x = ego_pose.x + camera.mount_x * c
    cam_y = ego_pose.y + camera.mount_x * s
    ap = actor.pose
    ac, as_ = math.cos(ap.yaw), math.sin(ap.yaw)
    # Actor centre and half-axes in camera coordinates: depth along the heading, "right".
    dx, dy = ap.x - cam_x, ap.y - cam_y
    d_c, r_c = dx * c + dy * s, dx * s - dy * c
    hl, hw = 0.5 * actor.length, 0.5 * actor.width
    d_l, r_l = hl * (ac * c + as_ * s), hl * (ac * s - as_ * c)  # +length/2 along the actor
    d_w, r_w = hw * (ac * s - as_ * c), -hw * (ac * c + as_ * s)  # +width/2 (its left)
    pts = [
        (d_c + d_l + d_w, r_c + r_l + r_w),
        (d_c + d_l - d_w, r_c + r_l - r_w),
        (d_c - d_l - d_w, r_c - r_l - r_w),
        (d_c - d_l + d_w, r_c - r_l + r_w),
    ]
    if abs(d_l) + abs(d_w) > d_c - NEAR:  # some corner is in front of the near plane
        pts = _clip_near(pts)
        if not pts:
            return None
    f = camera.focal_px
    w, h = float(camera.width), float(camera.height)
    cx, cy = 0.5 * w, 0.5 * h
    u0 = u1 = None
    d_min, d_max = math.inf, 0.0
    for depth, right in pts:
        u = cx + f * right / depth
        if u0 is None:
            u0 = u1 = u
        elif u < u0:
            u0 = u
        elif u > u1:
            u1 = u
        if depth < d_min:
            d_min = depth
        if depth > d_max:
            d_max = depth
    top = actor.height - camera.mount_z  # roof above the camera [m]
    v0 = cy - f * top / (d_min if top > 0.0 else d_max)
    v1 = cy + f * camera.mount_z / (d_min if camera.mount_z > 0.0 else d_max)
    # Clamping each coordinate keeps the order, so an off-image box collapses to an edge
    # (min(max(u, 0), w) written out: no builtin calls in this per-frame path).
    bx0 = 0.0 if u0 < 0.0 else (w if u0 > w else u0)
    bx1 = 0.0 if u1 < 0.0 else (w if u1 > w else u1)
    by0 = 0.0 if v0 < 0.0 else (h if v0 > h else v0)
    by1 = 0.0 if v1 < 0.0 else (h if v1 > h else v1)
    visible = bx1 > bx0 and by1 > by0
    raw_area = (u1 - u0) * (v1 - v0)
    truncation = 1.0 - (bx1 - bx0) * (by1 - by0) / raw_area if raw_area > 0.0 else 1.0
    los = math.atan2(dy, dx)
    facing = math.cos(ap.yaw - los)
    view = abs(math.remainder(ap.yaw - los, math.tau))
    if view > 0.5 * math.pi:
        view = math.pi - view
    return (
        (bx0, by0, bx1, by1),
        (u0, v0, u1, v1),
        (1.0 if truncation >= 1.0 else truncation) if truncation > 0.0 else 0.0,
        math.hypot(dx, dy),
        math.atan2(-r_c, d_c),
        view,
        visible,
        facing,
    )
