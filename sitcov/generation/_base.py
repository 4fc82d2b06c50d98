"""The generator interface: how the campaign asks for situations and reports outcomes."""

from __future__ import annotations

import abc
from typing import TYPE_CHECKING, Any, ClassVar

if TYPE_CHECKING:
    import numpy as np

    from sitcov.hyperspace import Hyperspace, Situation
    from sitcov.sim import Outcome


class Generator(abc.ABC):
    """Chooses the next situation to test (the analogue of an Optuna sampler).

    The campaign calls, in this order, for each batch of ``B`` runs (``B`` fixed by the
    campaign, independent of how many workers execute it):

    1. ``ask(rng)`` ``B`` times, with ``rng`` derived from (campaign seed, run index);
    2. ``state()``, stored in the same transaction as the ``B`` planned runs;
    3. after the batch has run, ``tell(situation, outcome)`` for each run in run-index order.

    ``from_state(hyperspace, state)`` must rebuild a generator that continues exactly as the
    original would have: asking 50, saving, restoring and asking 50 more gives the same
    100 situations as asking 100 at once. ``state()`` returns JSON-serialisable data.

    Generators never touch global random state; every random choice uses the ``rng`` given.
    """

    #: Registry name, e.g. ``"sitcov"``.
    name: ClassVar[str]
    #: True if ``tell`` changes what later asks return (the campaign then works in batches).
    learns: ClassVar[bool] = False

    def __init__(self, hyperspace: Hyperspace, **options: Any) -> None:
        self.hyperspace = hyperspace

    @abc.abstractmethod
    def ask(self, rng: np.random.Generator) -> Situation:
        """Return the next situation; may update internal counts."""

    def tell(self, situation: Situation, outcome: Outcome) -> None:  # noqa: B027
        """Learn from a finished run; the default ignores it."""

    @abc.abstractmethod
    def state(self) -> dict[str, Any]:
        """JSON-serialisable state from which :meth:`from_state` resumes exactly."""

    @classmethod
    @abc.abstractmethod
    def from_state(cls, hyperspace: Hyperspace, state: dict[str, Any]) -> Generator:
        """Rebuild a generator from :meth:`state` output."""
