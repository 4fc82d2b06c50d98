"""Typed conflicts between two routes, derived from their geometry.

:func:`~sitcov.sim.embedded._map.route_conflict` says *where* two routes conflict;
:func:`conflict_type` says *how* they meet, from the headings along that overlap:

- ``following``: one route starts inside the other's swept path and they run together to
  the end of one of them (same lane: a rear-end conflict).
- ``diverging``: one route starts inside the other's swept path, they run together, then
  split (queued on the same approach, one turns: rear-end and turning conflicts).
- ``merging``: the routes come from different places and join, running together
  afterwards (same exit, on-ramp, roundabout entry).
- ``crossing``: they overlap without ever running together (paths cross at an angle).

For a cyclist the same classes get a ``cyclist_`` prefix, except ``cyclist_right_hook``: a
crossing where, before it, the cyclist rode beside the car on its right in the same
direction (the car turns right across a cyclist keeping straight on). Every overlap with a
pedestrian's crosswalk route is ``pedestrian_crossing``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from sitcov.sim.embedded._map import CONFLICT_STEP, Conflict, overlap_matrix, route_conflict
from sitcov.sim.embedded._path import Path

#: Width of each kind's box [m] for swept paths: the BMW 320i of the embedded world (cars),
#: a heavy rigid truck, bike plus rider (1.8 x 0.6 m) and a pedestrian (0.5 x 0.5 m), as
#: issue 12 sizes them.
KIND_WIDTHS: dict[str, float] = {"car": 1.61, "truck": 2.5, "cyclist": 0.6, "pedestrian": 0.5}
#: Headings within this angle count as running together [rad].
PARALLEL = math.radians(10.0)
#: Routes run together if they stay parallel inside each other's swept path this long [m].
TOGETHER = 6.0
#: A cyclist counts as riding beside the car if, this far before the conflict on its own
#: route [m], it is right of the car's route (within this lateral range [m]) and parallel.
HOOK_LOOKBACK = 8.0
HOOK_LATERAL = 4.0
#: ... and at the end of the overlap the car heads this far right of the cyclist [rad] ...
HOOK_TURN = math.radians(30.0)
#: ... having itself turned right by more than this [rad] from this far before the overlap [m].
HOOK_SELF_TURN = math.radians(10.0)
HOOK_APPROACH = 4.0
#: Every conflict type :func:`conflict_type` can return.
CONFLICT_TYPES = (
    "crossing",
    "merging",
    "diverging",
    "following",
    "pedestrian_crossing",
    "cyclist_crossing",
    "cyclist_merging",
    "cyclist_diverging",
    "cyclist_following",
    "cyclist_right_hook",
)


@dataclass(frozen=True)
class TypedConflict:
    """A conflict and its type (one of :data:`CONFLICT_TYPES`)."""

    type: str
    conflict: Conflict


def typed_conflict(
    ego: Path, actor: Path, kind: str = "car", width_ego: float = 1.61
) -> TypedConflict | None:
    """Where and how an ego on ``ego`` meets an actor of ``kind`` on ``actor`` (None: never)."""
    gap = 0.5 * (width_ego + KIND_WIDTHS[kind])
    conflict = route_conflict(ego, actor, gap)
    if conflict is None:
        return None
    if kind == "pedestrian":
        return TypedConflict("pedestrian_crossing", conflict)
    base = _geometric_type(ego, actor, gap)
    if kind != "cyclist":
        return TypedConflict(base, conflict)
    if base == "crossing" and _rides_beside(ego, actor, conflict):
        return TypedConflict("cyclist_right_hook", conflict)
    return TypedConflict(f"cyclist_{base}", conflict)


def conflict_type(ego: Path, actor: Path, kind: str = "car", width_ego: float = 1.61) -> str | None:
    """The type of conflict between the ego's and an actor's route, or None if none.

    Args:
        ego: the ego's route (a car's lane path).
        actor: the other road user's route (``sitcov.sim.embedded._routes.actor_route``).
        kind: the other road user's kind (car, truck, cyclist, pedestrian).
        width_ego: the ego's width [m].
    """
    typed = typed_conflict(ego, actor, kind, width_ego)
    return None if typed is None else typed.type


def _geometric_type(ego: Path, actor: Path, gap: float) -> str:
    """crossing / merging / diverging / following from the first overlapping stretch."""
    e = np.asarray(ego.resampled(CONFLICT_STEP))
    a = np.asarray(actor.resampled(CONFLICT_STEP))
    d, close, ie, ia = overlap_matrix(e, a, gap)
    he, ha = _headings(e)[ie], _headings(a)[ia]
    rows = np.flatnonzero(close.any(axis=1))
    first = last = int(rows[0])
    # the first contiguous overlapping stretch along the ego's route
    while last + 1 < len(ie) and ie[last + 1] == ie[last] + 1 and close[last + 1].any():
        last += 1
    run = best = 0
    together_to = (0, 0)
    for i in range(first, last + 1):
        j = int(np.argmin(np.where(close[i], d[i], np.inf)))
        if abs(math.remainder(he[i] - ha[j], 2.0 * math.pi)) < PARALLEL:
            run += 1
            if run > best:
                best, together_to = run, (int(ie[i]), int(ia[j]))
        else:
            run = 0
    if best * CONFLICT_STEP < TOGETHER:
        return "crossing"
    ego_starts_inside = int(ie[first]) == 0
    actor_starts_inside = ia.size > 0 and ia[0] == 0 and bool(close[first:, 0].any())
    if not (ego_starts_inside or actor_starts_inside):
        return "merging"
    i_end, j_end = together_to
    ends_together = i_end >= len(e) - 2 or j_end >= len(a) - 2
    return "following" if ends_together else "diverging"


def _headings(points: np.ndarray) -> np.ndarray:
    d = np.diff(points, axis=0)
    h = np.arctan2(d[:, 1], d[:, 0])
    return np.append(h, h[-1])


def _rides_beside(ego: Path, actor: Path, conflict: Conflict) -> bool:
    """A right hook: shortly before the conflict the cyclist rode parallel on the car's
    right, and the car turned right across it: the car itself turns right into the overlap
    (by more than :data:`HOOK_SELF_TURN` from :data:`HOOK_APPROACH` before it to its end)
    and by the end heads more than :data:`HOOK_TURN` to the right of the cyclist.

    The second turn is measured against the cyclist, not against the car's own earlier
    heading: on a roundabout both circulate (turning left) before the car exits to the
    right, and the ring's curvature hides most of the exit's turn from a comparison with
    the car alone. The first keeps out a car driving straight on while the cyclist turns
    left across it (the cyclist's move, not a hook).
    """
    s = conflict.s_ov - HOOK_LOOKBACK
    if s <= 0.0:
        return False
    x, y, h = actor.point_at(s)
    s_e, i = ego.project(x, y, -1)
    _, _, he = ego.point_at(s_e)
    lateral = ego.lateral_offset(x, y, i)
    parallel = abs(math.remainder(h - he, 2.0 * math.pi)) < 2.0 * PARALLEL
    end = ego.point_at(conflict.s_ego_end)[2]
    own = math.remainder(end - ego.point_at(conflict.s_ego - HOOK_APPROACH)[2], 2.0 * math.pi)
    turn = math.remainder(end - actor.point_at(conflict.s_ov_end)[2], 2.0 * math.pi)
    return (
        parallel and -HOOK_LATERAL < lateral < 0.0 and own < -HOOK_SELF_TURN and turn < -HOOK_TURN
    )
