"""Pedestrians for the dash-cam renderer: an articulated body of rounded parts.

A person is a skeleton of joints (hips, knees, ankles, shoulders, elbows, wrists, neck,
head) posed by a walking cycle, and a set of parts, each the convex hull of a few spheres
on those joints (a limb is a capsule: two spheres; the torso: four). Seen from the camera a
sphere is a disc, so a part's screen shape is the convex hull of its joints' projected
discs; this reads as a person from any side without a mesh. Parts are flat-shaded (the
sun-facing half of a limb lighter) and depth-sorted far to near; the whole person is drawn
with the vehicles in one far-to-near pass, so cars and people occlude each other.

The walking phase is the distance walked along the heading (position projected on the
heading direction) over the stride, so it advances as the pedestrian moves, the same in
every run; a standing pedestrian (speed 0) stands with the legs together.

Appearance (clothing, skin, hair) is a deterministic function of the ``ActorView``: the
shirt is the actor's ``color`` when set, and the other colours are picked from palettes by
a hash of the colour and height, so a world that draws each actor's colour from its seeded
rng gets varied, reproducible people.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

from sitcov._geometry import convex_hull
from sitcov.perception._base import ActorView, CameraSpec, Pose
from sitcov.weather import fog_transmittance

Vec3 = tuple[float, float, float]
Sphere = tuple[Vec3, float]
Poly = tuple[list[tuple[float, float]], tuple[int, int, int]]

#: Stride of one full walking cycle (two steps) [m].
STRIDE = 1.5
#: Palettes the appearance is drawn from (RGB).
SHIRTS = ((200, 40, 40), (40, 70, 160), (235, 235, 230), (40, 40, 45), (60, 130, 70),
          (230, 180, 40), (120, 60, 140), (160, 160, 165))  # fmt: skip
TROUSERS = ((35, 45, 80), (30, 30, 35), (90, 80, 70), (60, 70, 95), (140, 130, 110))
SKIN = ((235, 195, 165), (200, 150, 115), (150, 100, 70), (95, 65, 45))
HAIR = ((25, 20, 18), (70, 45, 25), (150, 110, 60), (110, 105, 100))
SHOE = (30, 28, 28)
#: Each part is drawn over a slightly larger, darker copy of itself [px], its outline:
#: the shading at a limb's edge where it turns away from the light.
OUTLINE_PX = 1.5
OUTLINE_SHADE = 0.45
#: Direction towards the sun (as the vehicles'), for the lit side of each part.
SUN_XY = (0.35, 0.45)


def appearance(actor: ActorView) -> dict[str, tuple[int, int, int]]:
    """Clothing, skin and hair colours of a pedestrian or rider, fixed by the actor's fields."""
    key = (actor.color or (0, 0, 0), round(actor.height * 100))
    h = (
        (key[0][0] * 73856093)
        ^ (key[0][1] * 19349663)
        ^ (key[0][2] * 83492791)
        ^ (key[1] * 2654435)
    )
    h &= 0x7FFFFFFF
    shirt = actor.color or SHIRTS[h % len(SHIRTS)]
    return {
        "shirt": tuple(int(c) for c in shirt),  # type: ignore[dict-item]
        "trousers": TROUSERS[(h // 7) % len(TROUSERS)],
        "skin": SKIN[(h // 53) % len(SKIN)],
        "hair": HAIR[(h // 311) % len(HAIR)],
        "shoe": SHOE,
    }


def walk_phase(actor: ActorView) -> float:
    """Walking phase [rad] from the distance walked along the heading (see module doc)."""
    p = actor.pose
    along = p.x * math.cos(p.yaw) + p.y * math.sin(p.yaw)
    return 2.0 * math.pi * along / STRIDE


def _leg(
    hip: Vec3, swing: float, knee_bend: float, thigh: float, shin: float
) -> tuple[Vec3, Vec3, Vec3]:
    """Knee, ankle and toe of a leg swung forward by ``swing`` with the shin bent back by
    ``knee_bend`` [rad] (x forward, z up)."""
    kx = hip[0] + thigh * math.sin(swing)
    kz = hip[2] - thigh * math.cos(swing)
    a = swing - knee_bend
    ax, az = kx + shin * math.sin(a), kz - shin * math.cos(a)
    return (kx, hip[1], kz), (ax, hip[1], az), (ax + 0.16, hip[1], max(0.03, az - 0.03))


def skeleton(height: float, phase: float, amplitude: float) -> dict[str, Vec3]:
    """Joint positions [m] in the person's frame (x forward, y left, z up from the ground):
    ``amplitude`` 0 stands, 1 walks at full stride; the lower ankle is 0.07 m up."""
    s = height / 1.75
    hip_z, shoulder_z, neck_z = 0.93 * s, 1.42 * s, 1.52 * s
    thigh, shin, upper, fore = 0.45 * s, 0.41 * s, 0.29 * s, 0.27 * s
    j: dict[str, Vec3] = {"neck": (0.0, 0.0, neck_z), "head": (0.02 * s, 0.0, 1.6 * s)}
    for side, sign in (("l", 1.0), ("r", -1.0)):
        ph = phase + (0.0 if sign > 0 else math.pi)
        swing = 0.45 * amplitude * math.sin(ph)
        lift = 0.5 * amplitude * max(0.0, math.cos(ph))  # knee bends while the leg swings
        hip = (0.0, sign * 0.1 * s, hip_z)
        knee, ankle, toe = _leg(hip, swing, lift, thigh, shin)
        j.update({f"hip_{side}": hip, f"knee_{side}": knee, f"ankle_{side}": ankle})
        j[f"toe_{side}"] = toe
        arm = -0.4 * amplitude * math.sin(ph)  # arms swing against the legs
        sh = (0.0, sign * 0.2 * s, shoulder_z)
        el = (sh[0] + upper * math.sin(arm), sign * 0.22 * s, sh[2] - upper * math.cos(arm))
        fa = arm + 0.25 + 0.3 * amplitude
        wr = (el[0] + fore * math.sin(fa), sign * 0.22 * s, el[2] - fore * math.cos(fa))
        j[f"shoulder_{side}"], j[f"elbow_{side}"], j[f"wrist_{side}"] = sh, el, wr
    # Feet rest on the ground: lift the skeleton so the lower ankle stands at ankle height.
    drop = min(j["ankle_l"][2], j["ankle_r"][2]) - 0.07 * s
    return {k: (v[0], v[1], v[2] - drop) for k, v in j.items()}


def person_parts(
    j: dict[str, Vec3], height: float, colors: dict[str, tuple[int, int, int]]
) -> list[tuple[list[Sphere], tuple[int, int, int]]]:
    """The body's parts as sphere hulls with their colours."""
    s = height / 1.75
    parts: list[tuple[list[Sphere], tuple[int, int, int]]] = []
    for side in ("l", "r"):
        parts.append(
            ([(j[f"hip_{side}"], 0.09 * s), (j[f"knee_{side}"], 0.07 * s)], colors["trousers"])
        )
        parts.append(
            ([(j[f"knee_{side}"], 0.07 * s), (j[f"ankle_{side}"], 0.05 * s)], colors["trousers"])
        )
        parts.append(
            ([(j[f"ankle_{side}"], 0.05 * s), (j[f"toe_{side}"], 0.045 * s)], colors["shoe"])
        )
        parts.append(
            ([(j[f"shoulder_{side}"], 0.06 * s), (j[f"elbow_{side}"], 0.05 * s)], colors["shirt"])
        )
        parts.append(
            ([(j[f"elbow_{side}"], 0.045 * s), (j[f"wrist_{side}"], 0.04 * s)], colors["skin"])
        )
    hl, hr = j["hip_l"], j["hip_r"]
    torso = [
        ((j["shoulder_l"][0], j["shoulder_l"][1] * 0.8, j["shoulder_l"][2] - 0.02 * s), 0.09 * s),
        ((j["shoulder_r"][0], j["shoulder_r"][1] * 0.8, j["shoulder_r"][2] - 0.02 * s), 0.09 * s),
        ((hl[0], hl[1] * 0.9, hl[2] + 0.05 * s), 0.1 * s),
        ((hr[0], hr[1] * 0.9, hr[2] + 0.05 * s), 0.1 * s),
    ]
    parts.append((torso, colors["shirt"]))
    parts.append(
        (
            [(j["neck"], 0.05 * s), ((j["neck"][0], 0.0, j["neck"][2] + 0.06 * s), 0.05 * s)],
            colors["skin"],
        )
    )
    parts.append(([(j["head"], 0.11 * s)], colors["skin"]))
    hx, _, hz = j["head"]
    parts.append(([((hx - 0.025 * s, 0.0, hz + 0.03 * s), 0.105 * s)], colors["hair"]))
    return parts


def _disc(u: float, v: float, r: float, n: int) -> list[tuple[float, float]]:
    return [
        (u + r * math.cos(2 * math.pi * k / n), v + r * math.sin(2 * math.pi * k / n))
        for k in range(n)
    ]


class ActorFrame:
    """Maps an actor's local points to the ego camera and the screen, with fog."""

    def __init__(self, camera: CameraSpec, ego: Pose, actor: ActorView, weather: dict[str, float],
                 fog_color: Sequence[float], far: float) -> None:  # fmt: skip
        c, s = math.cos(ego.yaw), math.sin(ego.yaw)
        self.c, self.s = c, s
        self.cam = (ego.x + camera.mount_x * c, ego.y + camera.mount_x * s)
        self.mount_z = camera.mount_z
        self.f, self.cx, self.cy = camera.focal_px, 0.5 * camera.width, 0.5 * camera.height
        self.pose = actor.pose
        self.ac, self.as_ = math.cos(actor.pose.yaw), math.sin(actor.pose.yaw)
        self.weather, self.fog_color, self.far = weather, fog_color, far

    def world(self, p: Vec3) -> tuple[float, float]:
        """World x, y of a local point."""
        return (self.pose.x + p[0] * self.ac - p[1] * self.as_,
                self.pose.y + p[0] * self.as_ + p[1] * self.ac)  # fmt: skip

    def to_cam(self, p: Vec3) -> Vec3:
        """Camera frame (depth, right, up) of a local point."""
        wx, wy = self.world(p)
        dx, dy = wx - self.cam[0], wy - self.cam[1]
        return (dx * self.c + dy * self.s, dx * self.s - dy * self.c, p[2] - self.mount_z)

    def screen(self, q: Vec3) -> tuple[float, float]:
        return (self.cx + self.f * q[1] / q[0], self.cy - self.f * q[2] / q[0])

    def final(self, color: Sequence[float], dist: float) -> tuple[int, int, int]:
        """Colour after fog (:func:`sitcov.weather.fog_transmittance`) and far haze."""
        beta, start = self.weather["beta"], self.weather["fog_start"]
        t = fog_transmittance(beta, start, dist) if beta > 0 else 1.0
        t *= 1.0 - min(1.0, max(0.0, (dist - 0.5 * self.far) / (0.5 * self.far)))
        fc = self.fog_color
        return tuple(int(min(255.0, color[k]) * t + fc[k] * (1 - t)) for k in range(3))  # type: ignore[return-value]

    def hull(
        self, spheres: Sequence[Sphere], near: float, pad: float = 0.0
    ) -> tuple[list[tuple[float, float]], float] | None:
        """Screen hull of projected sphere discs (radii + ``pad`` px) and the mean distance,
        or None if behind."""
        pts: list[tuple[float, float]] = []
        dist = 0.0
        for centre, r in spheres:
            q = self.to_cam(centre)
            if q[0] < near + r:
                return None
            u, v = self.screen(q)
            rp = self.f * r / q[0] + pad
            pts.extend(_disc(u, v, rp, 12 if rp > 3 else 6))
            dist += math.sqrt(q[0] ** 2 + q[1] ** 2)
        return convex_hull(pts), dist / len(spheres)


def _part_shade(
    frame: ActorFrame, spheres: Sequence[Sphere], color: Sequence[float], cloud: float
) -> list[float]:
    """Lighter when the part sits on the sun side of the body (seen from the camera)."""
    cy = sum(c[1] for c, _ in spheres) / len(spheres)
    side = cy * (SUN_XY[0] * -frame.as_ + SUN_XY[1] * frame.ac)  # + when the part faces the sun
    k = 0.9 + (0.12 if side > 0 else -0.08) * (1.0 - 0.8 * cloud)
    return [min(255.0, ch * k) for ch in color]


def parts_polygons(
    frame: ActorFrame,
    parts: Sequence[tuple[list[Sphere], tuple[int, int, int]]],
    cloud: float,
    near: float,
) -> list[tuple[float, list[tuple[float, float]], tuple[int, int, int]]]:
    """(distance, screen polygon, colour) of each part, unsorted."""
    out = []
    for spheres, color in parts:
        got = frame.hull(spheres, near)
        if got is None or len(got[0]) < 3:
            continue
        pts, d = got
        shaded = _part_shade(frame, spheres, color, cloud)
        rim = frame.hull(spheres, near, OUTLINE_PX)
        if rim is not None:
            out.append((d + 1e-6, rim[0], frame.final([c * OUTLINE_SHADE for c in shaded], d)))
        out.append((d, pts, frame.final(shaded, d)))
    return out


def shadow_polygon(
    frame: ActorFrame, rx: float, ry: float, color: Sequence[float], near: float
) -> Poly | None:
    """A dark ellipse on the ground under the actor (local half-axes rx, ry [m])."""
    ring = [
        (rx * math.cos(2 * math.pi * k / 12), ry * math.sin(2 * math.pi * k / 12), 0.0)
        for k in range(12)
    ]
    qs = [frame.to_cam(p) for p in ring]
    if min(q[0] for q in qs) < near:
        return None
    d = sum(math.hypot(q[0], q[1]) for q in qs) / len(qs)
    return [frame.screen(q) for q in qs], frame.final(color, d)


def person_polygons(
    camera: CameraSpec,
    ego: Pose,
    actor: ActorView,
    weather: dict[str, float],
    fog_color: Sequence[float],
    far: float,
    shadow: Callable[[float], Sequence[float]],
    near: float,
) -> list[Poly]:
    """Screen polygons (far to near) and final colours for one pedestrian."""
    frame = ActorFrame(camera, ego, actor, weather, fog_color, far)
    if frame.to_cam((0.0, 0.0, 0.0))[0] < -1.0:
        return []
    amp = min(1.0, max(0.0, actor.speed / 1.2))
    joints = skeleton(actor.height, walk_phase(actor), amp)
    parts = parts_polygons(
        frame, person_parts(joints, actor.height, appearance(actor)), weather["cloud"], near
    )
    parts.sort(key=lambda x: -x[0])
    out: list[Poly] = []
    sh = shadow_polygon(frame, 0.35, 0.25, shadow(weather["cloud"]), near)
    if sh is not None:
        out.append(sh)
    out.extend((pts, col) for _, pts, col in parts)
    return out
