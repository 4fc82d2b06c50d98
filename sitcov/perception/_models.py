"""Fetching and locating the SSD-MobileNetV2 (Open Images V4) detector model.

The model is not on a model hub; it ships inside the npm package of MediaPipe's Objectron
solution, packed with its label map into one ``.data`` blob whose file table (name, start
byte, end byte) lives in a small JavaScript loader. ``fetch_model`` runs ``npm pack``,
reads the table, cuts the model out, checks its sha256 and stores it (and the label map) in
the user's cache directory. Nothing is ever fetched implicitly: detectors call
:func:`model_path`, which only looks.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import shutil
import subprocess
import tarfile
import tempfile
from pathlib import Path

from sitcov.errors import SetupError, SitcovError

#: The npm package (pinned) that carries the model.
NPM_PACKAGE = "@mediapipe/objectron@0.4.1675468480"
#: Archive members inside the npm tarball.
DATA_MEMBER = "package/objectron_solution_packed_assets.data"
LOADER_MEMBER = "package/objectron_solution_packed_assets_loader.js"
#: File names inside the packed data blob.
MODEL_ENTRY = "object_detection_ssd_mobilenetv2_oidv4_fp16.tflite"
LABELS_ENTRY = "object_detection_oidv4_labelmap.txt"
#: sha256 of the model file; anything else is refused.
MODEL_SHA256 = "d0a5255bf8c4f5a0bc4240741a76c41d5e939f7655078f945f50ab53a9375da6"
#: Where the model lives unless SITCOV_MODEL_DIR says otherwise.
MODEL_DIR_ENV = "SITCOV_MODEL_DIR"

_FILES_RE = re.compile(r'"files"\s*:\s*(\[.*?\])', re.DOTALL)


class ModelFetchError(SitcovError):
    """The model could not be obtained (npm missing, network, hash or member mismatch)."""


class ModelNotFoundError(SetupError):
    """The model has not been fetched yet (or an explicit path does not exist)."""


def model_dir() -> Path:
    """The directory holding fetched models: ``$SITCOV_MODEL_DIR`` or ``~/.cache/sitcov/models``."""
    env = os.environ.get(MODEL_DIR_ENV)
    if env:
        return Path(env).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sitcov" / "models"


def model_path(explicit: str | os.PathLike[str] | None = None) -> Path:
    """Locate the detector model without fetching anything.

    Args:
        explicit: a user-supplied ``.tflite`` file; used as is (no hash check, so users can
            plug a retrained model with the same input/output layout).

    Raises:
        ModelNotFoundError: the file does not exist; the message says how to get it.
    """
    if explicit is not None:
        path = Path(explicit).expanduser()
        if not path.is_file():
            raise ModelNotFoundError(f"model file {str(path)!r} does not exist")
        return path
    path = model_dir() / MODEL_ENTRY
    if not path.is_file():
        raise ModelNotFoundError(
            f"detector model not found in {str(model_dir())!r}; run `sitcov models fetch` "
            f"(or set {MODEL_DIR_ENV})"
        )
    return path


def labels_path(model: Path) -> Path:
    """The label-map file stored beside ``model`` by :func:`fetch_model`."""
    return model.with_name(LABELS_ENTRY)


def sha256_file(path: Path) -> str:
    """Hex sha256 of a file, read in chunks."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            digest.update(chunk)
    return digest.hexdigest()


def parse_file_table(loader_js: str) -> dict[str, tuple[int, int]]:
    """Read the packed-asset file table from the Emscripten loader script.

    Returns:
        base file name -> (start, end) byte offsets into the ``.data`` blob.

    Raises:
        ModelFetchError: no table in the script.
    """
    match = _FILES_RE.search(loader_js)
    if match is None:
        raise ModelFetchError(f"no file table found in {LOADER_MEMBER}")
    try:
        entries = json.loads(match.group(1))
        return {Path(e["filename"]).name: (int(e["start"]), int(e["end"])) for e in entries}
    except (ValueError, KeyError, TypeError) as exc:
        raise ModelFetchError(f"unreadable file table in {LOADER_MEMBER}: {exc}") from exc


def extract_from_tarball(tarball: Path, dest: Path) -> Path:
    """Cut the model (and label map) out of the npm tarball into ``dest``; verify the hash.

    Returns:
        The path of the stored model.
    """
    with tarfile.open(tarball, "r:gz") as tar:
        try:
            loader = tar.extractfile(LOADER_MEMBER)
            data = tar.extractfile(DATA_MEMBER)
        except KeyError as exc:
            raise ModelFetchError(f"{NPM_PACKAGE} has no member {exc}") from exc
        if loader is None or data is None:
            raise ModelFetchError(f"{NPM_PACKAGE}: {LOADER_MEMBER} or {DATA_MEMBER} unreadable")
        table = parse_file_table(loader.read().decode("utf-8", errors="replace"))
        blob = data.read()
    if MODEL_ENTRY not in table:
        raise ModelFetchError(
            f"{MODEL_ENTRY} is not in the packed assets of {NPM_PACKAGE} "
            f"(found: {', '.join(sorted(table))})"
        )
    start, end = table[MODEL_ENTRY]
    model = blob[start:end]
    digest = hashlib.sha256(model).hexdigest()
    if digest != MODEL_SHA256:
        raise ModelFetchError(
            f"sha256 mismatch for {MODEL_ENTRY}: expected {MODEL_SHA256}, got {digest}"
        )
    dest.mkdir(parents=True, exist_ok=True)
    out = dest / MODEL_ENTRY
    _write_atomically(out, model)
    if LABELS_ENTRY in table:
        ls, le = table[LABELS_ENTRY]
        _write_atomically(dest / LABELS_ENTRY, blob[ls:le])
    return out


def _write_atomically(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` so that readers never see a partial file, even when two
    processes (e.g. parallel test workers) fetch at once: each writes its own temporary file
    and renames it into place."""
    tmp = path.with_name(f"{path.name}.{os.getpid()}.part")
    tmp.write_bytes(data)
    tmp.replace(path)


def fetch_model(dest: str | os.PathLike[str] | None = None, *, npm: str = "npm") -> Path:
    """Download the detector with ``npm pack``, verify it and store it.

    Args:
        dest: target directory (default :func:`model_dir`).
        npm: the npm executable.

    Returns:
        The stored model's path. An already present file with the right hash is reused.

    Raises:
        ModelFetchError: npm missing or failing, member missing, hash mismatch.
    """
    target = Path(dest).expanduser() if dest is not None else model_dir()
    existing = target / MODEL_ENTRY
    if existing.is_file() and sha256_file(existing) == MODEL_SHA256:
        return existing
    exe = shutil.which(npm)
    if exe is None:
        raise ModelFetchError(
            f"`{npm}` not found on PATH; install Node.js/npm to fetch the detector model, "
            "or pass your own file with --model"
        )
    with tempfile.TemporaryDirectory(prefix="sitcov-npm-") as tmp:
        try:
            proc = subprocess.run(
                [exe, "pack", NPM_PACKAGE, "--silent"],
                cwd=tmp,
                capture_output=True,
                text=True,
                timeout=600,
                check=False,
            )
        except (OSError, subprocess.TimeoutExpired) as exc:
            raise ModelFetchError(f"`npm pack {NPM_PACKAGE}` failed: {exc}") from exc
        tarballs = sorted(Path(tmp).glob("*.tgz"))
        if proc.returncode != 0 or not tarballs:
            detail = (proc.stderr or proc.stdout).strip().splitlines()
            last = detail[-1] if detail else f"exit code {proc.returncode}"
            raise ModelFetchError(f"`npm pack {NPM_PACKAGE}` failed: {last}")
        return extract_from_tarball(tarballs[0], target)
