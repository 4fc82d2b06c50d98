"""The judge: turns the facts a backend reports into a verdict and a failure kind.

Backends report facts (did the boxes overlap, when did the ego's box first leave the
drivable area, when did it first drift beyond the lane tolerance); they do not decide what
counts as a failure. A :class:`Judge` does, after ``Backend.run``, from campaign
configuration. The same facts therefore give a collision-only verdict (the paper's judge)
or one that also fails runs that leave the road, without simulating again.

Kinds of an outcome (``Outcome.kind``): ``pass`` or a failure kind of
:data:`FAILURE_KINDS` for judged runs, and ``error`` / ``timeout`` for runs that could not
be judged. When several counted events happen in one run, the kind is the earliest one
(ties: the order of :data:`FAILURE_KINDS`). The failure events:

- ``collision``: the ego's box overlapped another road user's while the ego moved;
- ``ego_stationary``: the same with the ego standing still (below
  :data:`STATIONARY_SPEED` at the impact): someone ran into it. Collisions between two
  other road users are recorded (``metrics["actor_collisions"]``) and are never the ego's;
- ``road_departure`` / ``lane_departure``: the ego's box left the road / its lane;
- ``blocked``: the ego stood still for a stated time while nothing occupied its path or the
  conflict zone ahead (``metrics["blocked_time"]``; docs/campaigns.md);
- ``route_incomplete``: the run's time budget ended before the ego reached its goal
  (``metrics["route_incomplete_time"]``).

Named judges (:data:`JUDGES`): ``default`` counts what the stack did (a collision it was
moving in, leaving the road, not making progress); ``paper`` counts every ego collision,
moving or standing, and nothing else (the paper's verdict; the CARLA Leaderboard also
counts every collision); ``strict`` counts every kind. A list of kinds is a judge too.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from sitcov.errors import ConfigError

if TYPE_CHECKING:
    from sitcov.sim._base import Outcome

#: What can count as a failure, in tie-break order.
FAILURE_KINDS = (
    "collision",
    "ego_stationary",
    "road_departure",
    "lane_departure",
    "blocked",
    "route_incomplete",
)
#: Every value of ``Outcome.kind`` / the stored ``failure_kind`` column.
OUTCOME_KINDS = ("pass", *FAILURE_KINDS, "error", "timeout")
#: Named judges. ``paper`` is the paper's collision-only judge (every ego collision).
JUDGES: dict[str, tuple[str, ...]] = {
    "default": ("collision", "road_departure", "blocked", "route_incomplete"),
    "paper": ("collision", "ego_stationary"),
    "strict": FAILURE_KINDS,
}
#: Ego speed below which a collision is ``ego_stationary`` [m/s] (backends report the
#: fact as ``metrics["ego_stationary"]``; the embedded world's ``STILL_SPEED``).
STATIONARY_SPEED = 0.3
#: Metric keys (``Outcome.metrics``) where backends report the first time of each event
#: other than a collision.
EVENT_METRICS = {
    "road_departure": "road_departure_time",
    "lane_departure": "lane_departure_time",
    "blocked": "blocked_time",
    "route_incomplete": "route_incomplete_time",
}
_EXPECTED = f"one of {', '.join(JUDGES)} or a list of {', '.join(FAILURE_KINDS)}"


def normalize_judge(spec: str | Sequence[str] | None) -> str | list[str]:
    """The canonical form of a judge setting: a name, or a list of kinds in order.

    A list equal to a named judge becomes that name, so ``[collision]`` and ``paper``
    compare equal when a campaign is resumed. A comma-separated string is a list.

    Raises:
        ConfigError: unknown name or kind, or an empty list.
    """
    if spec is None:
        return "default"
    if isinstance(spec, str):
        if spec in JUDGES:
            return spec
        spec = [part.strip() for part in spec.split(",") if part.strip()]
    kinds = list(spec) if not isinstance(spec, str) else []
    bad = [k for k in kinds if k not in FAILURE_KINDS]
    if not kinds or bad:
        raise ConfigError(field="judge", value=bad[0] if bad else spec, expected=_EXPECTED)
    ordered = [k for k in FAILURE_KINDS if k in kinds]
    for name, counted in JUDGES.items():
        if tuple(ordered) == counted:
            return name
    return ordered


def event_times(outcome: Outcome) -> dict[str, float]:
    """Kind -> first time [s] of every failure event the outcome reports as fact.

    A backend that says ``fail`` without saying why (no collision flag, no departure
    metric) is taken as reporting a collision at its end time, as every stored run
    before failure kinds existed did. A collision is ``ego_stationary`` when the outcome
    says so (``metrics["ego_stationary"]``; runs stored before have no such fact: their
    collisions are ``collision``).
    """
    times: dict[str, float] = {}
    if outcome.collision:
        t = outcome.collision_time
        kind = "ego_stationary" if (outcome.metrics or {}).get("ego_stationary") else "collision"
        times[kind] = float(outcome.sim_time if t is None else t)
    for kind, key in EVENT_METRICS.items():
        t = (outcome.metrics or {}).get(key)
        if t is not None:
            times[kind] = float(t)
    if not times and outcome.status == "fail":
        times["collision"] = float(outcome.sim_time)
    return times


@dataclass(frozen=True)
class Judge:
    """Decides pass/fail and the failure kind from an outcome's facts.

    Attributes:
        counts: the failure kinds that make a run fail.
        name: the judge's name (``default``, ``paper``, ``strict``) or ``custom``.
    """

    counts: tuple[str, ...]
    name: str = "custom"

    @classmethod
    def from_spec(cls, spec: str | Sequence[str] | None) -> Judge:
        """The judge of a campaign setting (see :func:`normalize_judge`)."""
        canon = normalize_judge(spec)
        if isinstance(canon, str):
            return cls(JUDGES[canon], canon)
        return cls(tuple(canon))

    @property
    def label(self) -> str:
        """Human-readable, e.g. ``paper (collision)``."""
        return f"{self.name} ({' + '.join(self.counts)})"

    def kind(self, outcome: Outcome) -> str:
        """The outcome's kind under this judge (see the module docstring)."""
        if outcome.status in ("error", "timeout"):
            return outcome.status
        times = event_times(outcome)
        counted = [(times[k], i, k) for i, k in enumerate(FAILURE_KINDS) if k in times]
        counted = [c for c in counted if c[2] in self.counts]
        return min(counted)[2] if counted else "pass"

    def __call__(self, outcome: Outcome) -> Outcome:
        """The outcome with ``status`` and ``failure_kind`` set by this judge."""
        kind = self.kind(outcome)
        if kind in ("error", "timeout"):
            return dataclasses.replace(outcome, failure_kind=kind)
        status = "pass" if kind == "pass" else "fail"
        return dataclasses.replace(outcome, status=status, failure_kind=kind)
