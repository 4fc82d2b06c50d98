"""A protocol-v1 stack that misbehaves on purpose (fixture of the reliability tests).

``python unruly_stack.py MODE`` drives sensibly, except in runs whose seed is 1 mod 3,
where at the third step it does MODE:

- ``flood-stdout``: writes control messages without end;
- ``long-line``: writes a 100 MB line (no newline for 100 MB) on stdout;
- ``stderr-flood``: writes 100 MB on stderr without a newline, then answers normally;
- ``bad-utf8``: answers with bytes that are not UTF-8;
- ``exit0``: exits with code 0 in the middle of the run;
- ``ignore-term``: ignores SIGTERM (from the start) and hangs;
- ``fork-escape``: starts a daemon (double fork + setsid, so outside the stack's process
  group) that would sleep for 10 minutes, then crashes;
- ``memory``: allocates under a 200 MiB address-space limit until MemoryError kills it.
"""

import json
import os
import resource
import signal
import sys
import time

MODE = sys.argv[1]
MB = 1 << 20


def send(message):
    sys.stdout.write(json.dumps(message) + "\n")
    sys.stdout.flush()


def daemon():
    """Double fork + setsid: a grandchild in its own session, re-parented to init."""
    if os.fork() == 0:
        os.setsid()
        if os.fork() == 0:
            os.execv(
                sys.executable,
                [sys.executable, "-c", "import time; time.sleep(600)", "unruly-daemon"],
            )
        os._exit(0)
    os.wait()


def misbehave():
    out = sys.stdout.buffer
    if MODE == "flood-stdout":
        while True:
            send({"type": "control", "throttle": 0.1})
    if MODE == "long-line":
        for _ in range(100):
            out.write(b"x" * MB)
        out.write(b"\n")
        out.flush()
        time.sleep(600)
    if MODE == "stderr-flood":
        for _ in range(100):
            sys.stderr.buffer.write(b"e" * MB)
        sys.stderr.flush()
        return
    if MODE == "bad-utf8":
        out.write(b'{"type": "control", "note": "\xff\xfe\xfd"}\n')
        out.flush()
        time.sleep(600)
    if MODE == "exit0":
        sys.exit(0)
    if MODE == "ignore-term":
        time.sleep(600)
    if MODE == "fork-escape":
        daemon()
        sys.exit(5)
    if MODE == "memory":
        with open("/proc/self/statm") as f:
            in_use = int(f.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        resource.setrlimit(resource.RLIMIT_AS, (in_use + 200 * MB, resource.RLIM_INFINITY))
        hoard = [bytearray(MB) for _ in range(100_000)]
        print(len(hoard))


def main():
    if MODE == "ignore-term":
        signal.signal(signal.SIGTERM, signal.SIG_IGN)
    seed = steps = 0
    for line in sys.stdin:
        message = json.loads(line)
        kind = message["type"]
        if kind == "hello":
            send({"type": "hello", "protocol": 1, "name": "unruly", "wants": "detections"})
        elif kind == "reset":
            seed, steps = message["seed"], 0
            send({"type": "ready"})
        elif kind == "step":
            steps += 1
            if seed % 3 == 1 and steps == 3:
                misbehave()
            send({"type": "control", "throttle": 0.3, "brake": 0.0, "steer": 0.0})
        elif kind == "close":
            if MODE == "ignore-term":
                time.sleep(600)
            return


main()
