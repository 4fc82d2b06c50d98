"""Who runs a campaign: the owner record of a campaign lock, and whether that owner lives.

A campaign being run is marked in its database by one row (see
:meth:`sitcov.campaign._sqlite.SQLiteStore.lock_campaign`): the owner's process id, host,
process start marker, start time and a heartbeat. A second process that wants to run the
same campaign reads that row and refuses while the owner is alive; a dead owner's row is
taken over.

Whether the owner is alive is decided in two ways:

- same host: the process id exists, is not a zombie, and (on Linux) was started at the
  recorded moment (``/proc/PID/stat`` start time), so a recycled process id is not
  mistaken for the owner;
- another host (a database on a shared disk): the heartbeat, refreshed every
  :data:`HEARTBEAT` seconds by the owner, is younger than the staleness limit.
"""

from __future__ import annotations

import os
import socket
import time
import uuid
from dataclasses import dataclass
from datetime import datetime, timezone
from pathlib import Path

#: Seconds between heartbeats of a lock's owner.
HEARTBEAT = 5.0
#: Default seconds without a heartbeat after which another host's lock counts as stale.
STALE_AFTER = 60.0

#: Tokens of the locks this process holds now (a lock of this pid that is not here was
#: left by an earlier, failed attempt in this same process and is stale).
HELD: set[str] = set()


def this_host() -> str:
    """The name this machine's locks are recorded under."""
    return socket.gethostname()


def process_start(pid: int) -> int | None:
    """When process ``pid`` started (clock ticks since boot; Linux), None if unknown."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return int(fields[19])  # field 22 of stat(5); fields[0] is field 3


def _zombie(pid: int) -> bool:
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return False
    return text[text.rindex(")") + 2 :].startswith("Z")


def pid_alive(pid: int, start: int | None) -> bool:
    """True if process ``pid`` exists on this host, is not a zombie, and started at ``start``
    (when both that and the process's start time are known)."""
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass  # another user's process: it exists
    except OverflowError:
        return False
    if _zombie(pid):
        return False
    now = process_start(pid)
    return start is None or now is None or now == start


@dataclass(frozen=True)
class LockOwner:
    """The process recorded as running a campaign.

    Attributes:
        campaign: the campaign's name.
        token: unique per acquisition (a fencing token: writes check it is still theirs).
        pid: the owner's process id on ``host``.
        host: the owner's host name.
        pid_start: the owner process's start marker (:func:`process_start`), or None.
        started: when the lock was taken, ISO 8601 UTC.
        heartbeat: the owner's last heartbeat, seconds since the epoch.
    """

    campaign: str
    token: str
    pid: int
    host: str
    pid_start: int | None
    started: str
    heartbeat: float

    @classmethod
    def me(cls, campaign: str) -> LockOwner:
        """A new owner record for this process."""
        pid = os.getpid()
        return cls(
            campaign=campaign,
            token=uuid.uuid4().hex,
            pid=pid,
            host=this_host(),
            pid_start=process_start(pid),
            started=datetime.now(timezone.utc).isoformat(timespec="seconds"),
            heartbeat=time.time(),
        )

    def alive(self, stale_after: float = STALE_AFTER, now: float | None = None) -> bool:
        """Whether the owner still runs the campaign (see the module docstring)."""
        if self.host == this_host():
            if self.pid == os.getpid():
                return self.token in HELD
            return pid_alive(self.pid, self.pid_start)
        now = time.time() if now is None else now
        return now - self.heartbeat < stale_after

    def describe(self, now: float | None = None) -> str:
        """``pid 123 on host h since 2026-...Z (last heartbeat 2 s ago)``."""
        now = time.time() if now is None else now
        age = max(0.0, now - self.heartbeat)
        return (
            f"pid {self.pid} on host {self.host} since {self.started} "
            f"(last heartbeat {age:.0f} s ago)"
        )
