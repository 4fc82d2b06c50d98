"""The external-process boundary: protocol v1, time-outs, crashes, restarts, no leftovers."""

from __future__ import annotations

import json
import os
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest
from needs import missing, need_program

from sitcov.av import EgoState, Observation, RunInfo, make_stack
from sitcov.av._external import ExternalProcessStack
from sitcov.av._protocol import PROTOCOL_VERSION
from sitcov.errors import ConfigError, StackError, StackTimeoutError
from sitcov.perception import CameraSpec, Detection

ROOT = Path(__file__).resolve().parents[2]
PY = sys.executable
EXAMPLES = {
    "python": [PY, str(ROOT / "examples" / "python_stack.py")],
    "node": ["node", str(ROOT / "examples" / "node_stack.js")],
}

# -- process inspection (Linux /proc) -------------------------------------------------------


def _stat(pid: int) -> tuple[str, int, int] | None:
    """(state, ppid, pgid) of ``pid``, or None if it does not exist."""
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2 :].split()
    return fields[0], int(fields[1]), int(fields[2])


def children() -> list[tuple[int, str]]:
    """(pid, state) of this process's children, zombies included.

    multiprocessing's own helper (the resource tracker of the ``spawn`` context) lives as
    long as this process by design and is not counted.
    """
    me = os.getpid()
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit():
            stat = _stat(int(entry))
            if stat is not None and stat[1] == me:
                try:
                    cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
                except OSError:
                    cmdline = b""
                if b"multiprocessing.resource_tracker" not in cmdline:
                    found.append((int(entry), stat[0]))
    return found


def alive(pid: int) -> bool:
    """True if ``pid`` exists and is not a zombie."""
    stat = _stat(pid)
    return stat is not None and stat[0] != "Z"


if not Path("/proc/self/stat").exists():  # the process checks read Linux's /proc
    missing("Linux /proc is not available")


@pytest.fixture(autouse=True)
def _no_leftover_processes():
    """Every test must leave no child (running or zombie) behind."""
    before = {pid for pid, _ in children()}
    yield
    deadline = time.monotonic() + 3.0
    while time.monotonic() < deadline:
        left = [(pid, st) for pid, st in children() if pid not in before]
        if not left:
            return
        time.sleep(0.05)
    pytest.fail(f"processes left behind: {left}")


# -- a scriptable stack ------------------------------------------------------------------

MISBEHAVING = textwrap.dedent(
    """
    import json, subprocess, sys, time
    mode = sys.argv[1]
    pidfile = sys.argv[2] if len(sys.argv) > 2 else None
    def send(m):
        sys.stdout.write(json.dumps(m) + "\\n"); sys.stdout.flush()
    steps = 0
    seed = 0
    for line in sys.stdin:
        msg = json.loads(line)
        if msg["type"] == "hello":
            if mode == "hello-timeout":
                time.sleep(60)
            version = 99 if mode == "version" else 1
            print("hello from the stack", file=sys.stderr, flush=True)
            send({"type": "hello", "protocol": version, "name": "scripted",
                  "wants": "image" if mode.startswith("image") else "detections",
                  "image_transport": "stdin" if mode == "image-stdin" else "file"})
        elif msg["type"] == "reset":
            seed = msg["seed"]; steps = 0
            if mode == "echo-reset":
                print(json.dumps(msg), file=sys.stderr, flush=True)
            send({"type": "ready"})
        elif msg["type"] == "step":
            steps += 1
            bad = mode if mode in ("crash", "hang", "garbage", "grandchild", "stdout-noise",
                                   "nan", "report", "double") else None
            if mode == "by-seed":
                bad = {1: "crash", 2: "hang"}.get(seed % 3)
            if bad and steps == 3:
                if bad == "crash":
                    print("Traceback: boom", file=sys.stderr, flush=True)
                    sys.exit(3)
                if bad == "hang":
                    time.sleep(600)
                if bad == "garbage":
                    sys.stdout.write("this is not json\\n"); sys.stdout.flush(); continue
                if bad == "stdout-noise":
                    print("debug: thinking", flush=True); continue
                if bad == "nan":
                    sys.stdout.write('{"type":"control","throttle":NaN}\\n'); sys.stdout.flush()
                    continue
                if bad == "double":
                    sys.stdout.write('{"type":"control"}\\n{"type":"control"}\\n')
                    sys.stdout.flush()
                    continue
                if bad == "report":
                    send({"type": "error", "message": "planner exploded"}); continue
                if bad == "grandchild":
                    child = subprocess.Popen(["sleep", "600"])
                    open(pidfile, "w").write(str(child.pid))
                    time.sleep(600)
            image = msg["image"]
            checksum = None
            if image is not None:
                n = 1
                for d in image["shape"]:
                    n *= d
                if "path" in image:
                    with open(image["path"], "rb") as f:
                        data = f.read(n)
                else:
                    data = sys.stdin.buffer.read(image["bytes"]) if False else None
                checksum = sum(data[:: 997]) if data else None
            send({"type": "control", "throttle": 2.0, "brake": -1, "steer": 0.25,
                  "info": {"n": len(msg["detections"] or []), "t": msg["t"],
                           "checksum": checksum}})
        elif msg["type"] == "close":
            if mode == "ignore-close":
                time.sleep(600)
            break
    """
)


@pytest.fixture
def script(tmp_path: Path) -> Path:
    path = tmp_path / "scripted_stack.py"
    path.write_text(MISBEHAVING)
    return path


def info(seed: int = 0) -> RunInfo:
    route = tuple((float(i), 0.0) for i in range(60))
    return RunInfo(0.05, route, (59.0, 0.0), "t-junction", CameraSpec(), seed)


def obs(k: int, *, image: np.ndarray | None = None) -> Observation:
    t = 0.05 * k
    dets = (Detection((100.0, 200.0, 180.0, 260.0), 0.9),) if k % 2 else None
    return Observation(
        t, EgoState(float(k), 0.5, 0.0, 5.0, t), None if image is not None else dets, image
    )


def drive(stack: ExternalProcessStack, seed: int, steps: int = 6) -> list:
    stack.reset(info(seed))
    return [stack.step(obs(k)) for k in range(steps)]


# -- tests -----------------------------------------------------------------------------------


def test_handshake_round_trip_and_clipping(script: Path) -> None:
    stack = ExternalProcessStack([PY, str(script), "ok"], step_timeout=5.0)
    try:
        controls = drive(stack, seed=4)
        assert stack.peer == {"name": "scripted", "wants": "detections", "image_transport": "file"}
        # values outside their ranges are clipped, info passes through
        assert all((c.throttle, c.brake, c.steer) == (1.0, 0.0, 0.25) for c in controls)
        assert [c.info["n"] for c in controls] == [0, 1, 0, 1, 0, 1]
        assert controls[3].info["t"] == pytest.approx(0.15)
        assert stack.config()["stack_name"] == "scripted"
        assert stack.config()["protocol"] == PROTOCOL_VERSION
    finally:
        stack.close()
    assert stack.pid is None


@pytest.mark.parametrize("example", sorted(EXAMPLES))
def test_example_stacks_follow_the_route_and_brake(example: str) -> None:
    if example == "node":
        need_program("node")
    stack = ExternalProcessStack(EXAMPLES[example], step_timeout=5.0)
    try:
        stack.reset(info())
        # left of the route (+y), heading along it: steer right (negative), accelerate
        free = stack.step(Observation(0.0, EgoState(0.0, 1.0, 0.0, 0.0, 0.0), ()))
        assert free.throttle > 0.3 and free.brake == 0.0 and free.steer < 0.0
        # a wide, confident car box in the image centre: full brake, latched for the run
        car = Detection((300.0, 200.0, 500.0, 300.0), 0.9)
        hit = stack.step(Observation(0.05, EgoState(0.3, 1.0, 0.0, 6.0, 0.05), (car,)))
        later = stack.step(Observation(0.10, EgoState(0.6, 1.0, 0.0, 5.0, 0.10), ()))
        assert (hit.brake, later.brake, later.throttle) == (1.0, 1.0, 0.0)
        stack.reset(info())  # the latch does not survive a reset
        assert stack.step(Observation(0.0, EgoState(0.0, 0.0, 0.0, 0.0, 0.0), ())).brake == 0.0
    finally:
        stack.close()


@pytest.mark.parametrize(
    ("mode", "error", "words"),
    [
        ("crash", StackError, ["exited with code 3", "Traceback: boom"]),
        ("garbage", StackError, ["this is not json", "stderr"]),
        ("stdout-noise", StackError, ["debug: thinking"]),
        ("nan", StackError, ["must be a finite number"]),
        ("report", StackError, ["planner exploded"]),
        ("double", StackError, ["more than one line in answer to step"]),
        ("hang", StackTimeoutError, ["did not answer the step within 0.5 s"]),
    ],
)
def test_failing_step_raises_kills_and_restarts(script: Path, mode: str, error, words) -> None:
    stack = ExternalProcessStack([PY, str(script), mode], step_timeout=0.5)
    try:
        stack.reset(info())
        first_pid = stack.pid
        stack.step(obs(0))
        stack.step(obs(1))
        start = time.monotonic()
        with pytest.raises(error) as caught:
            stack.step(obs(2))
        assert time.monotonic() - start < 3.0
        for word in words:
            assert word in str(caught.value)
        assert str(script) in str(caught.value)  # the message names the stack
        assert caught.value.status == ("timeout" if error is StackTimeoutError else "error")
        assert stack.pid is None and not alive(first_pid)
        with pytest.raises(StackError, match="not running"):
            stack.step(obs(3))
        stack.reset(info())  # restarted for the next run
        assert stack.pid not in (None, first_pid) and stack.restarts == 1
        assert stack.step(obs(0)).throttle == 1.0
    finally:
        stack.close()


def test_timeout_kills_the_whole_process_group(script: Path, tmp_path: Path) -> None:
    pidfile = tmp_path / "grandchild.pid"
    stack = ExternalProcessStack([PY, str(script), "grandchild", str(pidfile)], step_timeout=0.5)
    try:
        with pytest.raises(StackTimeoutError):
            drive(stack, seed=0)
        grandchild = int(pidfile.read_text())
        deadline = time.monotonic() + 2.0
        while alive(grandchild) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert not alive(grandchild)
    finally:
        stack.close()


def test_version_mismatch_is_a_clear_error(script: Path) -> None:
    stack = ExternalProcessStack([PY, str(script), "version"])
    with pytest.raises(StackError, match="speaks protocol 99 but this sitcov speaks protocol 1"):
        stack.reset(info())
    assert stack.pid is None


def test_hello_and_close_time_outs(script: Path) -> None:
    stack = ExternalProcessStack([PY, str(script), "hello-timeout"], start_timeout=0.5)
    with pytest.raises(StackTimeoutError, match="hello within 0.5 s"):
        stack.reset(info())
    stack = ExternalProcessStack([PY, str(script), "ignore-close"])
    stack.reset(info())
    pid = stack.pid
    start = time.monotonic()
    stack.close()  # the stack ignores close: killed after the grace period
    assert time.monotonic() - start < 3.0 and not alive(pid)


def test_missing_command_is_refused_before_any_run(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match="av_cmd: expected an executable program"):
        ExternalProcessStack(str(tmp_path / "no-such-stack"))


def test_command_that_vanishes_later_is_a_stack_error(tmp_path: Path) -> None:
    program = tmp_path / "stack.sh"
    program.write_text("#!/bin/sh\nexit 1\n")
    program.chmod(0o755)
    stack = ExternalProcessStack(str(program))
    program.unlink()
    with pytest.raises(StackError, match="cannot be started"):
        stack.reset(info())


def test_black_box_hides_the_situation_grey_box_sends_it(script: Path, tmp_path: Path) -> None:
    from sitcov.hyperspace import Situation

    situation = Situation({"friction": "0.4"}, {"friction": 0.4})
    run = RunInfo(
        0.05, ((0.0, 0.0), (1.0, 0.0)), (1.0, 0.0), "t-junction", CameraSpec(), 7, situation
    )
    for grey in (False, True):
        log = tmp_path / f"stderr-{grey}.log"
        stack = ExternalProcessStack([PY, str(script), "echo-reset"], grey_box=grey, stderr_log=log)
        stack.reset(run)
        stack.close()
        lines = log.read_text().splitlines()
        assert lines[0] == "hello from the stack"  # stderr passes through to the log
        reset = json.loads(lines[1])
        assert reset["seed"] == 7 and reset["camera"]["width"] == 800
        assert reset["route"] == [[0.0, 0.0], [1.0, 0.0]]
        assert ("situation" in reset) is grey
        if grey:
            assert reset["situation"]["bins"] == {"friction": "0.4"}


def test_images_travel_as_raw_bytes_in_a_shared_file(script: Path) -> None:
    frame = np.arange(450 * 800 * 3, dtype=np.uint64).astype(np.uint8).reshape(450, 800, 3)
    expected = int(frame.reshape(-1)[::997].astype(np.int64).sum())
    stack = ExternalProcessStack([PY, str(script), "image"], step_timeout=5.0)
    try:
        stack.reset(info())
        assert stack.wants == "image"
        control = stack.step(obs(0, image=frame))
        assert control.info["checksum"] == expected
        path = stack._frame.path
        assert os.path.getsize(path) == frame.nbytes
        with pytest.raises(StackError, match="wants camera images"):
            stack.step(obs(1))  # detections instead of frames: wrong perception mode
        assert not os.path.exists(path)  # the frame file goes with the process
    finally:
        stack.close()


def test_crash_and_hang_by_seed_only_fail_those_runs(script: Path) -> None:
    """Runs whose seed makes the stack crash or hang fail; every other run completes."""
    stack = ExternalProcessStack([PY, str(script), "by-seed"], step_timeout=0.3)
    statuses = []
    try:
        for seed in range(9):
            try:
                drive(stack, seed)
                statuses.append("pass")
            except StackError as exc:
                statuses.append(exc.status)
    finally:
        stack.close()
    assert statuses == ["pass", "error", "timeout"] * 3
    assert stack.restarts == 5  # a fresh process after each of the 6 failures but the last


def test_make_stack_builds_an_external_stack_from_a_cmd_spec(script: Path) -> None:
    stack = make_stack(f"cmd:{PY} {script} ok", params={"step_timeout": 2.5, "grey_box": True})
    assert isinstance(stack, ExternalProcessStack)
    assert (stack.step_timeout, stack.grey_box, stack.args[-1]) == (2.5, True, "ok")
    with pytest.raises(ConfigError, match="av_params.speed"):
        make_stack(f"cmd:{PY} {script}", params={"speed": 3})
    with pytest.raises(ConfigError, match="fault"):
        make_stack(f"cmd:{PY} {script}", fault="f1")
    with pytest.raises(ConfigError, match="non-empty command"):
        make_stack("cmd:  ")
    with pytest.raises(ConfigError, match="av_params.step_timeout: expected a positive number"):
        make_stack(f"cmd:{PY} {script}", params={"step_timeout": "2"})


def test_pickles_as_configuration(script: Path) -> None:
    import pickle

    stack = ExternalProcessStack([PY, str(script), "ok"], step_timeout=0.7, env={"A": "1"})
    try:
        stack.reset(info())
        copy = pickle.loads(pickle.dumps(stack))
        assert copy.pid is None and (copy.args, copy.step_timeout, copy.env) == (
            stack.args,
            0.7,
            {"A": "1"},
        )
    finally:
        stack.close()


def test_stack_dies_with_a_killed_worker(script: Path, tmp_path: Path) -> None:
    """A campaign worker killed mid-run (e.g. its run time-out) leaves no hanging stack."""
    import signal
    import subprocess

    pidfile = tmp_path / "stack.pid"
    worker_code = textwrap.dedent(
        f"""
        import time
        from sitcov.av import EgoState, Observation, RunInfo
        from sitcov.av._external import ExternalProcessStack
        from sitcov.perception import CameraSpec
        stack = ExternalProcessStack([{PY!r}, {str(script)!r}, "hang"], step_timeout=600)
        stack.reset(RunInfo(0.05, ((0.0, 0.0), (9.0, 0.0)), (9.0, 0.0), "m", CameraSpec(), 0))
        open({str(pidfile)!r}, "w").write(str(stack.pid))
        for k in range(5):
            stack.step(Observation(0.0, EgoState(0.0, 0.0, 0.0, 0.0, 0.0)))
        """
    )
    worker = subprocess.Popen([PY, "-c", worker_code])
    try:
        deadline = time.monotonic() + 20.0
        while not pidfile.exists() or not pidfile.read_text():
            assert time.monotonic() < deadline, "the worker did not start its stack"
            time.sleep(0.05)
        stack_pid = int(pidfile.read_text())
        time.sleep(0.3)  # the stack now hangs in its third step
        assert alive(stack_pid)
        worker.send_signal(signal.SIGKILL)
        worker.wait(timeout=5)
        deadline = time.monotonic() + 3.0
        while alive(stack_pid) and time.monotonic() < deadline:
            time.sleep(0.02)
        assert not alive(stack_pid)
    finally:
        if worker.poll() is None:
            worker.kill()
            worker.wait()


# -- whole campaigns -------------------------------------------------------------------------


def _campaign(tmp_path: Path, name: str, av: str, **options):
    from sitcov.campaign import CampaignConfig, open_store, run_campaign

    fields = {"runs": 12, "seed": 3, "executor": "serial"} | options
    config = CampaignConfig(name=name, av=av, **fields)
    with open_store(tmp_path / "campaigns.db") as store:
        result = run_campaign(config, store)
        return result, store.runs(name)


def test_campaigns_with_python_and_node_stacks_agree(tmp_path: Path) -> None:
    """The same stack in two languages: every stored run has the identical outcome."""
    need_program("node")
    runs = {}
    for lang in ("python", "node"):
        av = "cmd:" + " ".join(EXAMPLES[lang])
        result, runs[lang] = _campaign(tmp_path, lang, av, av_params={"step_timeout": 5.0})
        assert result.counts["pending"] == 0 and len(runs[lang]) == 12
        assert {r.status for r in runs[lang]} <= {"pass", "fail"}
        assert runs[lang][0].config.get("av", av) == av
    # V8's and libm's sin/cos/atan2 differ in the last bit, so compare verdicts, not bits
    for py, js in zip(runs["python"], runs["node"], strict=True):
        assert py.situation == js.situation and py.seed == js.seed
        assert (py.status, py.outcome.end_reason, py.outcome.aeb_fired) == (
            js.status,
            js.outcome.end_reason,
            js.outcome.aeb_fired,
        )
        assert py.outcome.sim_time == pytest.approx(js.outcome.sim_time, abs=0.101)


def test_campaign_with_the_reference_stack_through_the_plugin_path(tmp_path: Path) -> None:
    _, by_path = _campaign(tmp_path, "path", "sitcov.av:ReferenceStack", runs=6)
    _, by_name = _campaign(tmp_path, "name", "reference", runs=6)
    assert [r.outcome.to_dict() for r in by_path] == [r.outcome.to_dict() for r in by_name]


def _stack_processes(marker: str) -> list[int]:
    """Living processes whose command line mentions ``marker``."""
    found = []
    for entry in os.listdir("/proc"):
        if entry.isdigit() and int(entry) != os.getpid():
            try:
                cmdline = Path(f"/proc/{entry}/cmdline").read_bytes()
            except OSError:
                continue
            if marker.encode() in cmdline and alive(int(entry)):
                found.append(int(entry))
    return found


@pytest.mark.slow
def test_campaign_with_crashing_and_hanging_runs(script: Path, tmp_path: Path) -> None:
    """Runs whose seed makes the stack crash are ``error``, hang ``timeout``; all others
    complete; afterwards no stack process is left, in worker processes or here."""
    av = f"cmd:{PY} {script} by-seed"
    result, runs = _campaign(
        tmp_path,
        "flaky",
        av,
        runs=15,
        executor="processes",
        workers=2,
        av_params={"step_timeout": 0.5},
        backend_options={"sim_timeout": 1.0},
    )
    # a run that neither crashes nor hangs is judged (a 1 s budget leaves its route
    # incomplete, so under the default judge it fails as route_incomplete)
    expected = [{0: "judged", 1: "error", 2: "timeout"}[r.seed % 3] for r in runs]
    got = ["judged" if r.status in ("pass", "fail") else r.status for r in runs]
    assert got == expected
    assert {"judged", "error", "timeout"} <= set(expected)
    for r in runs:
        if r.status == "error":
            assert "StackError" in r.outcome.message and "code 3" in r.outcome.message
        if r.status == "timeout":
            assert "StackTimeoutError" in r.outcome.message
    assert result.counts["pending"] == 0
    assert _stack_processes(str(script)) == []


def test_a_forgotten_stack_is_ended_by_garbage_collection(script: Path) -> None:
    import gc

    stack = ExternalProcessStack([PY, str(script), "ok"])
    stack.reset(info())
    pid = stack.pid
    del stack
    gc.collect()
    assert not alive(pid)


def test_grey_box_through_the_embedded_backend(script: Path, tmp_path: Path) -> None:
    from sitcov.hyperspace import load_hyperspace
    from sitcov.sim import make_backend

    hs = load_hyperspace()
    situation = hs.situation_from_bins(
        {e: hs.labels(e)[1] for e in hs.element_names}, np.random.default_rng(0)
    )
    seen = {}
    for grey in (False, True):
        log = tmp_path / f"grey-{grey}.log"
        stack = ExternalProcessStack(
            [PY, str(script), "echo-reset"], grey_box=grey, stderr_log=log, step_timeout=5.0
        )
        backend = make_backend("embedded", grey_box=True, sim_timeout=0.2)
        try:
            outcome = backend.run(situation, stack, seed=1)
        finally:
            stack.close()
        assert outcome.status == "pass" and outcome.metrics["steps"] == 4
        seen[grey] = json.loads(log.read_text().splitlines()[1])
    assert "situation" not in seen[False]
    assert seen[True]["situation"] == situation.to_dict()
