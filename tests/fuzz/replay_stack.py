"""A stack that answers sitcov with the byte strings in a JSON file (fuzz fixture).

``python replay_stack.py ANSWERS.json``: the file holds a list of latin-1 strings; the
stack answers its k-th incoming message with the k-th string's bytes exactly as given
(newline or not), then answers correctly once the list is used up.
"""

import json
import sys

answers = [a.encode("latin-1") for a in json.load(open(sys.argv[1]))]  # noqa: SIM115
proper = {
    "hello": b'{"type": "hello", "protocol": 1, "name": "replay"}\n',
    "reset": b'{"type": "ready"}\n',
    "step": b'{"type": "control", "throttle": 0.2}\n',
}
for k, line in enumerate(sys.stdin.buffer):
    kind = json.loads(line)["type"]
    if kind == "close":
        break
    sys.stdout.buffer.write(answers[k] if k < len(answers) else proper[kind])
    sys.stdout.buffer.flush()
