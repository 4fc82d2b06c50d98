"""The evidence folder's manifest: hashes that tie every artefact to its inputs (UL 4600).

Every input that decides the evidence is hashed from its content, not from file bytes that
change without meaning (a database's pages move on every write): the stack as configured
(and the files its command or class is read from), the campaign configuration without
execution-only settings, the hyperspace, the stored runs, the ODD, the criterion and the
sitcov version. So the manifest changes when, and only when, one of them changes; each
artefact's sha256 lets a safety case cite exactly the file it read.
"""

from __future__ import annotations

import hashlib
import importlib.util
import json
import shlex
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

from sitcov.hyperspace import canonical_json

#: the manifest's own file name (not hashed into itself)
MANIFEST = "manifest.json"


def content_hash(obj: Any) -> str:
    """sha256 of an object's canonical JSON (sorted keys, no whitespace)."""
    return hashlib.sha256(canonical_json(obj).encode()).hexdigest()


def file_hash(path: str | Path) -> str:
    """sha256 of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def stack_files(stack: Mapping[str, Any]) -> dict[str, str]:
    """Files the stack under test is read from, with their hashes: the arguments of an
    external command that name existing files, and the module of a ``module:Class`` stack
    (the built-in stacks are covered by the sitcov version)."""
    out: dict[str, str] = {}
    command = stack.get("av_cmd")
    if command:
        for word in shlex.split(str(command)):
            if Path(word).is_file():
                out[word] = file_hash(word)
    av = str(stack.get("av") or "")
    if ":" in av:
        spec = importlib.util.find_spec(av.split(":", 1)[0])
        if spec is not None and spec.origin and Path(spec.origin).is_file():
            out[spec.origin] = file_hash(spec.origin)
    return out


def runs_hash(runs: Iterable[Any]) -> str:
    """sha256 of the stored runs' content (campaign, index, seed, situation, outcome)."""
    digest = hashlib.sha256()
    for run in sorted(runs, key=lambda r: (r.campaign, r.index)):
        outcome = None if run.outcome is None else run.outcome.to_dict()
        row = [run.campaign, run.index, run.seed, run.situation.id, run.status, outcome]
        digest.update(json.dumps(row, sort_keys=True, default=str).encode())
        digest.update(b"\n")
    return digest.hexdigest()


def artefact_hashes(out_dir: Path) -> dict[str, str]:
    """Relative path -> sha256 of every file in the folder except the manifest."""
    files = sorted(p for p in out_dir.rglob("*") if p.is_file() and p.name != MANIFEST)
    return {p.relative_to(out_dir).as_posix(): file_hash(p) for p in files}


def write_manifest(out_dir: Path, inputs: Mapping[str, Any]) -> dict[str, Any]:
    """Write ``manifest.json``: the inputs, each with its hash, and every artefact's hash."""
    hashed = {
        name: {"value": value, "sha256": content_hash(value)} for name, value in inputs.items()
    }
    manifest = {
        "inputs": hashed,
        "inputs_sha256": content_hash({k: v["sha256"] for k, v in hashed.items()}),
        "artefacts": artefact_hashes(out_dir),
    }
    (out_dir / MANIFEST).write_text(json.dumps(manifest, indent=2, sort_keys=True) + "\n")
    return manifest
