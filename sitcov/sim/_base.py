"""The backend interface and the outcome of a run."""

from __future__ import annotations

import abc
import math
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
#: is everything before physics profiles and failure kinds.
WORLD_MODEL_VERSION = 2


@dataclass(frozen=True)
class Conditions:
    """Physical quantities derived from a situation's environment elements.

    Dynamics read ``mu`` and ``wind_lateral_accel``; sensors read the rest. The mapping
    from CARLA-unit weather values to these quantities is documented in
    ``sitcov.sim.conditions_from_values``.

    Attributes:
        mu: effective tyre-road friction coefficient [-].
        fog_extinction: fog extinction coefficient beta [1/m] (Koschmieder: visibility 3.912/beta).
        fog_start: distance from the camera at which fog begins [m].
        illumination: relative scene illumination in (0, 1], 1 = clear noon.
        rain_noise: perception noise intensity in [0, 1] from rain, spray and glare.
        wind_speed: mean wind speed [m/s].
        wind_lateral_accel: RMS of the wind's lateral acceleration [m/s^2] (0 in the
            ``carla`` physics profile: CARLA's wind moves no vehicle).
        raw: the environment values as given (CARLA units), for renderers.
    """

    mu: float = 1.0
    fog_extinction: float = 0.0
    fog_start: float = 0.0
    illumination: float = 1.0
    rain_noise: float = 0.0
    wind_speed: float = 0.0
    wind_lateral_accel: float = 0.0
    raw: dict[str, Any] = field(default_factory=dict)

    def transmittance(self, distance: float) -> float:
        """Fraction of contrast that survives fog over ``distance`` metres (Beer-Lambert)."""
        return math.exp(-self.fog_extinction * max(0.0, distance - self.fog_start))

    @property
    def visibility(self) -> float:
        """Meteorological visibility [m] (inf without fog)."""
        if self.fog_extinction <= 0:
            return math.inf
        return self.fog_start + 3.912 / self.fog_extinction


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
            backend reports ``road_departure_time`` and ``lane_departure_time`` here.
        failure_kind: set by the campaign's judge: ``pass``, ``collision``,
            ``road_departure``, ``lane_departure``, ``error`` or ``timeout``; None for an
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
