"""benchmarks/bench_side_symmetry.py, whose table docs/pem.md quotes: the sun's mirror, the
seen shading, and the mirrored frames' boxes, on a handful of frames of the real detector."""

from __future__ import annotations

import math
from types import ModuleType

import numpy as np
import pytest
from benchmark_modules import load_benchmark

from sitcov.perception import Detection, _vehicle


@pytest.fixture(scope="module")
def bench() -> ModuleType:
    return load_benchmark("bench_side_symmetry")


def test_the_mirrored_sun_negates_only_the_lateral_part(bench) -> None:
    sun = _vehicle.SUN
    for yaw in (0.0, 0.5 * math.pi, math.pi, 1.1):
        m = bench._mirrored_sun(yaw)
        f, left = (math.cos(yaw), math.sin(yaw)), (-math.sin(yaw), math.cos(yaw))
        assert m[0] * f[0] + m[1] * f[1] == pytest.approx(sun[0] * f[0] + sun[1] * f[1])
        assert m[0] * left[0] + m[1] * left[1] == pytest.approx(
            -(sun[0] * left[0] + sun[1] * left[1])
        )
        assert m[2] == sun[2]


def test_the_seen_shading_of_a_mirror_pose_is_that_under_the_mirrored_sun(bench) -> None:
    """Mirroring the pose in the plane x = 0 (yaw -> pi - yaw, camera offset (dx, dy) ->
    (-dx, dy)) gives the shading under the sun mirrored in that plane; it stays in [0, the
    sun's horizontal length]."""
    rng = np.random.default_rng(5)
    sun = _vehicle.SUN
    mirrored = (-sun[0], sun[1], sun[2])
    for _ in range(200):
        yaw, dx, dy = rng.uniform(-math.pi, math.pi), *rng.uniform(-20.0, 20.0, 2)
        lit = bench.sun_light(yaw, dx, dy, sun)
        assert 0.0 <= lit <= math.hypot(sun[0], sun[1]) + 1e-12
        assert bench.sun_light(math.pi - yaw, -dx, dy, mirrored) == pytest.approx(lit, abs=1e-12)


def _mirrored(detector, width: int):
    """``detector`` run on the mirrored frame, its boxes mirrored back."""

    def detect(img: np.ndarray) -> list[Detection]:
        out = detector(np.ascontiguousarray(np.fliplr(img)))
        return [Detection((width - d.box[2], d.box[1], width - d.box[0], d.box[3]), d.score,
                          d.label) for d in out]  # fmt: skip

    return detect


def test_flipped_frames_are_matched_at_the_mirrored_box(bench, ssd_model) -> None:
    """With a detector that itself looks at the mirror image, ``as_is`` and ``flipped``
    swap exactly (the bench mirrors the true box as it mirrors the frame); the sun is put
    back after the run; on leg R, where the seen shading changes, the sun's mirror
    changes the frame."""
    from sitcov.perception import CameraSpec, SSDDetector

    detector = SSDDetector(ssd_model, min_score=0.05)
    args = {"legs": ("R",), "distances": (10.0,), "bearings": (10.0,), "colors": ("grey",)}
    sun = _vehicle.SUN
    rows = bench.side_scores(detector, **args)
    assert _vehicle.SUN is sun
    swapped = bench.side_scores(_mirrored(detector, CameraSpec().width), **args)
    assert len(rows) == 4 and {r["side"] for r in rows} == set(bench.SIDES)
    assert [r["flipped"] for r in swapped] == pytest.approx([r["as_is"] for r in rows], abs=1e-6)
    assert [r["as_is"] for r in swapped] == pytest.approx([r["flipped"] for r in rows], abs=1e-6)
    assert any(r["as_is"] >= 0.3 for r in rows)
    assert any(abs(r["lit"] - r["lit_mirrored"]) > 0.05 for r in rows)
    s = bench.summary(rows)
    assert s["modes"]["as_is"]["mean_abs_change"] == 0.0
    assert "gap L-R" in bench.table(s)
