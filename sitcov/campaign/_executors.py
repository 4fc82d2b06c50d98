"""Executors: where runs execute - in this process, in local worker processes, or on Ray.

Every executor takes tasks ``(index, situation, seed)`` and yields ``(index, outcome,
wall_time)`` as runs finish, possibly out of order. A run's outcome depends only on its
situation, seed and the config, so every executor stores the same results.

Workers (processes or Ray actors) build the backend and the AV stack ONCE, when they
start, and keep them for all their runs. A run that raises is returned as ``error`` with
the exception's message and traceback (see :func:`error_message`) and the worker keeps
serving, except a
:class:`~sitcov.errors.SetupError` (the campaign cannot run at all: a missing model or
optional package), which stops the campaign with that error. A run that exceeds
``config.run_timeout`` seconds of wall time is returned as ``timeout``:

- ``serial``: a ``SIGALRM`` timer interrupts the run (main thread on POSIX only; elsewhere
  the limit is not enforced), then backend and stack are rebuilt;
- ``processes``: the worker is killed and replaced by a fresh one;
- ``ray``: the actor is killed and replaced.
"""

from __future__ import annotations

import abc
import contextlib
import logging
import multiprocessing as mp
import os
import signal
import sys
import threading
import time
import traceback
from collections import deque
from collections.abc import Iterable, Iterator
from multiprocessing.connection import wait
from typing import Any

from sitcov.campaign._build import build_backend, build_stack
from sitcov.campaign._config import CampaignConfig
from sitcov.errors import MissingExtraError, SetupError, SitcovError, StackError
from sitcov.hyperspace import Situation
from sitcov.sim import STATUSES, Outcome

#: A task: (run index, situation as ``Situation.to_dict()``, simulation seed).
Task = tuple[int, dict, int]
#: A result: (run index, outcome, wall-clock seconds).
Result = tuple[int, Outcome, float]

log = logging.getLogger("sitcov.campaign")

_STARTUP_TIMEOUT = 600.0  # [s] for a worker to import and build backend + stack
#: Tasks in flight per worker process: the next one already waits in the worker's pipe, so
#: a worker never idles while the parent stores a result (matters on busy machines).
_PIPELINE = 2


class _WallTimeout(BaseException):
    """Raised by the SIGALRM handler inside a run (BaseException: stacks can't swallow it)."""


def _timeout_outcome(limit: float) -> Outcome:
    return Outcome.errored(f"run exceeded the wall-time limit of {limit:g} s", status="timeout")


def execute(backend: Any, stack: Any, task: Task, record: bool) -> Result:
    """Run one task, turning any exception into an ``error`` (or ``timeout``) outcome.

    Raises:
        SetupError: the campaign cannot run at all (e.g. the camera model is missing);
            re-raised instead of stored, so the campaign stops at once.
    """
    index, situation, seed = task
    start = time.perf_counter()
    try:
        outcome = backend.run(Situation.from_dict(situation), stack, seed, record=record)
        if not isinstance(outcome, Outcome) or outcome.status not in STATUSES:
            outcome = Outcome.errored(f"backend returned an invalid outcome: {outcome!r:.200}")
    except SetupError:
        raise
    except StackError as exc:
        outcome = Outcome.errored(error_message(exc), status=exc.status)
    except Exception as exc:
        outcome = Outcome.errored(error_message(exc))
    return index, outcome, time.perf_counter() - start


#: Characters of a traceback kept in a stored error message (its end: where it was raised).
TRACEBACK_CHARS = 4000


def error_message(exc: BaseException) -> str:
    """``Type: message`` on the first line, then the traceback (its last TRACEBACK_CHARS).

    The first line is what one-line views (JUnit attribute, tables) show; the traceback is
    what makes a bug in a backend or stack findable from the stored run alone.
    """
    head = " ".join(f"{type(exc).__name__}: {exc}".splitlines())[:500]
    trace = "".join(traceback.format_exception(type(exc), exc, exc.__traceback__))
    if len(trace) > TRACEBACK_CHARS:
        trace = "... (traceback truncated)\n" + trace[-TRACEBACK_CHARS:]
    return f"{head}\n{trace.rstrip()}"


class Executor(abc.ABC):
    """Runs tasks; ``map`` yields results as they finish."""

    def __init__(self, config: CampaignConfig) -> None:
        self.config = config

    @abc.abstractmethod
    def map(self, tasks: Iterable[Task]) -> Iterator[Result]:
        """Run every task; yield each result once, in any order."""

    def close(self) -> None:  # noqa: B027
        """Stop workers and release backends."""

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class SerialExecutor(Executor):
    """Runs tasks one after another in this process (timeouts via SIGALRM)."""

    def __init__(self, config: CampaignConfig, backend: Any = None) -> None:
        super().__init__(config)
        self._backend = backend if backend is not None else build_backend(config)
        self._stack = build_stack(config)

    def _alarm_usable(self) -> bool:
        return (
            self.config.run_timeout is not None
            and hasattr(signal, "setitimer")
            and threading.current_thread() is threading.main_thread()
        )

    def map(self, tasks: Iterable[Task]) -> Iterator[Result]:
        for task in tasks:
            if not self._alarm_usable():
                yield execute(self._backend, self._stack, task, self.config.record_traces)
                continue
            yield self._run_with_alarm(task)

    def _run_with_alarm(self, task: Task) -> Result:
        limit = float(self.config.run_timeout)  # type: ignore[arg-type]

        def on_alarm(signum: int, frame: Any) -> None:
            raise _WallTimeout

        previous = signal.signal(signal.SIGALRM, on_alarm)
        start = time.perf_counter()
        try:
            signal.setitimer(signal.ITIMER_REAL, limit)
            try:
                return execute(self._backend, self._stack, task, self.config.record_traces)
            finally:
                signal.setitimer(signal.ITIMER_REAL, 0)
        except _WallTimeout:
            # The interrupted backend/stack may be mid-step: start from fresh ones.
            self._rebuild()
            return task[0], _timeout_outcome(limit), time.perf_counter() - start
        finally:
            signal.signal(signal.SIGALRM, previous)

    def _rebuild(self) -> None:
        for part in (self._stack, self._backend):
            with contextlib.suppress(Exception):  # best effort on a broken part
                part.close()
        self._backend = build_backend(self.config)
        self._stack = build_stack(self.config)

    def close(self) -> None:
        self._stack.close()
        self._backend.close()


# -- local processes -------------------------------------------------------------------------


def _worker_main(conn: Any, config_data: dict, worker_index: int) -> None:
    """A worker process: build backend + stack once, then serve tasks until told to stop."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent handles Ctrl-C
    try:
        config = CampaignConfig(**config_data)
        backend = build_backend(config, worker_index=worker_index)
        stack = build_stack(config)
    except BaseException as exc:
        conn.send(("fatal", f"{type(exc).__name__}: {exc}"))
        return
    conn.send(("ready", os.getpid()))
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            break  # the parent is gone
        if task is None:
            break
        try:
            try:
                message = ("result", execute(backend, stack, task, config.record_traces))
            except SetupError as exc:
                message = ("fatal", str(exc))  # the campaign cannot run: the parent stops
            conn.send(message)
        except (BrokenPipeError, OSError):
            break  # the parent is gone
    stack.close()
    backend.close()


def _exit_text(code: int | None) -> str:
    """``exit code 3``, or ``killed by SIGKILL (the out-of-memory killer sends it)``."""
    if code is None or code >= 0:
        return f"exit code {code}"
    try:
        name = signal.Signals(-code).name
    except ValueError:
        name = f"signal {-code}"
    hint = " (the out-of-memory killer sends it)" if name == "SIGKILL" else ""
    return f"exit code {code}: killed by {name}{hint}"


class _Worker:
    def __init__(self, ctx: Any, config_data: dict, index: int) -> None:
        self.index = index
        self.conn, child = ctx.Pipe()
        self.process = ctx.Process(
            target=_worker_main, args=(child, config_data, index), daemon=True
        )
        self.process.start()
        child.close()
        self.inflight: deque[Task] = deque()  # sent, not yet answered; the first is running
        self.deadline = float("inf")  # [monotonic s] when the running task times out

    def wait_ready(self) -> None:
        if not self.conn.poll(_STARTUP_TIMEOUT):
            raise SitcovError(f"a campaign worker did not start within {_STARTUP_TIMEOUT:g} s")
        try:
            kind, payload = self.conn.recv()
        except EOFError:
            raise SitcovError("a campaign worker died while starting") from None
        if kind != "ready":
            raise SitcovError(f"a campaign worker could not start: {payload}")

    def kill(self) -> None:
        self.process.kill()
        self.process.join(5)
        self.conn.close()


class ProcessExecutor(Executor):
    """Persistent local worker processes (``spawn``), one backend + stack each.

    Args:
        config: the campaign config (``workers`` processes are started).
    """

    def __init__(self, config: CampaignConfig) -> None:
        super().__init__(config)
        self._ctx = mp.get_context("spawn")
        self._data = config.model_dump(mode="json")
        self._workers = [_Worker(self._ctx, self._data, k) for k in range(config.workers)]
        try:
            for worker in self._workers:
                worker.wait_ready()
        except BaseException:
            self.close()
            raise

    def _replace(self, worker: _Worker) -> _Worker:
        worker.kill()
        fresh = _Worker(self._ctx, self._data, worker.index)
        fresh.wait_ready()
        self._workers[self._workers.index(worker)] = fresh
        return fresh

    def map(self, tasks: Iterable[Task]) -> Iterator[Result]:
        queue = deque(tasks)
        limit = self.config.run_timeout

        def give_back(worker: _Worker) -> Task:
            """Take the worker's tasks back: the running one is returned, the rest re-queued."""
            head = worker.inflight.popleft()
            queue.extendleft(reversed(worker.inflight))
            worker.inflight.clear()
            return head

        while queue or any(w.inflight for w in self._workers):
            now = time.monotonic()
            for worker in list(self._workers):
                while queue and len(worker.inflight) < _PIPELINE:
                    if not worker.inflight:
                        worker.deadline = now + limit if limit else float("inf")
                    try:
                        worker.conn.send(queue[0])
                    except OSError:  # the worker died (killed): its running task's EOF is
                        if not worker.inflight:  # handled below; an idle one is replaced
                            self._replace(worker)
                        break
                    worker.inflight.append(queue.popleft())
            busy = {w.conn: w for w in self._workers if w.inflight}
            soonest = min(w.deadline for w in busy.values())
            timeout = None if soonest == float("inf") else max(0.0, soonest - time.monotonic())
            for conn in wait(list(busy), timeout):
                worker = busy[conn]
                try:
                    _kind, payload = conn.recv()
                except (EOFError, OSError):
                    worker.process.join(5)  # reaped, so its exit code is known
                    task, code = give_back(worker), worker.process.exitcode
                    self._replace(worker)
                    message = f"the worker process died ({_exit_text(code)})"
                    yield task[0], Outcome.errored(message), 0.0
                    continue
                if _kind == "fatal":
                    raise SetupError(payload)
                worker.inflight.popleft()
                # the next queued task starts now in the worker: its clock starts now
                worker.deadline = time.monotonic() + limit if limit else float("inf")
                yield payload
            now = time.monotonic()
            for worker in list(self._workers):
                if worker.inflight and worker.deadline <= now:
                    task = give_back(worker)
                    self._replace(worker)
                    yield task[0], _timeout_outcome(float(limit)), float(limit)

    def close(self) -> None:
        for worker in self._workers:
            with contextlib.suppress(OSError, ValueError):
                worker.conn.send(None)
        for worker in self._workers:
            worker.process.join(5)
            if worker.process.is_alive():
                worker.process.kill()
                worker.process.join(5)
            worker.conn.close()
        self._workers = []


# -- Ray ---------------------------------------------------------------------------------------


class _RayWorker:
    """A Ray actor holding one backend + stack."""

    def __init__(self, config_data: dict, worker_index: int) -> None:
        self.config = CampaignConfig(**config_data)
        self.backend = build_backend(self.config, worker_index=worker_index)
        self.stack = build_stack(self.config)

    def ready(self) -> bool:
        return True

    def run(self, task: Task) -> Result | tuple[str, str]:
        try:
            return execute(self.backend, self.stack, task, self.config.record_traces)
        except SetupError as exc:
            return ("fatal", str(exc))  # the campaign cannot run: the driver raises it


#: Times a run is started on Ray before a lost worker (a dead node, a crashed actor) is
#: stored as the run's ``error``: a run lost with its node is re-run elsewhere, but a run
#: that itself kills its worker every time must not loop forever.
RAY_ATTEMPTS = 3


class RayExecutor(Executor):
    """Ray actors (one backend + stack each), on ``ray_address`` or a local Ray started here.

    A run whose actor dies (its node was lost, its process crashed) is re-run on another
    actor, up to :data:`RAY_ATTEMPTS` times in all, then stored as ``error``; the dead actor
    is replaced without waiting for the replacement (on a cluster that lost a node it may
    never find room: the surviving actors carry on alone). Runs are deterministic, so a
    re-run stores exactly what the lost one would have.

    Raises:
        MissingExtraError: ray is not installed.
    """

    def __init__(self, config: CampaignConfig) -> None:
        super().__init__(config)
        try:
            import ray
        except ImportError:
            raise MissingExtraError("the ray executor", "ray", "ray") from None
        self._ray = ray
        self._owns = not ray.is_initialized()
        if self._owns:
            env = {"PYTHONPATH": os.pathsep.join(p for p in sys.path if p)}
            kwargs: dict[str, Any] = {
                "include_dashboard": False,
                "log_to_driver": False,
                "runtime_env": {"env_vars": env},
            }
            if config.ray_address:
                ray.init(address=config.ray_address, **kwargs)
            else:
                ray.init(num_cpus=config.workers, **kwargs)
        self._actor_cls = ray.remote(num_cpus=1)(_RayWorker)
        self._data = config.model_dump(mode="json")
        self._actors = [self._actor_cls.remote(self._data, k) for k in range(config.workers)]
        #: ready() of actors that replace dead ones -> their slot (not yet serving)
        self._starting: dict[Any, int] = {}
        try:
            self._ray.get([a.ready.remote() for a in self._actors], timeout=_STARTUP_TIMEOUT)
        except Exception as exc:
            self.close()
            raise SitcovError(
                f"a Ray campaign worker could not start: {_first_line(exc)}"
            ) from None

    def _replace(self, slot: int) -> None:
        """Kill the actor of ``slot`` and start another (without waiting for it)."""
        with contextlib.suppress(Exception):  # it may be dead already
            self._ray.kill(self._actors[slot])
        self._actors[slot] = self._actor_cls.remote(self._data, slot)
        self._starting[self._actors[slot].ready.remote()] = slot

    def _started(self, ref: Any) -> int:
        """The slot whose replacement actor answered ``ref``; raises if it could not start."""
        slot = self._starting.pop(ref)
        try:
            self._ray.get(ref)
        except self._ray.exceptions.RayTaskError as exc:  # its constructor raised
            raise SitcovError(
                f"a Ray campaign worker could not start: {_first_line(exc)}"
            ) from None
        except Exception:  # lost before it started (its node died too): try again
            self._replace(slot)
            return -1
        return slot

    def map(self, tasks: Iterable[Task]) -> Iterator[Result]:
        queue: deque[tuple[Task, int]] = deque((task, 1) for task in tasks)
        limit = self.config.run_timeout
        starting = set(self._starting.values())  # replacements from an earlier batch
        idle = [slot for slot in range(len(self._actors)) if slot not in starting]
        busy: dict[Any, tuple[int, Task, int, float]] = {}  # ref -> slot, task, attempt, deadline
        while queue or busy:
            while queue and idle:
                slot = idle.pop()
                task, attempt = queue.popleft()
                ref = self._actors[slot].run.remote(task)
                deadline = time.monotonic() + limit if limit else float("inf")
                busy[ref] = (slot, task, attempt, deadline)
            soonest = min((d for *_, d in busy.values()), default=float("inf"))
            timeout = None if soonest == float("inf") else max(0.0, soonest - time.monotonic())
            if not busy:
                timeout = _STARTUP_TIMEOUT  # only replacements starting: wait for one
            waiting = [*busy, *self._starting]
            done, _ = self._ray.wait(waiting, num_returns=1, timeout=timeout)
            if not done and not busy:
                raise SitcovError(
                    f"no Ray campaign worker could start within {_STARTUP_TIMEOUT:g} s "
                    "(has the cluster lost its nodes?)"
                )
            for ref in done:
                if ref in self._starting:
                    slot = self._started(ref)
                    if slot >= 0:
                        idle.append(slot)
                    continue
                yield from self._finished(ref, busy, idle, queue)
            yield from self._expired(busy, idle, limit)

    def _finished(
        self,
        ref: Any,
        busy: dict[Any, tuple[int, Task, int, float]],
        idle: list[int],
        queue: deque[tuple[Task, int]],
    ) -> Iterator[Result]:
        """Yield the result of a finished task, or re-queue it if its actor was lost."""
        slot, task, attempt, _ = busy.pop(ref)
        try:
            result = self._ray.get(ref)
        except Exception as exc:  # the actor died (a lost node, a crash) or its result was lost
            self._replace(slot)
            reason = _first_line(exc)
            if attempt >= RAY_ATTEMPTS:
                message = f"the Ray worker died {attempt} times running this run: {reason}"
                yield task[0], Outcome.errored(message), 0.0
                return
            log.warning("run %d lost with its Ray worker (%s); running it again", task[0], reason)
            queue.appendleft((task, attempt + 1))
            return
        idle.append(slot)
        if result[0] == "fatal":
            raise SetupError(result[1])
        yield result

    def _expired(
        self, busy: dict[Any, tuple[int, Task, int, float]], idle: list[int], limit: float | None
    ) -> Iterator[Result]:
        """Yield ``timeout`` for runs past their deadline; their actors are replaced."""
        now = time.monotonic()
        for ref, (slot, task, _, deadline) in list(busy.items()):
            if deadline <= now:
                busy.pop(ref)
                self._replace(slot)
                yield task[0], _timeout_outcome(float(limit)), float(limit)  # type: ignore[arg-type]

    def close(self) -> None:
        for actor in self._actors:
            with contextlib.suppress(Exception):  # dead, or never placed
                self._ray.kill(actor)
        self._actors = []
        self._starting = {}
        if self._owns:
            self._ray.shutdown()


def _first_line(exc: BaseException) -> str:
    """``Type: message`` of an exception on one line (Ray errors carry long tracebacks)."""
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}"[:300]


def make_executor(config: CampaignConfig, backend: Any = None) -> Executor:
    """The executor named by ``config.executor`` (``backend`` is reused by ``serial``)."""
    if config.executor == "serial":
        return SerialExecutor(config, backend)
    if config.executor == "ray":
        return RayExecutor(config)
    return ProcessExecutor(config)
