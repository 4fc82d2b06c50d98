"""The backend interface and the outcome of a run."""

from __future__ import annotations

import abc
from dataclasses import asdict, dataclass, field
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    from sitcov.av import AVStack
    from sitcov.hyperspace import Situation

#: Statuses a stored run can have. ``fail`` means the stack failed (what counts as a
#: failure is the campaign's judge, see ``sitcov.sim.Judge``; ``Outcome.kind`` says which
#: kind); ``error`` and ``timeout`` mean the run could not be judged.
STATUSES = ("pass", "fail", "error", "timeout")
#: Version of the embedded world model (dynamics, conditions, judge facts). Stored with every
#: campaign; campaigns made with another version cannot be extended. Version 1 ("legacy")
#: is everything before physics profiles and failure kinds; version 3 added the route
#: progress facts (route completion, blocked, route incomplete, stationary collisions)
#: and the reference stack's releasing AEB.
WORLD_MODEL_VERSION = 3


@dataclass(frozen=True)
class Trace:
    """Recorded trajectories of a run, one row per control step.

    Each of ``ego`` and ``ov`` is a list of (t [s], x [m], y [m], yaw [rad], speed [m/s]);
    ``ov`` is the primary other road user (the intersection situation's). ``actors`` maps
    every non-ego actor's name (``ov``, ``actor2``, ...) to its rows (empty in traces
    recorded before actors existed); ``meta["actors"]`` gives each one's kind, size and
    route.
    """

    ego: list[tuple[float, float, float, float, float]]
    ov: list[tuple[float, float, float, float, float]]
    meta: dict[str, Any] = field(default_factory=dict)
    actors: dict[str, list[tuple[float, float, float, float, float]]] = field(default_factory=dict)


@dataclass(frozen=True)
class Outcome:
    """What a run produced; every reported number is computed from these.

    Attributes:
        status: ``pass`` | ``fail`` | ``error`` | ``timeout`` (see :data:`STATUSES`).
        end_reason: why the simulation stopped: ``goal``, ``collision``, ``sim_timeout``
            (60 s simulated, not a failure), ``stopped`` (ego halted and nothing can change),
            ``error`` or ``wall_timeout``.
        sim_time: simulated time at the end [s].
        collision: whether ego and OV collided.
        collision_time: [s] or None.
        collision_speed: relative speed at impact [m/s] or None.
        min_distance: minimum distance between the two vehicle boxes [m].
        min_ttc: minimum constant-velocity time-to-collision of the vehicles' footprint
            discs [s], or None if they never closed in (docs/metrics.md).
        pet: post-encroachment time at the conflict zone [s] or None (docs/metrics.md).
        aeb_fired: whether the ego's emergency brake fired.
        aeb_time: [s] or None.
        message: error text for ``error``/``timeout`` runs.
        metrics: further backend-specific metrics (JSON-serialisable); the embedded
            backend reports ``road_departure_time`` and ``lane_departure_time`` here, and
            the route progress facts: ``route_completion`` [0-1], ``time_to_goal``,
            ``blocked_time``, ``route_incomplete_time``, ``ego_stopped``, ``stop_reason``,
            ``ego_stationary`` (docs/campaigns.md, "Route completion and blame"). Runs
            stored before world model 3 have none of these (null: not judged on them).
        failure_kind: set by the campaign's judge: ``pass``, a kind of
            ``sitcov.sim.FAILURE_KINDS``, ``error`` or ``timeout``; None for an
            outcome straight from a backend (see :attr:`kind`). Not part of ``==``: it is
            derived from the facts and ``status``, which are compared.
        trace: recorded trajectories when the run was asked to record.
    """

    status: str
    end_reason: str
    sim_time: float = 0.0
    collision: bool = False
    collision_time: float | None = None
    collision_speed: float | None = None
    min_distance: float | None = None
    min_ttc: float | None = None
    pet: float | None = None
    aeb_fired: bool = False
    aeb_time: float | None = None
    message: str | None = None
    metrics: dict[str, Any] = field(default_factory=dict)
    failure_kind: str | None = field(default=None, compare=False)
    trace: Trace | None = field(default=None, compare=False)

    @property
    def failed(self) -> bool:
        """True when the stack under test failed (by the judge that set ``status``)."""
        return self.status == "fail"

    @property
    def kind(self) -> str:
        """``failure_kind`` if a judge set it; else ``collision`` for a failed run (what
        ``fail`` meant before failure kinds existed) and the status otherwise."""
        if self.failure_kind is not None:
            return self.failure_kind
        return "collision" if self.status == "fail" else self.status

    def to_dict(self, *, with_trace: bool = False) -> dict[str, Any]:
        """JSON-serialisable form (the trace only if asked)."""
        data = asdict(self)
        if not with_trace:
            data.pop("trace")
        return data

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Outcome:
        """Inverse of :meth:`to_dict`."""
        data = dict(data)
        trace = data.pop("trace", None)
        if trace is not None:
            trace = Trace(**trace)
        return cls(**data, trace=trace)

    @classmethod
    def errored(cls, message: str, *, status: str = "error") -> Outcome:
        """The outcome stored for a run that raised (``error``) or ran out of wall time."""
        reason = "wall_timeout" if status == "timeout" else "error"
        return cls(status=status, end_reason=reason, message=message)


class Backend(abc.ABC):
    """A simulator that runs one situation with one AV stack.

    ``run`` must be deterministic: the same situation, stack configuration and seed give
    the identical outcome on every call and machine. All randomness comes from
    ``numpy.random.default_rng(seed)`` or generators derived from it.
    """

    #: Registry name, e.g. ``"embedded"``.
    name: ClassVar[str]

    @abc.abstractmethod
    def run(
        self, situation: Situation, av_stack: AVStack, seed: int, *, record: bool = False
    ) -> Outcome:
        """Simulate ``situation`` with ``av_stack`` driving the ego; judge the run."""

    def effects(self) -> dict[str, str]:
        """Element name -> one-line description of its effect in this backend.

        Elements of a hyperspace that are not listed have no effect in this backend, and
        the campaign says so before it starts.
        """
        return {}

    def close(self) -> None:  # noqa: B027
        """Release resources (server connections, processes)."""
