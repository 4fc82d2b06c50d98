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
from math import atan2, cos, sin
from typing import Any

from sitcov.perception._base import ActorView, CameraSpec, Pose

#: Near clipping plane [m]: points closer to the camera plane are cut away.
NEAR = 0.1

#: ``math.hypot`` under the name :func:`_project` uses (``_jit.py`` binds the name to its
#: correctly rounded version when it compiles that code: the same bits).
hypot = math.hypot


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
    """:func:`project_box` as a plain tuple in :class:`Projection`'s field order (faster).

    The arithmetic is :func:`_project` (compiled by numba when it is installed, the same
    bits, see ``sitcov/_jit.py``).
    """
    ap = actor.pose
    ok, bx0, by0, bx1, by1, u0, v0, u1, v1, trunc, dist, bearing, view, visible, facing = (
        _PROJECT or _kernel()
    )(
        ego_pose.x, ego_pose.y, ego_pose.yaw, ap.x, ap.y, ap.yaw, actor.length, actor.width,
        actor.height, camera.mount_x, camera.mount_z, camera.focal_px, float(camera.width),
        float(camera.height),
    )  # fmt: skip
    if not ok:
        return None
    return ((bx0, by0, bx1, by1), (u0, v0, u1, v1), trunc, dist, bearing, view, visible, facing)


def _project(
    ex: float,
    ey: float,
    eyaw: float,
    ax: float,
    ay: float,
    ayaw: float,
    length: float,
    width: float,
    height: float,
    mount_x: float,
    mount_z: float,
    f: float,
    w: float,
    h: float,
) -> tuple:
    """The projection's arithmetic on plain floats: (ok, clipped box, raw box, truncation,
    distance, bearing, view angle, visible, facing); ok is False (and the rest zeros) when
    the whole box lies behind the near plane."""
    c, s = cos(eyaw), sin(eyaw)
    cam_x = ex + mount_x * c
    cam_y = ey + mount_x * s
    ac, as_ = cos(ayaw), sin(ayaw)
    # Actor centre and half-axes in camera coordinates: depth along the heading, "right".
    dx, dy = ax - cam_x, ay - cam_y
    d_c, r_c = dx * c + dy * s, dx * s - dy * c
    hl, hw = 0.5 * length, 0.5 * width
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
        if len(pts) == 0:
            return (False, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, False, 0.0)
    cx, cy = 0.5 * w, 0.5 * h
    depth, right = pts[0]
    u0 = u1 = cx + f * right / depth
    d_min = d_max = depth  # d_max starts at 0 and depth >= NEAR > 0: the same maximum
    for k in range(1, len(pts)):
        depth, right = pts[k]
        u = cx + f * right / depth
        if u < u0:
            u0 = u
        elif u > u1:
            u1 = u
        if depth < d_min:
            d_min = depth
        if depth > d_max:
            d_max = depth
    top = height - mount_z  # roof above the camera [m]
    v0 = cy - f * top / (d_min if top > 0.0 else d_max)
    v1 = cy + f * mount_z / (d_min if mount_z > 0.0 else d_max)
    # Clamping each coordinate keeps the order, so an off-image box collapses to an edge
    # (min(max(u, 0), w) written out: no builtin calls in this per-frame path).
    bx0 = 0.0 if u0 < 0.0 else (w if u0 > w else u0)
    bx1 = 0.0 if u1 < 0.0 else (w if u1 > w else u1)
    by0 = 0.0 if v0 < 0.0 else (h if v0 > h else v0)
    by1 = 0.0 if v1 < 0.0 else (h if v1 > h else v1)
    visible = bx1 > bx0 and by1 > by0
    raw_area = (u1 - u0) * (v1 - v0)
    truncation = 1.0 - (bx1 - bx0) * (by1 - by0) / raw_area if raw_area > 0.0 else 1.0
    los = atan2(dy, dx)
    return (
        True,
        bx0,
        by0,
        bx1,
        by1,
        u0,
        v0,
        u1,
        v1,
        (1.0 if truncation >= 1.0 else truncation) if truncation > 0.0 else 0.0,
        hypot(dx, dy),
        atan2(-r_c, d_c),
        _view_angle(ayaw - los),
        visible,
        cos(ayaw - los),
    )


def _view_angle(rel: float) -> float:
    """The view angle [rad] for the actor's heading ``rel`` relative to the line of sight:
    ``abs(math.remainder(rel, tau))`` folded to [0, pi/2] (0 rear or front, pi/2 side-on).

    ``math.remainder`` (which numba lacks) is written out as CPython computes it: the
    exact ``fmod`` (Python's ``%`` of two non-negative floats, numba's too) and the
    rounding of the remainder to the nearer multiple, ties to even; only its magnitude
    is needed, so the sign is dropped. The same bits as ``math.remainder`` for every
    finite ``rel`` (``tests/sim/test_sim_jit.py``).
    """
    x = abs(rel)
    m = x % _TAU
    c = _TAU - m
    if m < c:
        r = m
    elif m > c:
        r = c
    else:  # halfway: the multiple with an even quotient
        r = abs(m - 2.0 * ((0.5 * (x - m)) % _TAU))
    return math.pi - r if r > 0.5 * math.pi else r


_TAU = math.tau
_PROJECT: Any = None


def _kernel() -> Any:
    """:func:`_project` compiled by numba when it is installed, else itself (loaded once)."""
    global _PROJECT
    if _PROJECT is None:
        from sitcov._jit import compiled

        example = (0.0, 0.0, 0.0, 10.0, 1.0, 0.3, 4.6, 1.8, 1.5, 1.5, 1.3, 800.0, 640.0, 480.0)
        helpers = (_clip_near, _view_angle)  # _clip_near makes a list: numba's NRT
        _PROJECT = compiled(_project, *example, helpers=helpers, nrt=True) or _project
    return _PROJECT
