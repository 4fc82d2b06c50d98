"""An AV stack running as a separate process (any language), driven over protocol v1.

The stack is a black box: sitcov starts the command, greets it, and for every run sends
``reset`` then one ``step`` per control period, each answered by a ``control`` within the
step time-out. A stack that crashes, writes garbage or hangs fails *that run* (``StackError``
/ ``StackTimeoutError`` from ``step``): its whole process group is killed, and the next
``reset`` starts it afresh. Nothing outlives :meth:`ExternalProcessStack.close` (or garbage
collection / interpreter exit): no zombies, no orphans - not even descendants that left the
stack's process group (``setsid``): every process started carries a per-stack token in its
environment (:data:`TOKEN_VAR`), and killing a stack also kills every process of this user
that still carries it (Linux ``/proc``).

What a stack writes is bounded: a stdout line longer than :data:`MAX_LINE` bytes fails the
run at once (memory stays bounded, whatever the stack floods), stderr is read in pieces of
at most :data:`_STDERR_PIECE` bytes, and invalid UTF-8 or JSON is a protocol error.
"""

from __future__ import annotations

import collections
import contextlib
import ctypes
import logging
import mmap
import os
import select
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import uuid
import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sitcov._version import __version__
from sitcov.av import _protocol as proto
from sitcov.av._base import AVStack, Control, Observation, RunInfo
from sitcov.errors import ConfigError, StackError, StackTimeoutError

log = logging.getLogger("sitcov.av.external")

#: Time a stack may take to start and answer the hello, or to answer a reset [s].
START_TIMEOUT = 10.0
#: Time a stack gets to exit after ``close`` before it is killed [s].
CLOSE_GRACE = 1.0
#: Stderr lines kept to quote when the stack fails [lines].
_STDERR_TAIL = 20
_CHUNK = 1 << 16  # bytes read from the stack's stdout at a time
#: Longest stdout line a stack may write [bytes]; a control message is well under 1 KiB.
MAX_LINE = 4 << 20
_EXIT_POLL = 0.25  # [s] how often a silent stack is checked for having exited
_STDERR_PIECE = 1 << 14  # longest piece of a stderr line logged or quoted [bytes]
#: Environment variable carrying the per-stack token that marks all its processes.
TOKEN_VAR = "SITCOV_STACK_TOKEN"
_PR_SET_PDEATHSIG = 1  # prctl option, linux/prctl.h


def _require_executable(program: str, cwd: str | Path | None) -> None:
    """Refuse a command whose program cannot be found, before any run is stored."""
    if os.sep in program:
        path = Path(cwd or ".") / program
        found = path.is_file() and os.access(path, os.X_OK)
    else:
        found = shutil.which(program) is not None
    if not found:
        raise ConfigError(
            field="av_cmd",
            value=program,
            expected="an executable program (not found or not executable)",
        )


def _marked(token: str) -> list[int]:
    """Processes of this user whose environment carries ``token`` (Linux; else none)."""
    needle = f"{TOKEN_VAR}={token}".encode()
    found = []
    try:
        entries = os.listdir("/proc")
    except OSError:
        return found
    for entry in entries:
        if not entry.isdigit() or int(entry) == os.getpid():
            continue
        try:
            with open(f"/proc/{entry}/environ", "rb") as f:
                environ = f.read()
        except OSError:  # gone, or another user's process
            continue
        if needle in environ.split(b"\0"):
            found.append(int(entry))
    return found


def _kill_group(proc: subprocess.Popen, token: str | None = None) -> None:
    """SIGKILL the process group of ``proc`` (its own session) and every process still
    marked with ``token`` (descendants that left the group), then reap ``proc``."""
    if proc.poll() is None:
        with contextlib.suppress(ProcessLookupError, PermissionError):
            os.killpg(proc.pid, signal.SIGKILL)
    for _ in range(3 if token else 0):  # a fork racing the sweep is caught by the next one
        escaped = _marked(token)
        if not escaped:
            break
        for pid in escaped:
            with contextlib.suppress(ProcessLookupError, PermissionError):
                os.kill(pid, signal.SIGKILL)
    with contextlib.suppress(Exception):
        proc.wait(timeout=5.0)
    for pipe in (proc.stdin, proc.stdout):
        with contextlib.suppress(Exception):
            if pipe is not None:
                pipe.close()


def _die_with_parent() -> Callable[[], None] | None:
    """A ``preexec_fn`` making the child get SIGKILL when its parent dies (Linux only).

    Without it, a stack that hangs while sitcov's worker process is killed (e.g. by a
    campaign's run time-out) would live on as an orphan. Linux delivers the signal when
    the *thread* that started the child exits, so it is used only from the main thread.
    """
    if not sys.platform.startswith("linux") or threading.current_thread() is not (
        threading.main_thread()
    ):
        return None
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):  # pragma: no cover - exotic libc
        return None
    parent = os.getpid()

    def preexec() -> None:
        prctl(_PR_SET_PDEATHSIG, signal.SIGKILL)
        if os.getppid() != parent:  # the parent died before prctl took effect
            os._exit(1)

    return preexec


def _pump_stderr(proc: subprocess.Popen, tail: collections.deque, path: str | None) -> None:
    """Forward the stack's stderr lines to the log (and ``path``), keeping the last ones.

    A plain function, not a method: the thread must not keep the stack object alive, so
    that garbage collection can still end a forgotten stack's process.
    """
    sink = open(path, "a", encoding="utf-8") if path else None  # noqa: SIM115
    try:  # readline with a limit: a flood without newlines is read piece by piece
        for raw in iter(lambda: proc.stderr.readline(_STDERR_PIECE), b""):
            line = raw.decode("utf-8", "replace").rstrip("\n")
            tail.append(line)
            log.info("[%s] %s", proc.pid, line)
            if sink is not None:
                sink.write(line + "\n")
                sink.flush()
    except (OSError, ValueError):
        pass
    finally:
        if sink is not None:
            sink.close()
        with contextlib.suppress(Exception):
            proc.stderr.close()


def _shm_dir() -> str:
    """A RAM-backed directory for frame files when there is one, else the temp dir."""
    shm = "/dev/shm"
    return shm if os.path.isdir(shm) and os.access(shm, os.W_OK) else tempfile.gettempdir()


class _FrameFile:
    """A per-run shared file holding the current camera frame as raw HxWx3 uint8 bytes."""

    def __init__(self, nbytes: int) -> None:
        fd, self.path = tempfile.mkstemp(prefix="sitcov-frame-", suffix=".rgb", dir=_shm_dir())
        try:
            os.ftruncate(fd, nbytes)
            self.map = mmap.mmap(fd, nbytes)
        finally:
            os.close(fd)
        self.nbytes = nbytes

    def write(self, data: memoryview) -> None:
        self.map[:] = data

    def close(self) -> None:
        with contextlib.suppress(Exception):
            self.map.close()
        with contextlib.suppress(FileNotFoundError):
            os.unlink(self.path)


class ExternalProcessStack(AVStack):
    """Drive an AV stack that runs as its own process and speaks protocol v1.

    Args:
        cmd: the command, a list of arguments or a string split like a shell would
            (no shell features; use ``["sh", "-c", "..."]`` for those).
        step_timeout: wall-clock seconds the stack has to answer each step [s].
        grey_box: send the situation in each ``reset`` when the backend provides it
            (``RunInfo.situation``; the embedded backend does with ``grey_box=True``).
            Default: black box, the stack sees only what its sensors would.
        cwd: working directory of the stack process.
        env: extra environment variables for the stack process (added to sitcov's).
        start_timeout: seconds to start and answer the hello, and to answer a reset [s].
        stderr_log: a file to which the stack's stderr is appended (it is also logged
            on the ``sitcov.av.external`` logger and quoted when the stack fails).
    """

    name = "external"

    def __init__(
        self,
        cmd: str | list[str],
        step_timeout: float = 1.0,
        grey_box: bool = False,
        cwd: str | Path | None = None,
        env: dict[str, str] | None = None,
        *,
        start_timeout: float = START_TIMEOUT,
        stderr_log: str | Path | None = None,
    ) -> None:
        args = shlex.split(cmd) if isinstance(cmd, str) else [str(a) for a in cmd]
        if not args:
            raise ConfigError(field="av_cmd", value=cmd, expected="a non-empty command")
        for key, value in (("step_timeout", step_timeout), ("start_timeout", start_timeout)):
            if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
                raise ConfigError(
                    field=f"av_params.{key}", value=value, expected="a positive number of seconds"
                )
        _require_executable(args[0], cwd)
        self.args = args
        self.step_timeout = float(step_timeout)
        self.start_timeout = float(start_timeout)
        self.grey_box = bool(grey_box)
        self.cwd = None if cwd is None else str(cwd)
        self.env = dict(env or {})
        self.stderr_log = None if stderr_log is None else str(stderr_log)
        self.peer: dict[str, Any] = {}  # the stack's hello: name, wants, image_transport
        self.restarts = 0  # processes started after the first one
        self._proc: subprocess.Popen | None = None
        self._buffer = bytearray()
        self._stderr_tail: collections.deque[str] = collections.deque(maxlen=_STDERR_TAIL)
        self._stderr_thread: threading.Thread | None = None
        self._frame: _FrameFile | None = None
        self._started = 0
        self._finalizer: weakref.finalize | None = None
        self._token = uuid.uuid4().hex  # marks this stack's processes (see _kill_group)

    # -- pickling: a stack crosses process boundaries as its configuration only ----------

    def __getstate__(self) -> dict[str, Any]:
        keys = ("args", "step_timeout", "start_timeout", "grey_box", "cwd", "env", "stderr_log")
        return {k: getattr(self, k) for k in keys}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__init__(  # type: ignore[misc]
            state.pop("args"),
            state.pop("step_timeout"),
            state.pop("grey_box"),
            state.pop("cwd"),
            state.pop("env"),
            **state,
        )

    # -- AVStack -------------------------------------------------------------------------

    @property
    def who(self) -> str:
        """How errors name this stack."""
        return f"external stack {shlex.join(self.args)!r}"

    @property
    def pid(self) -> int | None:
        """The running stack process's id (None when not running)."""
        return self._proc.pid if self._proc is not None and self._proc.poll() is None else None

    @property
    def wants(self) -> str | None:
        """``detections`` or ``image`` once the stack has said hello."""
        return self.peer.get("wants")

    def reset(self, info: RunInfo) -> None:
        """Start the process if needed, then send ``reset`` and wait for ``ready``."""
        self._drop_frame()
        if self._proc is None or self._proc.poll() is not None:
            self._start()
        try:
            self._send(proto.reset(info, grey_box=self.grey_box))
            proto.expect(self._receive(self.start_timeout, "reset"), "ready", who=self.who)
        except StackError:
            self._kill()
            raise

    def step(self, observation: Observation) -> Control:
        """One protocol round trip; the stack is killed on any failure (restarted at reset)."""
        if self._proc is None:
            raise StackError(f"{self.who} is not running (it failed earlier in this run)")
        try:
            image, payload = self._image(observation)
            self._send(proto.step(observation, image), payload)
            return proto.parse_control(self._receive(self.step_timeout, "step"), who=self.who)
        except StackError:
            self._kill()
            raise

    def close(self) -> None:
        """Ask the stack to exit; kill its process group if it has not within a second."""
        proc = self._proc
        if proc is not None and proc.poll() is None:
            with contextlib.suppress(StackError):
                self._send({"type": "close"})
            with contextlib.suppress(subprocess.TimeoutExpired):
                proc.wait(timeout=CLOSE_GRACE)
        self._kill()

    def config(self) -> dict[str, Any]:
        """The command and protocol settings, stored with each run."""
        data = {
            "name": self.name,
            "cmd": self.args,
            "protocol": proto.PROTOCOL_VERSION,
            "step_timeout": self.step_timeout,
            "grey_box": self.grey_box,
        }
        if self.peer:
            data["stack_name"] = self.peer["name"]
        return data

    # -- process handling ----------------------------------------------------------------

    def _start(self) -> None:
        self._kill()
        env = {**os.environ, **self.env, TOKEN_VAR: self._token}
        try:
            proc = subprocess.Popen(
                self.args,
                stdin=subprocess.PIPE,
                stdout=subprocess.PIPE,
                stderr=subprocess.PIPE,
                cwd=self.cwd,
                env=env,
                start_new_session=True,  # own process group: killpg reaches grandchildren
                preexec_fn=_die_with_parent(),
                bufsize=0,
            )
        except OSError as exc:
            raise StackError(f"{self.who} cannot be started: {exc}") from exc
        os.set_blocking(proc.stdin.fileno(), False)
        self._proc = proc
        self._finalizer = weakref.finalize(self, _kill_group, proc, self._token)
        self._buffer.clear()
        self._stderr_tail.clear()
        self._stderr_thread = threading.Thread(
            target=_pump_stderr,
            args=(proc, self._stderr_tail, self.stderr_log),
            name=f"sitcov-stderr-{proc.pid}",
            daemon=True,
        )
        self._stderr_thread.start()
        if self._started:
            self.restarts += 1
        self._started += 1
        try:
            self._send(
                proto.hello(
                    step_timeout=self.step_timeout,
                    grey_box=self.grey_box,
                    version=__version__,
                )
            )
            self.peer = proto.parse_hello(self._receive(self.start_timeout, "hello"), who=self.who)
            self.min_box_width = self.peer.get("min_box_width", 0.0)
            self.min_box_sizes = self.peer.get("min_box_sizes", {})
            self.centre_window = self.peer.get("centre_window", (0.0, 1.0))
        except StackError:
            self._kill()
            raise
        log.debug("started %s (pid %d): %s", self.who, proc.pid, self.peer)

    def _kill(self) -> None:
        """Kill the process group (if any), reap it, and forget the process."""
        proc, self._proc = self._proc, None
        self._drop_frame()
        if proc is None:
            return
        if self._finalizer is not None:
            self._finalizer.detach()
            self._finalizer = None
        _kill_group(proc, self._token)
        if self._stderr_thread is not None:
            self._stderr_thread.join(timeout=2.0)
            self._stderr_thread = None

    def _failure(self, what: str) -> str:
        """A message saying how the process ended, with the tail of its stderr."""
        proc = self._proc
        code = None
        if proc is not None:
            with contextlib.suppress(subprocess.TimeoutExpired):
                code = proc.wait(timeout=1.0)
        if self._stderr_thread is not None:
            self._stderr_thread.join(timeout=1.0)
        tail = " | ".join(list(self._stderr_tail)[-5:])
        status = f"exited with code {code}" if code is not None else "closed its stdout"
        return f"{self.who} {status} during {what}" + (f"; stderr: {tail}" if tail else "")

    # -- I/O ---------------------------------------------------------------------------

    def _send(self, message: dict[str, Any], payload: memoryview | None = None) -> None:
        """Write a message (and raw bytes after it) without ever blocking past a time-out."""
        proc = self._proc
        assert proc is not None and proc.stdin is not None
        data = memoryview(proto.encode(message))
        timeout = self.step_timeout if message["type"] == "step" else self.start_timeout
        deadline = time.monotonic() + timeout
        fd = proc.stdin.fileno()
        for part in (data, payload):
            while part is not None and part.nbytes:
                try:
                    written = os.write(fd, part)
                except BlockingIOError:
                    written = 0
                except OSError as exc:  # BrokenPipeError: the stack has exited
                    raise StackError(self._failure(message["type"])) from exc
                part = part[written:]
                if part.nbytes:
                    remaining = deadline - time.monotonic()
                    if remaining <= 0:
                        raise StackTimeoutError(
                            f"{self.who} did not read its {message['type']} message "
                            f"within {timeout:g} s (wall clock)"
                        )
                    select.select([], [fd], [], remaining)

    def _receive(self, timeout: float, what: str) -> dict[str, Any]:
        """The next message line, waiting at most ``timeout`` wall seconds."""
        proc = self._proc
        assert proc is not None and proc.stdout is not None
        fd = proc.stdout.fileno()
        deadline = time.monotonic() + timeout
        while True:
            end = self._buffer.find(b"\n")
            if end >= 0:
                line = bytes(self._buffer[:end])
                del self._buffer[: end + 1]
                if not line.strip():
                    continue
                message = proto.decode(line, who=self.who)
                if self._buffer.strip():
                    extra = bytes(self._buffer[:80]).decode("utf-8", "replace")
                    raise StackError(
                        f"{self.who} sent more than one line in answer to {what}: {extra!r}..."
                    )
                return message
            if len(self._buffer) > MAX_LINE:
                raise StackError(
                    f"{self.who} wrote more than {MAX_LINE >> 20} MiB on stdout without a "
                    f"newline in answer to {what} (a flood, or logs on stdout?)"
                )
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise StackTimeoutError(
                    f"{self.who} did not answer the {what} within {timeout:g} s (wall clock)"
                )
            ready, _, _ = select.select([fd], [], [], min(remaining, _EXIT_POLL))
            if not ready:
                if proc.poll() is not None:  # exited, but a descendant holds the pipe open
                    raise StackError(self._failure(what))
                continue
            chunk = os.read(fd, _CHUNK)
            if not chunk:
                raise StackError(self._failure(what))
            self._buffer += chunk

    def _image(self, observation: Observation) -> tuple[dict[str, Any] | None, memoryview | None]:
        """The step message's image reference, and raw bytes to send after the line."""
        frame = observation.image
        if frame is None:
            if self.wants == "image" and observation.detections is not None:
                raise StackError(
                    f"{self.who} wants camera images but the backend sends detections "
                    "(perception mode 'pem'); run the backend with camera perception"
                )
            return None, None
        data = memoryview(frame if frame.flags.c_contiguous else frame.copy()).cast("B")
        ref: dict[str, Any] = {"shape": list(frame.shape), "dtype": "uint8"}
        if self.peer.get("image_transport") == "stdin":
            ref["bytes"] = data.nbytes
            return ref, data
        if self._frame is None or self._frame.nbytes != data.nbytes:
            self._drop_frame()
            self._frame = _FrameFile(data.nbytes)
        self._frame.write(data)
        ref["path"] = self._frame.path
        return ref, None

    def _drop_frame(self) -> None:
        if self._frame is not None:
            self._frame.close()
            self._frame = None


#: ``make_stack`` specs starting with this build an :class:`ExternalProcessStack`.
CMD_PREFIX = "cmd:"
_OPTIONS = ("step_timeout", "grey_box", "cwd", "env", "start_timeout", "stderr_log")


def external_stack(
    cmd: str, fault: str | None = None, params: dict[str, Any] | None = None
) -> ExternalProcessStack:
    """An :class:`ExternalProcessStack` from a ``make_stack`` spec (without ``cmd:``).

    ``params`` carries the process options (``step_timeout``, ``grey_box``, ``cwd``,
    ``env``, ``start_timeout``, ``stderr_log``); a fault cannot be seeded into a black box.

    Raises:
        ConfigError: a fault was given, or an option is unknown.
    """
    if fault is not None:
        raise ConfigError(
            field="fault",
            value=fault,
            expected="no fault for an external stack (faults are seeded into the reference stack)",
        )
    params = dict(params or {})
    unknown = sorted(set(params) - set(_OPTIONS))
    if unknown:
        raise ConfigError(
            f"av_params.{unknown[0]}: not an option of external stacks; "
            f"expected one of: {', '.join(_OPTIONS)}",
            field=f"av_params.{unknown[0]}",
            value=unknown[0],
            expected=" | ".join(_OPTIONS),
        )
    return ExternalProcessStack(cmd.strip(), **params)
