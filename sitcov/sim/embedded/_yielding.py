"""What a road user sees ahead on its own path, and how it yields or follows.

Every actor other than the ego gets a :class:`Watcher` (``_scene.build_actors``) over the
other road users whose routes overlap its own (the ego included). The overlaps are
:func:`route_zones`: stretches where the two swept paths (half widths plus
:data:`ZONE_MARGIN`) meet, each with its arc lengths on both routes and whether the routes
cross there, run the same way (a queue, a merge) or meet head-on. Every step
:meth:`Watcher.obstacle` turns the other road users' arc lengths and speeds into the nearest
obstacle on the actor's path (distance and speed), from three rules:

- **occupied**: the other is inside a zone the actor has not entered yet: a standing
  obstacle where the zone starts (inside the zone: the other, if it is ahead);
- **follow**: on a same-way stretch the other is ahead of the actor: a leader at its
  position mapped onto the actor's route, moving at its speed;
- **yield**: the other will reach the zone within :data:`HORIZON` seconds and before the
  actor does (first come, first served; the earlier actor of the scene on a tie), or, if it
  does not react itself (the ego, an adversary still synchronising), before the actor
  would have cleared it: a standing obstacle where the zone starts. Arrival times use the
  current speed floored at :data:`V_FLOOR`.

An adversary (``strict=False``, after its synchronisation ends) sees the ego only while it
stands (slower than :data:`SLOW`): it must still meet a moving ego (that is the test), but it
does not drive into a standing one. The controllers then brake with the Intelligent Driver
Model (:func:`idm_accel`, :data:`IDM`) for the obstacle, never harder than their own command.

The IDM (Treiber, Hennecke & Helbing 2000, "Congested traffic states in empirical
observations and microscopic simulations", Phys. Rev. E 62, 1805) is written out here:
it is one formula per step in the hot loop; the kept implementation closest to it,
``commonroad-idm-planner``, is a planner over CommonRoad scenario objects (route planner,
curvilinear frame) that would cost more per call than a whole step of this world.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from sitcov.sim.embedded._map import overlap_matrix
from sitcov.sim.embedded._path import Path, wrap_angle


@dataclass(frozen=True)
class IDMParams:
    """Parameters of the Intelligent Driver Model (SI units).

    Attributes:
        a: maximum acceleration [m/s^2]. b: comfortable deceleration [m/s^2].
        T: desired time gap [s]. s0: gap kept when standing [m]. delta: exponent [-].
    """

    a: float
    b: float
    T: float
    s0: float
    delta: float = 4.0


#: IDM parameters per kind. Car: city traffic of Treiber & Kesting, "Traffic Flow
#: Dynamics" (Springer 2013), Table 11.2 (T 1.0 s, s0 2 m, a 1.0 m/s^2, b 1.5 m/s^2,
#: delta 4). Cyclist and pedestrian: the same form with their own, assumed, values: a
#: cyclist keeps 1 s and 1 m, brakes comfortably at 1.5 m/s^2; a pedestrian keeps 0.5 s and
#: 0.5 m (about a step) and stops within a step or two.
IDM: dict[str, IDMParams] = {
    "car": IDMParams(a=1.0, b=1.5, T=1.0, s0=2.0),
    "cyclist": IDMParams(a=1.0, b=1.5, T=1.0, s0=1.0),
    "pedestrian": IDMParams(a=1.0, b=1.5, T=0.5, s0=0.5),
}
#: Extra clearance between the two swept paths of a zone [m].
ZONE_MARGIN = 0.3
#: A road user slower than this counts as standing [m/s] (the adversary's view of the ego).
SLOW = 1.0
#: Speed below which a road user stands [m/s] (``_controllers.STANDING``).
STANDING = 0.05
#: An ego braking so hard that it stands within this time [s] counts as standing.
STOP_HORIZON = 1.5
#: Speed floor in arrival-time estimates [m/s] (the timing law's ``min_speed``).
V_FLOOR = 0.5
#: How far ahead an actor yields to another road user's arrival [s], per kind, for another
#: actor and for the ego (which never yields itself: a pedestrian steps out if a car is
#: more than 1.5 s away, as the ``cross`` behaviour has it).
HORIZON: dict[str, tuple[float, float]] = {
    "car": (4.0, 3.0),
    "cyclist": (3.0, 2.0),
    "pedestrian": (3.0, 1.5),
}
#: How far ahead on its route an actor looks [m], per kind.
REACH: dict[str, float] = {"car": 40.0, "cyclist": 25.0, "pedestrian": 8.0}
#: How an actor sees the ego: like any road user; only while it stands (an adversary after
#: its synchronisation, a pedestrian stepping out as its behaviour says); not at all (an
#: adversary still synchronising: the timing law is the test).
EGO_ALL, EGO_STANDING, EGO_NEVER = 0, 1, 2
#: Where two routes merge their arc lengths do not line up: a road user mapped up to this
#: much [m] (plus both half lengths) behind is checked box to box.
MERGE_SLACK = 3.0
#: Spacing of the route points compared for zones [m].
ZONE_STEP = 0.5
#: Zone relations: the routes cross, run the same way, or meet head-on.
CROSS, SAME, OPPOSITE = 0, 1, 2
#: Headings within this angle run the same way; beyond ``HEAD_ON`` they meet head-on [rad]
#: (a left turn across the opposing lane, ~150 degrees, crosses it).
SAME_WAY, HEAD_ON = math.radians(45.0), math.radians(165.0)


@dataclass(frozen=True)
class Zone:
    """Where two routes' swept paths meet: arc lengths on route a and route b [m]."""

    sa0: float
    sa1: float
    sb0: float
    sb1: float
    relation: int


def idm_accel(p: IDMParams, v: float, v0: float, gap: float, dv: float) -> float:
    """IDM acceleration [m/s^2] at speed ``v`` with desired speed ``v0``, net ``gap`` to the
    obstacle [m] and approach rate ``dv = v - v_obstacle`` [m/s]."""
    s_star = p.s0 + max(0.0, v * p.T + v * dv / (2.0 * math.sqrt(p.a * p.b)))
    free = 1.0 - (v / v0) ** p.delta if v0 > 0.0 else 0.0
    if gap <= 0.01:
        return -math.inf
    return p.a * (free - (s_star / gap) ** 2)


@functools.lru_cache(maxsize=8192)
def route_zones(a: Path, b: Path, gap: float) -> tuple[Zone, ...]:
    """Every stretch of route ``a`` whose centre line comes within ``gap`` [m] of route
    ``b``'s, with the matching arc lengths on ``b`` and the relation of the headings there
    (cached: routes are shared by every run of a situation)."""
    pa = np.asarray(a.resampled(ZONE_STEP))
    pb = np.asarray(b.resampled(ZONE_STEP))
    _, close, ia, ib = overlap_matrix(pa, pb, gap)
    rows = np.flatnonzero(close.any(axis=1))
    if rows.size == 0:
        return ()
    step_a, step_b = a.length / (len(pa) - 1), b.length / (len(pb) - 1)
    zones = []
    start = 0
    for k in range(1, rows.size + 1):
        if k < rows.size and ia[rows[k]] == ia[rows[k - 1]] + 1:
            continue
        run = rows[start:k]
        hit = ib[close[run].any(axis=0)]
        sa0, sa1 = float(ia[run[0]]) * step_a, float(ia[run[-1]]) * step_a
        sb0, sb1 = float(hit.min()) * step_b, float(hit.max()) * step_b
        mid = run[len(run) // 2]
        j = ib[np.argmax(close[mid])]
        turn = abs(wrap_angle(a.point_at(float(ia[mid]) * step_a)[2] - b.point_at(j * step_b)[2]))
        relation = SAME if turn < SAME_WAY else (OPPOSITE if turn > HEAD_ON else CROSS)
        zones.append(Zone(sa0, sa1, sb0, sb1, relation))
        start = k
    return tuple(zones)


class Watcher:
    """The road users whose routes meet ``actor``'s and the rules of the module docstring.

    Args:
        actor: the road user that looks.
        others: ``(index, other actor, zones, is_ego, last)`` for every other road user whose
            route meets this one's (index: its place in the scene, the ego first; last: where
            the last zone ends on this route [m]).
        index: this actor's place in the scene.
    """

    __slots__ = ("actor", "entries", "index", "horizon", "horizon_ego", "reach", "idm", "others")

    def __init__(
        self, actor: Any, others: list[tuple[int, Any, tuple[Zone, ...], bool, float]], index: int
    ) -> None:
        self.actor, self.entries, self.index = actor, others, index
        self.horizon, self.horizon_ego = HORIZON[actor.kind]
        self.reach = REACH[actor.kind]
        self.idm = IDM[actor.kind]
        #: whether any road user but the ego meets this actor's route
        self.others = any(not is_ego for *_, is_ego, _ in others)

    def obstacle(self, ego: int = EGO_ALL, decel: float = 0.0) -> tuple[float, float, Any]:
        """The nearest obstacle on the path: (net gap [m], its speed along [m/s], the road
        user); (inf, 0, None) if none. ``ego``: how the ego counts (:data:`EGO_ALL`,
        :data:`EGO_STANDING`, :data:`EGO_NEVER`); ``decel``: the ego's deceleration over
        the last step [m/s^2] (an ego braking to a stop within :data:`STOP_HORIZON`
        counts as standing)."""
        a = self.actor
        s, half = a.s, a.half_l
        front, rear = s + half, s - half
        va = -1.0  # its speed floored at V_FLOOR, once needed
        best, best_v, who = math.inf, 0.0, None
        for index, other, zones, is_ego, last in self.entries:
            if not other.active or rear > last:
                continue  # gone, or every zone with it is behind this actor
            vb = other.body.speed
            if (
                is_ego
                and ego != EGO_ALL
                and (ego == EGO_NEVER or (vb >= SLOW and vb > decel * STOP_HORIZON))
            ):
                continue
            bs, bh = other.s, other.half_l
            bf, br = bs + bh, bs - bh
            shift = 0.0
            if is_ego and ego == EGO_STANDING and decel > 0.5:
                shift = vb * vb / (2.0 * decel)  # how far it goes on before it stands
                bf += shift
            for z in zones:
                if rear > z.sa1 or z.sa0 - front > self.reach or br > z.sb1:
                    continue  # passed it, too far ahead, or the other has passed it
                inside = bf > z.sb0
                if z.relation == SAME and inside:
                    # the other's place on this route (arc lengths run alike on a shared
                    # stretch; where routes merge, its box may be ahead all the same)
                    pos = z.sa0 + (bs - z.sb0)
                    if pos > s:
                        gap = pos - s - half - bh
                    elif s - pos < half + bh + MERGE_SLACK:
                        gap = self._ahead(other, shift)  # alongside: is its box ahead?
                        if gap == math.inf:
                            continue
                    else:
                        continue  # behind
                    lead = vb
                elif inside:
                    if front <= z.sa0:
                        gap, lead = z.sa0 - front, 0.0
                    else:  # both inside: only if it is ahead
                        gap = self._ahead(other, shift)
                        if gap == math.inf:
                            continue
                        lead = 0.0
                elif front > z.sa0 or (is_ego and ego != EGO_ALL):
                    continue  # this actor is there first: the other yields
                else:
                    tb = (z.sb0 - bf) / (vb if vb > V_FLOOR else V_FLOOR)
                    if tb > (self.horizon_ego if is_ego else self.horizon):
                        continue
                    if va < 0.0:
                        va = max(a.body.speed, V_FLOOR)
                    ta = (z.sa0 - front) / va
                    first = tb < ta or (tb == ta and index < self.index)
                    if not first and (not is_ego or tb > (z.sa1 - rear) / va):
                        continue
                    gap, lead = z.sa0 - front, 0.0
                if gap < best:
                    best, best_v, who = gap, lead, other
        return best, best_v, who

    def _ahead(self, other: Any, shift: float = 0.0) -> float:
        """Net distance to ``other``'s box (moved ``shift`` metres along its heading) along
        this actor's heading if it is ahead and across its path, else inf."""
        b, o = self.actor.body, other.body
        c, sn = math.cos(b.yaw), math.sin(b.yaw)
        dx = o.x + shift * math.cos(o.yaw) - b.x
        dy = o.y + shift * math.sin(o.yaw) - b.y
        ahead = dx * c + dy * sn
        rel = o.yaw - b.yaw
        rc, rs = abs(math.cos(rel)), abs(math.sin(rel))
        along = other.half_l * rc + other.half_w * rs  # the other box's extent along the heading
        across = other.half_l * rs + other.half_w * rc
        if ahead <= 0.0 or abs(dy * c - dx * sn) > self.actor.half_w + across:
            return math.inf
        return max(0.0, ahead - self.actor.half_l - along)

    def accel(self, v0: float, ego: int = EGO_ALL, decel: float = 0.0) -> float:
        """IDM acceleration [m/s^2] for the nearest obstacle at desired speed ``v0``; inf
        when nothing is ahead (``ego``, ``decel``: :meth:`obstacle`)."""
        gap, lead, _ = self.obstacle(ego, decel)
        if gap == math.inf:
            return math.inf
        v = self.actor.body.speed
        return idm_accel(self.idm, v, v0, gap, v - lead)

    def blocked(self, ego: int = EGO_ALL) -> bool:
        """Standing before a road user that stands too (the early end's ``stuck``: once
        the ego stands for good, nothing will move it)."""
        if self.actor.body.speed >= STANDING:
            return False
        _, _, who = self.obstacle(ego)
        return who is not None and who.body.speed < STANDING


def watch(actors: list[Any], ego: Any) -> None:
    """Give every actor its :class:`Watcher` over the others (``actor.watcher``)."""
    everyone = [ego, *actors]
    for i, a in enumerate(everyone[1:], start=1):
        entries = []
        for j, o in enumerate(everyone):
            if o is a:
                continue
            zones = route_zones(a.route, o.route, a.half_w + o.half_w + ZONE_MARGIN)
            if zones:
                entries.append((j, o, zones, j == 0, max(z.sa1 for z in zones)))
        a.watcher = Watcher(a, entries, i)


def limit(u: float, accel: float, a_max: float, b_max: float) -> float:
    """The command ``u`` in [-1, 1] (throttle > 0, brake < 0), never above the IDM's
    ``accel`` [m/s^2] over the body's acceleration ``a_max`` / braking ``b_max``."""
    if accel == math.inf:
        return u
    cap = accel / a_max if accel >= 0.0 else (accel / b_max if accel > -math.inf else -1.0)
    return cap if cap < u else u
