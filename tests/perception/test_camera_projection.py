"""Pinhole projection of vehicle boxes: hand-computed geometry, symmetry, clipping."""

from __future__ import annotations

import math

import pytest

from sitcov.perception import ActorView, CameraSpec, Pose, project_box

CAM = CameraSpec()
F = 400.0 / math.tan(math.radians(50.0))  # focal length [px] for 800 px and 100 deg
CAR = dict(length=4.7, width=1.85, height=1.5)


def car(x: float, y: float, yaw: float) -> ActorView:
    return ActorView(Pose(x, y, yaw), **CAR)


def test_focal_length():
    assert CAM.focal_px == pytest.approx(F)


def test_car_straight_ahead_is_centred_with_pinhole_size():
    # Rear face 20 m in front of the camera, which sits 2.5 m ahead of the ego centre.
    d = 20.0
    p = project_box(CAM, Pose(0.0, 0.0, 0.0), car(2.5 + d + 2.35, 0.0, 0.0))
    assert p.visible and p.truncation == 0.0
    x0, y0, x1, y1 = p.box
    assert (x0 + x1) / 2 == pytest.approx(400.0)
    assert x1 - x0 == pytest.approx(F * 1.85 / d)
    assert y0 == pytest.approx(225.0 - F * (1.5 - 1.0) / d)  # roof above the camera
    assert y1 == pytest.approx(225.0 + F * 1.0 / d)  # road below it
    assert p.raw_box == p.box
    assert p.distance == pytest.approx(d + 2.35)
    assert p.bearing == pytest.approx(0.0)
    assert p.view_angle == pytest.approx(0.0)


def _corner_bounds(ego: Pose, actor: ActorView) -> tuple[float, float, float, float]:
    """Independent projection: all 8 corners through a 3x3 camera matrix (no clipping)."""
    cx, cy = ego.x + 2.5 * math.cos(ego.yaw), ego.y + 2.5 * math.sin(ego.yaw)
    us, vs = [], []
    for sl in (-1, 1):
        for sw in (-1, 1):
            for z in (0.0, actor.height):
                a = actor.pose
                px = (
                    a.x
                    + sl * actor.length / 2 * math.cos(a.yaw)
                    - sw * actor.width / 2 * math.sin(a.yaw)
                )
                py = (
                    a.y
                    + sl * actor.length / 2 * math.sin(a.yaw)
                    + sw * actor.width / 2 * math.cos(a.yaw)
                )
                fwd = (px - cx) * math.cos(ego.yaw) + (py - cy) * math.sin(ego.yaw)
                left = -(px - cx) * math.sin(ego.yaw) + (py - cy) * math.cos(ego.yaw)
                us.append(400.0 - F * left / fwd)
                vs.append(225.0 - F * (z - 1.0) / fwd)
    return min(us), min(vs), max(us), max(vs)


@pytest.mark.parametrize(
    "ego,actor",
    [
        (Pose(0.0, 0.0, 0.0), car(20.0, 6.0, math.pi / 2)),
        (Pose(0.0, 0.0, 0.0), car(15.0, -4.0, 2.5)),
        (Pose(-74.3, -50.0, -math.pi / 2), car(-70.0, -75.0, math.pi)),
        (Pose(10.0, 5.0, 1.0), car(20.0, 25.0, -0.3)),
    ],
)
def test_matches_an_independent_corner_projection(ego, actor):
    p = project_box(CAM, ego, actor)
    assert p.raw_box == pytest.approx(_corner_bounds(ego, actor))


def test_invariant_under_moving_the_whole_scene():
    base = project_box(CAM, Pose(0.0, 0.0, 0.0), car(18.0, 5.0, 2.0))
    th, tx, ty = 1.1, -30.0, 12.0

    def move(x, y):
        return (tx + x * math.cos(th) - y * math.sin(th), ty + x * math.sin(th) + y * math.cos(th))

    moved = project_box(CAM, Pose(tx, ty, th), car(*move(18.0, 5.0), 2.0 + th))
    assert moved.box == pytest.approx(base.box)
    assert moved.bearing == pytest.approx(base.bearing)
    assert moved.view_angle == pytest.approx(base.view_angle)


def test_left_right_mirror_and_bearing_sign():
    left = project_box(CAM, Pose(0.0, 0.0, 0.0), car(15.0, 4.0, 0.4))
    right = project_box(CAM, Pose(0.0, 0.0, 0.0), car(15.0, -4.0, -0.4))
    assert left.box[2] < 400.0 < right.box[0]  # left of the image centre / right of it
    assert left.box[0] == pytest.approx(800.0 - right.box[2])
    assert left.bearing == pytest.approx(math.atan2(4.0, 12.5)) and right.bearing < 0.0


@pytest.mark.parametrize(
    "yaw,expected",
    [(0.0, 0.0), (math.pi, 0.0), (math.pi / 2, math.pi / 2), (-math.pi / 2, math.pi / 2)],
)
def test_view_angle_is_folded(yaw, expected):
    p = project_box(CAM, Pose(0.0, 0.0, 0.0), car(30.0, 0.0, yaw))
    assert p.view_angle == pytest.approx(expected)


def test_behind_the_camera_is_none():
    assert project_box(CAM, Pose(0.0, 0.0, 0.0), car(-10.0, 0.0, 0.0)) is None
    assert project_box(CAM, Pose(0.0, 0.0, 0.0), car(0.0, 0.0, math.pi / 2)) is None


def test_outside_the_field_of_view_is_not_visible():
    # Bearing 70 deg to the left: beyond the 50 deg half field of view.
    p = project_box(CAM, Pose(0.0, 0.0, 0.0), car(2.5 + 10.0, 10.0 * math.tan(1.22), 0.0))
    assert p is not None and not p.visible
    x0, y0, x1, y1 = p.box
    assert 0.0 <= x0 <= x1 <= 800.0 and x1 - x0 == 0.0
    assert p.truncation == 1.0


def test_half_out_of_the_image_is_half_truncated():
    # Centre the box on the left image edge: the centre ray at bearing 50 deg.
    d = 12.0
    lateral = d * math.tan(math.radians(50.0))
    p = project_box(CAM, Pose(0.0, 0.0, 0.0), car(2.5 + d, lateral, math.pi / 2))
    raw = p.raw_box
    assert raw[0] < 0.0 < raw[2]
    assert p.box[0] == 0.0
    assert p.truncation == pytest.approx(-raw[0] / (raw[2] - raw[0]))
    assert 0.2 < p.truncation < 0.8


def test_near_plane_clipping_of_a_car_alongside():
    # A car crossing right in front of the bumper, straddling the camera plane.
    p = project_box(CAM, Pose(0.0, 0.0, 0.0), car(2.5, 2.0, 0.0))
    assert p is not None and p.visible
    assert p.box[0] == 0.0  # it fills the left of the image
    assert p.truncation > 0.5
    assert all(math.isfinite(v) for v in p.raw_box)
