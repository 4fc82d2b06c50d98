"""The adversarial other vehicle (OV): arrive at the conflict point when the ego does.

The paper's controller, backend-neutral (the embedded and the CARLA backends both use it):

1. ``wait``: the OV holds still until the ego starts moving;
2. ``regulate``: every tick ``u = gain * (t_OV - t_ego)`` with ``t = distance to the
   conflict point / current speed`` (speeds below ``min_speed`` count as ``min_speed`` so
   a standing vehicle has a large but finite time); ``u > 0`` -> throttle ``min(u, 1)``,
   ``u < 0`` -> brake ``min(-u, 1)``;
3. ``cruise``: once the ego is within ``switch_distance`` of the conflict point (or the OV
   has reached it), the OV drives on to its goal at ``cruise_speed`` under a speed
   P-controller and ignores the ego.

Lateral control is pure pursuit on the OV's route.

Where the synchronisation ends is a property of the intersection situation: the paper ended
it with a "pass-through" trigger box on the ego's approach leg in Town03, so the ego's
distance to the conflict point at the switch differs per situation (13.5 to 29 m).
:data:`TOWN03_SWITCH_DISTANCES` derives those distances from the Town03 geometry below
(facts from the authors' released code); maps carry them as ``switch_distances`` and the
backends pass the situation's value in (docs/embedded.md, "The adversarial OV").
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

#: ``math.hypot`` under the name :func:`pure_pursuit` uses (numba compiles that code with
#: the name bound to a correctly rounded version, ``sitcov/_jit.py``: the same bits).
hypot = math.hypot


@dataclass(frozen=True)
class AdversaryParams:
    """Tuning of the adversary (documented in ``docs/embedded.md``).

    Attributes:
        gain: the paper's timing gain on ``t_OV - t_ego`` [1/s].
        switch_distance: the ego's remaining distance to the conflict point at which the
            OV stops regulating and cruises [m]; None (the default) takes the situation's
            value from the map (:func:`with_switch_distance`), a number overrides it for
            every situation.
        cruise_speed: speed after the switch, 15 km/h [m/s].
        cruise_gain: P gain of the cruise speed control [1/(m/s)].
        min_speed: speed floor in the arrival-time estimate [m/s].
        start_speed: ego speed that counts as "started" [m/s].
        lookahead_time: pure-pursuit look-ahead per unit speed [s].
        lookahead_min: minimum look-ahead distance [m].
    """

    gain: float = 3.0
    switch_distance: float | None = None
    cruise_speed: float = 15.0 / 3.6
    cruise_gain: float = 0.5
    min_speed: float = 0.5
    start_speed: float = 0.1
    lookahead_time: float = 0.8
    lookahead_min: float = 4.0


def arrival_time(distance: float, speed: float, min_speed: float) -> float:
    """Time to cover ``distance`` [m] at the current ``speed`` [m/s] (floored at ``min_speed``)."""
    return max(distance, 0.0) / max(speed, min_speed)


#: The controller's phases, in order; the law (:func:`timing_law`) numbers them 0, 1, 2.
PHASES = ("wait", "regulate", "cruise")


def law_constants(params: AdversaryParams, switch: float, has_conflict: bool) -> tuple:
    """What :func:`timing_law` reads of ``params``: (gain, switch distance, cruise speed,
    cruise gain, min speed, start speed, has conflict as 1.0/0.0)."""
    p = params
    flag = 1.0 if has_conflict else 0.0
    return (p.gain, switch, p.cruise_speed, p.cruise_gain, p.min_speed, p.start_speed, flag)


def timing_law(
    phase: int, k: Any, d_ego: float, v_ego: float, d_ov: float, v_ov: float
) -> tuple[int, float, float]:
    """One tick of the law (the module docstring): ``(phase, throttle, brake)``.

    ``phase`` indexes :data:`PHASES`; ``k`` is :func:`law_constants`. Plain floats, so the
    embedded world's timed car compiles it into its controller's kernel
    (``_controllers._timed_car``): the same operations in the same order either way.
    """
    if phase == 0:
        if v_ego <= k[5]:
            return 0, 0.0, 1.0
        phase = 1 if k[6] != 0.0 else 2
    if phase == 1 and (d_ego <= k[1] or d_ov <= 0.0):
        phase = 2
    if phase == 1:
        low = k[4]  # arrival_time(), inlined: this runs every step
        t_ov = (d_ov if d_ov > 0.0 else 0.0) / (v_ov if v_ov > low else low)
        t_ego = (d_ego if d_ego > 0.0 else 0.0) / (v_ego if v_ego > low else low)
        u = k[0] * (t_ov - t_ego)
    else:
        u = k[3] * (k[2] - v_ov)
    if u >= 0.0:
        return phase, (1.0 if u > 1.0 else u), 0.0
    return phase, 0.0, (1.0 if -u > 1.0 else -u)


class AdversaryController:
    """Longitudinal phases of the OV. One instance per run.

    Args:
        params: tuning; the defaults follow the paper.
        has_conflict: False if the routes never meet; the OV then cruises once the ego starts.
    """

    def __init__(self, params: AdversaryParams | None = None, has_conflict: bool = True) -> None:
        self.params = params or AdversaryParams()
        self.has_conflict = has_conflict
        self.phase_index = 0  # into PHASES
        p = self.params
        self._switch = FALLBACK_SWITCH_DISTANCE if p.switch_distance is None else p.switch_distance
        #: :func:`timing_law`'s constants
        self.constants = law_constants(p, self._switch, has_conflict)

    @property
    def phase(self) -> str:
        """``wait``, ``regulate`` or ``cruise``."""
        return PHASES[self.phase_index]

    def command(self, d_ego: float, v_ego: float, d_ov: float, v_ov: float) -> tuple[float, float]:
        """(throttle, brake) for this tick.

        Args:
            d_ego, d_ov: remaining distance along each route to the conflict point [m]
                (negative once past it).
            v_ego, v_ov: current speeds [m/s].
        """
        self.phase_index, thr, brk = timing_law(
            self.phase_index, self.constants, d_ego, v_ego, d_ov, v_ov
        )
        return thr, brk

    def lookahead(self, speed: float) -> float:
        """Pure-pursuit look-ahead distance [m] at ``speed`` [m/s]."""
        return max(self.params.lookahead_min, self.params.lookahead_time * speed)


def pure_pursuit(
    x: float, y: float, yaw: float, target_x: float, target_y: float, wheelbase: float
) -> float:
    """Road-wheel angle [rad] that steers a rear-axle point at (x, y) onto the target point."""
    dx, dy = target_x - x, target_y - y
    alpha = math.atan2(dy, dx) - yaw
    dist = hypot(dx, dy)
    if dist < 1e-6:
        return 0.0
    return math.atan2(2.0 * wheelbase * math.sin(alpha), dist)


# --- where the synchronisation ends: the paper's Town03 trigger boxes -----------------------

#: The paper's "pass-through" trigger box per ego start leg in CARLA Town03
#: (x_min, x_max, y_min, y_max) [m], CARLA frame: when the ego enters it the OV stops
#: synchronising (authors' released code, ``select_ego_passthroughtrigger_loc``).
TOWN03_SYNC_END_BOXES: dict[str, tuple[float, float, float, float]] = {
    "L": (-103.64, -98.64, -148.5, -128.5),
    "B": (-90.0, -70.0, -127.0, -121.0),
    "R": (-66.15, -61.15, -147.5, -127.5),
}
#: Town03 conflict points the OV synchronises to [m], CARLA frame.
TOWN03_CONFLICT_POINTS: dict[str, tuple[float, float]] = {
    "c1": (-74.63, -136.34),
    "c2": (-74.63, -139.28),
    "c4": (-89.0, -136.5),
}
#: A point and heading [deg] on each leg's inbound lane, towards the junction: the OV spawn
#: points of Town03, which lie on the lane the ego approaches on.
TOWN03_INBOUND_LANES: dict[str, tuple[float, float, float]] = {
    "L": (-109.0, -136.0, 0.0),
    "B": (-74.70, -114.95, 270.0),
    "R": (-55.08, -139.5, 180.0),
}
#: The twelve intersection situations: (ego movement, OV movement) -> conflict point.
PAPER_INTSITS: dict[tuple[str, str], str] = {
    ("L-B", "R-B"): "c4",
    ("L-R", "R-B"): "c4",
    ("L-R", "B-R"): "c1",
    ("L-R", "B-L"): "c1",
    ("B-L", "L-R"): "c1",
    ("B-L", "R-L"): "c2",
    ("B-L", "R-B"): "c2",
    ("B-R", "L-R"): "c1",
    ("R-L", "B-L"): "c2",
    ("R-B", "B-L"): "c2",
    ("R-B", "L-R"): "c4",
    ("R-B", "L-B"): "c4",
}


def box_entry(leg: str) -> tuple[float, float]:
    """Where an ego approaching on Town03 leg ``leg`` enters that leg's trigger box [m].

    The inbound lane is the ray from the leg's lane point along its heading; the entry is
    where that ray first reaches the box (slab intersection with the axis-aligned box).
    """
    x0, x1, y0, y1 = TOWN03_SYNC_END_BOXES[leg]
    px, py, yaw = TOWN03_INBOUND_LANES[leg]
    dx, dy = math.cos(math.radians(yaw)), math.sin(math.radians(yaw))
    t_in = 0.0
    for p, d, lo, hi in ((px, dx, x0, x1), (py, dy, y0, y1)):
        if abs(d) < 1e-9:
            continue
        t_in = max(t_in, min((lo - p) / d, (hi - p) / d))
    return px + t_in * dx, py + t_in * dy


def town03_switch_distance(ego_move: str, conflict: str) -> float:
    """The ego's distance [m] to the conflict point when it enters its trigger box.

    Euclidean, as the paper's synchronisation measured it (scenario_runner's SyncArrival
    uses straight-line distances to the target location).
    """
    ex, ey = box_entry(ego_move.split("-", 1)[0])
    cx, cy = TOWN03_CONFLICT_POINTS[conflict]
    return math.hypot(cx - ex, cy - ey)


def intsit_key(ego_move: str, ov_move: str) -> str:
    """Key of an intersection situation in ``switch_distances`` tables, e.g. ``"L-B/R-B"``."""
    return f"{ego_move}/{ov_move}"


#: The ego's distance to the conflict point at which the paper's OV stopped synchronising,
#: per intersection situation ("EGO/OV" -> m), derived from the Town03 geometry above.
TOWN03_SWITCH_DISTANCES: dict[str, float] = {
    intsit_key(e, o): round(town03_switch_distance(e, c), 2) for (e, o), c in PAPER_INTSITS.items()
}
#: Used when neither the parameters nor the map give a distance: the median of the Town03
#: situations [m].
FALLBACK_SWITCH_DISTANCE: float = statistics.median(TOWN03_SWITCH_DISTANCES.values())


def with_switch_distance(params: AdversaryParams, distance: float | None) -> AdversaryParams:
    """``params`` with the situation's switch ``distance`` [m] unless they fix their own."""
    if params.switch_distance is not None or distance is None:
        return params
    return replace(params, switch_distance=float(distance))


def lookup_switch_distance(table: Mapping[str, float], ego_move: str, ov_move: str) -> float | None:
    """The situation's entry of a ``switch_distances`` table, or None if it has none."""
    return table.get(intsit_key(ego_move, ov_move))
