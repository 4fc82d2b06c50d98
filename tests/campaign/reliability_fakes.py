"""A backend that runs out of memory on some seeds (loaded as ``reliability_fakes:HogBackend``).

On a "hog" seed it allocates far more than a limit allows, the way a leaking simulator or
stack would. The limit is either a memory cgroup the process joins first (``cgroup``: the
kernel's OOM killer then SIGKILLs the worker, as on a real machine) or an address-space
rlimit (``limit_mb`` above what the process uses: the allocation fails with MemoryError).
Only ever used in worker processes, never in the test process itself.
"""

from __future__ import annotations

import os
import resource
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
from campaign_fakes import FakeBackend

from sitcov.av import AVStack
from sitcov.sim import Outcome


def hogs(seed: int, rate: float) -> bool:
    """Whether HogBackend runs out of memory on this seed (deterministic)."""
    return bool(np.random.default_rng([int(seed), 31]).random() < rate)


class HogBackend(FakeBackend):
    """FakeBackend whose hog seeds allocate until a memory limit stops them."""

    name: ClassVar[str] = "hog"

    def __init__(
        self, hog_rate: float = 0.1, cgroup: str | None = None, limit_mb: int = 300, **kw: Any
    ) -> None:
        super().__init__(**kw)
        self.hog_rate, self.cgroup, self.limit_mb = hog_rate, cgroup, limit_mb

    def run(self, situation: Any, av_stack: AVStack, seed: int, *, record: bool = False) -> Outcome:
        if hogs(seed, self.hog_rate):
            self._hog()
        return super().run(situation, av_stack, seed, record=record)

    def _hog(self) -> None:
        if self.cgroup:
            Path(self.cgroup, "cgroup.procs").write_text(str(os.getpid()))  # v1 and v2
            _allocate(10 * self.limit_mb)  # the OOM killer ends this process here
        soft, hard = resource.getrlimit(resource.RLIMIT_AS)
        in_use = int(Path("/proc/self/statm").read_text().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        resource.setrlimit(resource.RLIMIT_AS, (in_use + (self.limit_mb << 20), hard))
        try:
            _allocate(10 * self.limit_mb)  # raises MemoryError
        finally:
            resource.setrlimit(resource.RLIMIT_AS, (soft, hard))


def _allocate(megabytes: int) -> list[bytearray]:
    """Touch ``megabytes`` MiB of memory, 1 MiB at a time."""
    return [bytearray(1 << 20) for _ in range(megabytes)]
