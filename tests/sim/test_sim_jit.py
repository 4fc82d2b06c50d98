"""The optional numba kernels (``_jit.py``) give exactly the Python code's bits."""

from __future__ import annotations

import bisect
import functools
import itertools
import math
import os
import random
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from needs import need_module

from sitcov._jit import _hypot_cr, compiled, enabled, typed_entry
from sitcov.av import _reference
from sitcov.av._pid import window_pid
from sitcov.perception import _camera, _pem
from sitcov.sim.embedded import _collision, _controllers, _dynamics, _monitors, _path


def _pairs(n: int, seed: int) -> list[tuple[float, float]]:
    """Random pairs over many magnitudes, ratios near 1 and tiny partners included."""
    rnd = random.Random(seed)
    out = []
    for _ in range(n):
        a = rnd.uniform(-20.0, 20.0) * 10.0 ** rnd.randint(-4, 3)
        mode = rnd.random()
        if mode < 0.3:
            b = a * rnd.uniform(-1.5, 1.5)
        elif mode < 0.5:
            b = rnd.uniform(-1e-3, 1e-3)
        else:
            b = rnd.uniform(-20.0, 20.0) * 10.0 ** rnd.randint(-4, 3)
        out.append((a, b))
    return out


def test_correctly_rounded_hypot_agrees_with_cpython_bit_for_bit() -> None:
    """CPython's math.hypot is correctly rounded; so is ``_hypot_cr`` (run here as plain
    Python: the same operations numba compiles)."""
    pairs = _pairs(20000, 0) + [
        (0.0, 0.0),
        (-0.0, 3.0),
        (3.0, -4.0),
        (1e-310, 1e-310),
        (5e-324, 0.0),
        (1e300, 1e300),
        (math.inf, 1.0),
        (1.0, -math.inf),
    ]
    bad = [(a, b) for a, b in pairs if _hypot_cr(a, b) != math.hypot(a, b)]
    assert not bad, f"{len(bad)} pairs differ, e.g. {bad[0]}"
    assert math.isnan(_hypot_cr(math.nan, 1.0))


def _cases(n: int, seed: int) -> list[tuple[float, ...]]:
    """(x, y, yaw, vx, vy, r, throttle, brake, delta, mu, lateral_accel): kinematic, blended
    and dynamic speeds, drive, brake, steering, low grip and wind."""
    rnd = random.Random(seed)
    steer_max = _dynamics.default_params().steer_max
    cases = []
    for _ in range(n):
        vx = rnd.choice([rnd.uniform(0.0, 12.0), rnd.uniform(0.0, 5.0), 0.0])
        cases.append(
            (
                rnd.uniform(-60.0, 60.0),
                rnd.uniform(-60.0, 60.0),
                rnd.uniform(-math.pi, math.pi),
                vx,
                rnd.uniform(-1.0, 1.0) * rnd.choice([0.0, 0.01, 0.5]),
                rnd.uniform(-1.0, 1.0) * rnd.choice([0.0, 0.1, 1.0]),
                rnd.choice([0.0, rnd.random(), 1.0]),
                rnd.choice([0.0, rnd.random(), 1.0]),
                rnd.uniform(-1.0, 1.0) * steer_max,
                rnd.choice([1.0, rnd.uniform(0.05, 1.2)]),
                rnd.choice([0.0, rnd.uniform(-2.0, 2.0)]),
            )
        )
    return cases


def test_compiled_integrator_is_bit_identical_to_python(monkeypatch) -> None:
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # this test is about the compiled path
    fast = compiled(_dynamics.integrate)
    k = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)._k
    bad = [
        c for c in _cases(5000, 1) if fast(k, *c, 0.05, 2) != _dynamics.integrate(k, *c, 0.05, 2)
    ]
    assert not bad, f"{len(bad)} of 5000 states differ, e.g. {bad[0]}"


def test_no_jit_switch_runs_the_python_code(monkeypatch) -> None:
    monkeypatch.setenv("SITCOV_NO_JIT", "1")
    assert not enabled()
    assert compiled(_dynamics.integrate) is None


def _not_compilable(x: float) -> object:
    return object()  # numba's nopython mode cannot build arbitrary objects


def test_a_numba_failure_warns_and_falls_back_to_python(monkeypatch) -> None:
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)
    with pytest.warns(RuntimeWarning, match="numba could not compile _not_compilable"):
        assert compiled(_not_compilable, 1.0) is None


def _third(a) -> float:
    return a[3] * 2.0


def test_an_example_that_fails_as_python_is_refused_before_numba_sees_it(monkeypatch) -> None:
    """Compiled code reads past a short array's end without a word (here the bytes after
    a 3-value array), which once made the PEM frame kernel's example divide by zero now
    and then; ``compiled`` runs every example as Python first, where it raises every
    time, and names the function."""
    from sitcov.errors import SitcovError

    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)
    with pytest.raises(SitcovError, match="compile example of _third does not run as Python"):
        compiled(_third, np.zeros(3))
    assert compiled(_third, np.zeros(4)) is not None


def test_the_pem_kernels_examples_are_whole_arrays_of_their_layouts() -> None:
    """The view and frame kernels' example arrays have the length of the arrays the
    sensor builds (a short one read past its end in compiled code: the intermittent
    "could not compile _pem_frame (ZeroDivisionError)"), and run as Python."""
    from sitcov.perception import PEMSensor
    from sitcov.perception._base import ActorView, Pose
    from sitcov.weather._conditions import Conditions

    sensor, cond = PEMSensor(), Conditions(rain_noise=0.2)
    q, p, _label = sensor.prepare(ActorView(Pose(10.0, 1.0, 0.3), 4.6, 1.8, 1.5), cond)
    assert len(_pem.example_view_array()) == len(q) == _pem.VIEW_ARRAY_LEN
    state = sensor._frame_state(None, np.asarray(q, dtype=float), p, cond, {})[3]
    assert len(_pem.example_frame_state()) == len(state)
    view = _pem._pem_view(np.array(_pem.example_view_array()), 0.0, 0.0, 0.0, 10.0, 1.0, 0.3)
    assert view[0]  # the example car is in view: every value of the array is read
    normals = np.zeros(_pem.FRAME_NORMALS)
    frame = np.array(_pem.example_frame_state())
    assert _pem._pem_frame(frame, normals, 0, 1.0, 0.0, 0.0, 0.0, 10.0, 1.0, 0.3)[0] != 0


def test_compiling_holds_the_machines_cache_lock_and_it_excludes_other_processes(
    monkeypatch,
) -> None:
    """``compiled`` compiles and loads under ``cache_lock`` (numba's disk cache has no lock
    of its own: kernels compiled side by side from an empty cache ran each other's machine
    code), and while one process holds the lock another cannot take it."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)
    from sitcov import _jit

    held = []
    real = _jit.cache_lock

    def recording():
        held.append(True)
        return real()

    monkeypatch.setattr(_jit, "cache_lock", recording)
    assert compiled(_dynamics.integrate) is not None
    assert held == [True]
    probe = (
        "import fcntl, os, tempfile, sys\n"
        "p = os.path.join(tempfile.gettempdir(), f'sitcov-numba-cache-{os.getuid()}.lock')\n"
        "h = open(p, 'a')\n"
        "try:\n    fcntl.flock(h, fcntl.LOCK_EX | fcntl.LOCK_NB)\nexcept BlockingIOError:\n"
        "    sys.exit(3)\n"
    )
    with real():
        assert subprocess.run([sys.executable, "-c", probe]).returncode == 3
    # released: the probe gets it, once any other process compiling now (another xdist
    # worker, a campaign's workers) has let go, so it waits for it (at most 120 s)
    waiting = probe.replace("fcntl.LOCK_EX | fcntl.LOCK_NB", "fcntl.LOCK_EX")
    waiting = "import signal\nsignal.alarm(120)\n" + waiting
    assert subprocess.run([sys.executable, "-c", waiting]).returncode == 0


def test_a_kernel_that_fails_its_example_from_the_cache_is_compiled_afresh(
    monkeypatch, recwarn
) -> None:
    """A damaged cache entry (numba's cache has races no lock covers) shows as a loaded
    kernel failing its example call, as "could not compile _pem_frame
    (ZeroDivisionError)" did: ``compiled`` then builds the kernel without the disk cache
    and keeps the compiled path, silently; only when that fails too does it fall back."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)
    from sitcov import _jit

    real = _jit._build
    caches = []

    def damaged(fn, helpers, *, cache, **options):
        caches.append(cache)
        if cache:

            def broken(*args):
                raise ZeroDivisionError("division by zero")

            return broken
        return real(fn, helpers, cache=cache, **options)

    k = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)._k
    example = (k, *_cases(1, 3)[0], 0.05, 2)
    monkeypatch.setattr(_jit, "_build", damaged)
    fast = compiled(_dynamics.integrate, *example)
    assert fast is not None and caches == [True, False]
    assert fast(*example) == _dynamics.integrate(*example)
    assert not [w for w in recwarn if "could not compile" in str(w.message)]

    def always_broken(fn, helpers, *, cache):
        def broken(*args):
            raise ZeroDivisionError("division by zero")

        return broken

    monkeypatch.setattr(_jit, "_build", always_broken)
    with pytest.warns(RuntimeWarning, match="could not compile integrate"):
        assert compiled(_dynamics.integrate, *example) is None


def test_vehicle_steps_give_the_same_bits_with_either_integrator() -> None:
    """A whole braking turn through ``Vehicle.step`` (whichever integrator this process
    uses) equals the plain-Python integrator's, step by step."""
    car = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.3, 8.0)
    ref = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.3, 8.0)
    for i in range(120):
        brake = 1.0 if i > 60 else 0.0
        car.step(0.3 * (i < 60), brake, 0.5, 0.6, 0.2)
        state = (ref.x, ref.y, ref.yaw, ref.vx, ref.vy, ref.r)
        if not (0.3 * (i < 60) == 0.0 and ref.vx == ref.vy == ref.r == 0.0):
            delta = 0.5 * ref.p.steer_max
            out = _dynamics.integrate(
                ref._k, *state, 0.3 * (i < 60), brake, delta, 0.6, 0.2, 0.05, 2
            )
            x, y, yaw, ref.vx, ref.vy, ref.r = out
            if yaw > math.pi or yaw < -math.pi:
                yaw = math.atan2(math.sin(yaw), math.cos(yaw))
            ref.x, ref.y, ref.yaw = x, y, yaw
        assert (car.x, car.y, car.yaw, car.vx, car.vy, car.r) == (
            ref.x,
            ref.y,
            ref.yaw,
            ref.vx,
            ref.vy,
            ref.r,
        ), f"step {i}"
    assert car.speed == 0.0  # the run really braked to a stop


def test_compiled_integrate_tracked_is_bit_identical_to_python(monkeypatch) -> None:
    """The car's fused step (integrator, heading wrap, route tracking; compiled) against
    the Python code, over the integrator's cases placed along a curved route."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    helpers = (_dynamics.integrate, ("track", _path._track))
    fast = compiled(_dynamics.integrate_tracked, helpers=helpers)
    assert fast is not None
    k = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)._k
    path = _path.Path(tuple(20.0 * math.sin(0.02 * i) for i in range(150)), tuple(range(150)))
    pts = (path.xs, path.ys, path.ss)
    arr = np.array(pts)
    rnd = random.Random(7)
    wrapped = 0
    for case in _cases(3000, 8):
        x, y, _ = path.point_at(rnd.uniform(0.0, path.length))
        case = (x + case[0] % 3.0, y + case[1] % 3.0, rnd.uniform(-3.3, 3.3), *case[3:])
        hint = rnd.randrange(-1, 160)
        want = _dynamics.integrate_tracked(k, *case, 0.05, 2, pts, hint)
        assert repr(fast(np.array(k), *case, 0.05, 2, arr, hint)) == repr(want), case
        wrapped += abs(case[2]) > math.pi
    assert wrapped > 50  # headings past pi were wrapped


def test_vehicle_step_on_a_route_equals_step_then_track() -> None:
    """``Vehicle.step`` with a route (one call, whichever path this process uses) gives
    the state of ``step`` and the arc length of ``Path.track`` afterwards, bit for bit,
    standing still included."""
    path = _path.Path(tuple(0.5 * i for i in range(200)), tuple(0.01 * i * i for i in range(200)))
    points = path.tracker().args[0]
    car = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)
    ref = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)
    hint = want_hint = 0
    for i in range(300):
        thr, brake = (0.6, 0.0) if i < 150 else (0.0, 1.0)
        s, hint = car.step(thr, brake, 0.3 * math.sin(0.05 * i), 0.8, 0.1, 0.05, 2, points, hint)
        ref.step(thr, brake, 0.3 * math.sin(0.05 * i), 0.8, 0.1, 0.05, 2)
        want_s, want_hint = path.track(ref.x, ref.y, want_hint)
        assert repr((car.x, car.y, car.yaw, car.vx, car.vy, car.r, s, hint)) == repr(
            (ref.x, ref.y, ref.yaw, ref.vx, ref.vy, ref.r, want_s, want_hint)
        ), f"step {i}"
    assert car.speed == 0.0 and hint > 10  # drove along and braked to a stop


def _boxes(n: int, seed: int) -> list[tuple[tuple[float, ...], tuple[float, ...]]]:
    """Box pairs (x, y, yaw, half length, half width): apart, touching and overlapping."""
    rnd = random.Random(seed)

    def box(spread: float) -> tuple[float, ...]:
        return (
            rnd.uniform(-spread, spread),
            rnd.uniform(-spread, spread),
            rnd.uniform(-4.0, 4.0),
            rnd.uniform(0.2, 3.0),
            rnd.uniform(0.2, 1.2),
        )

    return [(box(s), box(s)) for s in (rnd.choice([2.0, 6.0, 30.0]) for _ in range(n))]


def test_compiled_box_distance_is_bit_identical_to_python(monkeypatch) -> None:
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_collision, "_FLAT", None)  # load it now, compiled
    fast = _collision.box_distance_flat_fn()
    assert fast is not _collision.box_distance_flat  # numba compiled it
    pairs = _boxes(20000, 2)
    dists = [_collision.box_distance(a, b) for a, b in pairs]
    assert 0.0 in dists and max(dists) > 10.0  # overlapping and distant pairs both tested
    bad = [(a, b) for (a, b), d in zip(pairs, dists, strict=True) if repr(fast(*a, *b)) != repr(d)]
    assert not bad, f"{len(bad)} of 20000 pairs differ, e.g. {bad[0]}"


def test_compiled_proximity_is_bit_identical_to_python(monkeypatch) -> None:
    """The proximity monitor's kernel (box distance, disc TTC and DRAC of a pair) against the
    Python code: overlapping, near and distant boxes, closing and receding velocities."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_monitors, "_PROXIMITY", None)  # load it now, compiled
    fast = _monitors.proximity_fn()
    assert fast is not _monitors.proximity  # numba compiled it
    rnd = random.Random(11)
    ttcs, dracs = [], []
    for a, b in _boxes(20000, 3):
        ev, av = (rnd.uniform(-2.0, 12.0), rnd.uniform(-0.5, 0.5)), (rnd.uniform(0, 8), 0.0)
        k = (a[3], a[4], b[3], b[4], rnd.uniform(1.0, 3.0))
        near = rnd.random() < 0.8
        args = (*a[:3], *ev, *b[:3], *av)
        want = _monitors.proximity(*args, k, near)
        assert repr(fast(*args, np.array(k), near)) == repr(want), (args, k, near)
        ttcs.append(want[1])
        dracs.append(want[2])
    assert min(ttcs) == -1.0 and 0.0 in ttcs and max(ttcs) > 1.0  # none, touching, ahead
    assert min(dracs) == -1.0 and max(dracs) > 1.0  # none (touching or apart), decelerating


def test_compiled_proximity_route_is_bit_identical_to_python(monkeypatch) -> None:
    """The fused monitor update's first call per step (the ego's route offset and the road
    pre-test, then the proximity kernel) against the Python code and against
    ``EgoRouteMonitor.update``'s arithmetic: egos on and beside their route, clear and
    not clear of the road's clearance."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_monitors, "_PROXIMITY_ROUTE", None)  # load it now, compiled
    fast = _monitors.proximity_route_fn()
    assert fast is not _monitors.proximity_route  # numba compiled it
    rnd = random.Random(17)
    n = 40
    hs = tuple(rnd.uniform(-math.pi, math.pi) for _ in range(n))
    rows = (
        tuple(rnd.uniform(-50, 50) for _ in range(n)),
        tuple(rnd.uniform(-50, 50) for _ in range(n)),
        tuple(math.sin(h) for h in hs),
        tuple(math.cos(h) for h in hs),
        hs,
        [rnd.uniform(0.0, 6.0) for _ in range(n)],
        [rnd.uniform(0.0, 6.0) for _ in range(n)],
    )
    rt = np.array(rows)
    xs, ys, sin, cos, _, left, right = rows
    clears = []
    for a, b in _boxes(20000, 3):
        i = rnd.randrange(n)
        ex, ey = xs[i] + rnd.uniform(-5, 5), ys[i] + rnd.uniform(-5, 5)
        ev, av = (rnd.uniform(-2.0, 12.0), rnd.uniform(-0.5, 0.5)), (rnd.uniform(0, 8), 0.0)
        k = (a[3], a[4], b[3], b[4], rnd.uniform(1.0, 3.0), rnd.uniform(1, 3), rnd.uniform(0.5, 1))
        near = rnd.random() < 0.8
        args = (ex, ey, a[2], *ev, *b[:3], *av)
        want = _monitors.proximity_route(rows, i, *args, k, near)
        assert repr(fast(rt, i, *args, np.array(k), near)) == repr(want), (args, k, near)
        lat = -(ex - xs[i]) * sin[i] + (ey - ys[i]) * cos[i]  # EgoRouteMonitor.update's
        r = k[6] + k[5] * abs(math.sin(a[2] - hs[i])) + _monitors.CLEARANCE_SLACK
        assert want[:2] == (lat, lat + r < left[i] and r - lat < right[i])
        assert want[2:] == _monitors.proximity(*args, k, near)
        clears.append(want[1])
    assert 1000 < sum(clears) < len(clears) - 1000  # clear and not clear both tested


def test_compiled_projection_is_bit_identical_to_python(monkeypatch) -> None:
    """The camera projection's kernel (near-plane clipping included) with and without
    numba: every output field, for boxes in front, beside and behind the camera."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_camera, "_PROJECT", None)  # load it now, compiled
    fast = _camera._kernel()
    assert fast is not _camera._project  # numba compiled it
    rnd = random.Random(3)
    clipped = 0
    for _ in range(20000):
        ex, ey, eyaw = rnd.uniform(-50.0, 50.0), rnd.uniform(-50.0, 50.0), rnd.uniform(-4, 4)
        spread = rnd.choice([1.0, 5.0, 40.0])
        args = (
            ex,
            ey,
            eyaw,
            ex + rnd.uniform(-spread, spread),
            ey + rnd.uniform(-spread, spread),
            rnd.uniform(-4.0, 4.0),
            rnd.uniform(0.3, 6.0),
            rnd.uniform(0.3, 2.5),
            rnd.uniform(0.5, 3.5),
            rnd.choice([0.0, 2.5]),
            rnd.choice([0.0, 1.0, 1.6]),
            rnd.uniform(200.0, 900.0),
            800.0,
            450.0,
        )
        want = _camera._project(*args)
        clipped += not want[0]
        assert repr(fast(*args)) == repr(want), args  # repr: -0.0 and 0.0 differ too
    assert 1000 < clipped < 19000  # both branches ran


def _folded_remainder(rel: float) -> float:
    """The view angle as ``project_raw`` computed it before the fold was compiled."""
    view = abs(math.remainder(rel, math.tau))
    return math.pi - view if view > 0.5 * math.pi else view


def test_view_angle_equals_the_folded_math_remainder(monkeypatch) -> None:
    """The projection's view angle (``math.remainder`` written out for numba) gives
    ``math.remainder``'s folded bits, in Python and compiled: random angles of every
    size, the halfway cases (odd multiples of pi), their neighbours and signed zeros."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    fast = compiled(_camera._view_angle, 0.3)
    assert fast is not None
    rnd = random.Random(7)
    rels = [rnd.uniform(-20.0, 20.0) * 10.0 ** rnd.randint(-6, 5) for _ in range(50000)]
    halves = [k * 0.5 * math.pi for k in range(-41, 42)]
    rels += halves + [math.nextafter(h, d) for h in halves for d in (-math.inf, math.inf)]
    rels += [0.0, -0.0, 5e-324, 1e300, -1e300]
    for rel in rels:
        want = repr(_folded_remainder(rel))
        assert repr(_camera._view_angle(rel)) == want, rel
        assert repr(fast(rel)) == want, rel
    assert math.isnan(_camera._view_angle(math.nan)) and math.isnan(fast(math.nan))


def _view_array(rnd: random.Random) -> list[float]:
    """A random array for ``_pem._pem_view``: coefficients (the side's gain 0 in half of
    them), camera, box, scene, colour, detection gains, the score noise's size gain, cap and
    bend."""
    coeffs = [rnd.uniform(-3.0, 3.0) for _ in _pem.COEFFICIENTS]
    size_min = rnd.choice([1.0, 6.0, 30.0])
    coeffs[_pem._SIZE_MIN], coeffs[_pem._SIZE_REF] = size_min, rnd.uniform(10.0, 40.0)
    coeffs[_pem._SIZE_MAX] = size_min + rnd.choice([5.0, 250.0])
    coeffs[_pem._SIDE_GAIN] = rnd.choice([0.0, coeffs[_pem._SIDE_GAIN]])  # the side: off or on
    camera = [rnd.choice([0.0, 2.5]), rnd.choice([1.0, 1.6]), rnd.uniform(200.0, 900.0), 800.0]
    box = [rnd.uniform(0.3, 6.0), rnd.uniform(0.3, 2.5), rnd.uniform(0.5, 3.5)]
    scene = [rnd.choice([0.0, 0.02, 5.0]), rnd.choice([0.0, 20.0]), rnd.uniform(1e-12, 1.0)]
    scene.append(rnd.choice([0.0, rnd.uniform(0.0, 1.0)]))
    color = [rnd.uniform(-1.0, 1.0) for _ in range(5)]
    detect = [rnd.choice([0.0, rnd.uniform(-3.0, 3.0)]) for _ in range(2)]
    detect.append(rnd.choice([0.0, rnd.uniform(-1.0, 1.0)]))  # noise_size_gain
    detect.append(rnd.choice([60.0, 450.0]))  # noise_size_max_px
    detect.append(rnd.choice([0.0, rnd.uniform(-1.5, 1.5)]))  # noise_bend_gain
    detect.append(rnd.choice([40.0, 150.0]))  # noise_bend_px
    return coeffs + camera + [450.0] + box + scene + color + detect


def test_compiled_pem_view_is_bit_identical_to_python(monkeypatch) -> None:
    """The PEM's per-actor score kernel (projection, features, logit) with and without
    numba: actors in front, beside and behind, boxes below the size floor, fog, darkness."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_pem, "_VIEW_FN", None)  # load it now, compiled
    fast = _pem._view_kernel()
    assert fast is not _pem._pem_view  # numba compiled it
    rnd = random.Random(8)
    seen = 0
    for _ in range(20000):
        q = _view_array(rnd)
        ex, ey, eyaw = rnd.uniform(-50.0, 50.0), rnd.uniform(-50.0, 50.0), rnd.uniform(-4, 4)
        spread = rnd.choice([3.0, 15.0, 60.0])
        pose = (ex, ey, eyaw, ex + rnd.uniform(-spread, spread), ey + rnd.uniform(-spread, spread))
        args = (*pose, rnd.uniform(-4.0, 4.0))
        want = _pem._pem_view(q, *args)
        seen += want[0]
        assert repr(fast(np.array(q), *args)) == repr(want), (q, args)
    assert 1000 < seen < 19000  # both branches ran


def test_compiled_route_tracking_is_bit_identical_to_python(monkeypatch) -> None:
    """``Path.tracker()`` (compiled) against ``Path.track`` along a curved route driven
    forward with noise, from stale and out-of-range hints too."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_path, "_TRACK", None)  # load it now, compiled
    xs = tuple(20.0 * math.sin(0.02 * k) for k in range(150))
    ys = tuple(0.8 * k - 0.004 * k * k for k in range(150))
    path = _path.Path(xs, ys)
    track = path.tracker()
    assert isinstance(track, functools.partial) and track.func is _path._track_kernel()
    assert track.func is not _path._track  # numba compiled it
    rnd = random.Random(4)
    hint = 0
    for k in range(3000):
        s = 0.04 * k + rnd.uniform(-0.5, 0.5)
        x, y, _ = path.point_at(s)
        x, y = x + rnd.uniform(-2.0, 2.0), y + rnd.uniform(-2.0, 2.0)
        start = rnd.choice([hint, hint + 3, -1, 500])
        want = path.track(x, y, start)
        got = track(x, y, start)
        assert repr(got) == repr(want), (x, y, start)
        hint = want[1]
    assert hint > 100  # the walk reached the far end of the route


def test_compiled_car_steering_is_bit_identical_to_python(monkeypatch) -> None:
    """The scripted and timed cars' pure pursuit of their route (compiled) against the
    Python code, the route's ends and its interior, any heading; the compiled binary
    search finds bisect's index."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_controllers, "_CAR", None)  # load it now, compiled
    fast = _controllers._car_kernel()
    assert fast is not _controllers._car_steer  # numba compiled it
    xs = tuple(20.0 * math.sin(0.02 * k) for k in range(150))
    ys = tuple(0.8 * k - 0.004 * k * k for k in range(150))
    path = _path.Path(xs, ys)
    pts = (path.xs, path.ys, path.hs, path.ss)
    arr = np.array(pts)
    rnd = random.Random(5)
    for _ in range(20000):
        s = rnd.choice([rnd.uniform(-5.0, path.length + 5.0), rnd.choice(path.ss)])
        args = (s, rnd.uniform(-30, 30), rnd.uniform(-10, 120), rnd.uniform(-4, 4), 1.4, 2.7, 0.6)
        assert repr(fast(arr, *args)) == repr(_controllers._car_steer(pts, *args)), args
        assert _path._bisect_right(path.ss, s) == bisect.bisect_right(path.ss, s)


def test_compiled_timed_car_is_bit_identical_to_python(monkeypatch) -> None:
    """The timed car's kernel (timing law and steering in one) against the Python code:
    every phase and its switches, standing and moving cars and egos, any heading."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_controllers, "_TIMED", None)  # load it now, compiled
    fast = _controllers._timed_kernel()
    assert fast is not _controllers._timed_car  # numba compiled it
    path = _path.Path(tuple(float(k) for k in range(120)), tuple(0.01 * k * k for k in range(120)))
    pts = (path.xs, path.ys, path.hs, path.ss)
    arr = np.array(pts)
    rnd = random.Random(8)
    phases = set()
    for _ in range(20000):
        k = (3.0, rnd.uniform(10, 30), 4.17, 0.5, 0.5, 0.1, rnd.choice([0.0, 1.0]))
        k += (rnd.choice([40.0, math.inf]), 45.0, 0.8, 4.0, 1.4, 2.7, 0.6)
        speed = rnd.choice([0.0, rnd.uniform(0.0, 0.2), rnd.uniform(0.0, 12.0)])
        args = (rnd.randint(0, 2), rnd.uniform(-5, 60), speed, rnd.uniform(-5, 130))
        args += (rnd.uniform(-5, 125), rnd.uniform(-5, 60), rnd.uniform(-4, 4))
        args += (rnd.uniform(0, 12), rnd.choice([0.0, rnd.uniform(-0.3, 0.3)]))
        want = _controllers._timed_car(pts, k, *args)
        assert repr(fast(arr, np.array(k), *args)) == repr(want), (k, args)
        phases.add((args[0], want[0]))
    assert {(0, 0), (0, 1), (0, 2), (1, 1), (1, 2), (2, 2)} <= phases


def test_compiled_route_step_is_bit_identical_to_python(monkeypatch) -> None:
    """The reference stack's route following (compiled, float array) against the Python
    code (list): a noisy drive to the end of a curved route, throttle and brake, before
    and after the PID windows fill; outputs and the whole array, step by step."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    fast = compiled(_reference._route_step, helpers=(window_pid,))
    assert fast is not None
    route = [(20.0 * math.sin(0.02 * k), 0.8 * k - 0.004 * k * k) for k in range(60)]
    gains = (3.0, 0.5, 25.0, 0.15, 0.05, 0.07, 0.58, 0.02, 0.5, 0.05, 4.0, 0.75, 0.3, 0.8, 0.1)
    monkeypatch.setattr(_reference, "_STEP", _reference._route_step)  # route_state: a list
    state = _reference.route_state(gains, route)
    array = np.array(state, dtype=np.float64)
    rnd = random.Random(6)
    braked = 0
    for k in range(500):
        x, y = route[min(k // 7, 59)]
        args = (x + rnd.uniform(-1, 1), y + rnd.uniform(-1, 1), rnd.uniform(-3.2, 3.2))
        args += (rnd.choice([0.0, rnd.uniform(0.0, 12.0)]),)
        want = _reference._route_step(state, *args)
        assert repr(fast(array, *args)) == repr(want), (k, args)
        assert array.tolist() == [float(v) for v in state]
        braked += want[1] > 0.0
    assert state[_reference._DONE] == 1.0 and 10 < braked < 500  # braked; route consumed


def _helper_a(x: float) -> float:
    return x * 2.0


def _helper_b(x: float) -> float:
    return x * 3.0


def _calls_helper(x: float) -> float:
    return _helper_a(x) + 1.0


def test_the_disk_cache_name_changes_with_any_helper(monkeypatch) -> None:
    """numba's cache checks only the kernel's own file: a helper changed elsewhere must
    give a new cached name (the code digest), so stale machine code is never loaded."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    one = compiled(_calls_helper, 1.0, helpers=(_helper_a,))
    again = compiled(_calls_helper, 1.0, helpers=(_helper_a,))
    other = compiled(_calls_helper, 1.0, helpers=(("_helper_a", _helper_b),))
    assert one(1.0) == 3.0 and other(1.0) == 4.0  # the helper bound under its name ran
    assert one.py_func.__qualname__ == again.py_func.__qualname__
    assert one.py_func.__qualname__ != other.py_func.__qualname__
    assert one.py_func.__qualname__.startswith("_calls_helper_")


def _twice(x: float, n: int) -> float:
    return x * n


def test_typed_entry_is_the_compiled_code_without_dispatch(monkeypatch) -> None:
    """The entry point of the one compiled signature gives the dispatcher's results; a
    kernel with no or several signatures stays the dispatcher; in check mode a call with
    other types than the signature's raises TypeError (a float where an int was compiled
    would be truncated silently)."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)
    monkeypatch.delenv("SITCOV_JIT_CHECK", raising=False)
    assert typed_entry(None) is None
    fast = compiled(_twice, 1.5, 2)
    entry = typed_entry(fast)
    assert entry is not fast and type(entry).__name__ == "builtin_function_or_method"
    assert repr(entry(0.1, 3)) == repr(fast(0.1, 3)) == repr(_twice(0.1, 3))
    monkeypatch.setenv("SITCOV_JIT_CHECK", "1")
    checked = typed_entry(fast)
    assert checked(0.1, 3) == _twice(0.1, 3)
    with pytest.raises(TypeError, match="_twice"):
        checked(0.1, 2.5)
    fast(0.1, 2.5)  # a second signature: the dispatcher must choose
    assert typed_entry(fast) is fast
    assert typed_entry(compiled(_twice)) is not None  # not called yet: no signature


HERE = Path(__file__).parent


@pytest.mark.slow
def test_every_kernel_call_of_the_golden_runs_has_the_compiled_types() -> None:
    """The hot loop calls the kernels' entry points without numba's type checks
    (``typed_entry``): a process with ``SITCOV_JIT_CHECK=1`` checks every call's argument
    types against the compiled signature while it runs the fast subsets of both golden
    files (two cars; many actors, every controller, every shipped map), which must also
    still land on the golden bits."""
    need_module("numba", "fast")
    env = {**os.environ, "SITCOV_JIT_CHECK": "1", "PYTHONPATH": str(HERE.parent.parent)}
    env.pop("SITCOV_NO_JIT", None)
    tests = [
        f"{HERE / 'test_sim_world_golden.py'}::test_every_seventh_golden_run_is_reproduced_exactly",
        f"{HERE / 'test_sim_world_actors_golden.py'}"
        "::test_every_fifth_golden_multi_actor_run_is_reproduced_exactly",
    ]
    done = subprocess.run(
        [sys.executable, "-m", "pytest", "-q", "-p", "no:xdist", *tests],
        cwd=HERE.parent.parent,
        env=env,
        capture_output=True,
        text=True,
        timeout=900,
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert "2 passed" in done.stdout, done.stdout[-2000:]


def _bits(values: tuple) -> list:
    """Each float as its exact hex text (numpy and Python floats alike), ints as they are."""
    return [float(v).hex() if isinstance(v, float | np.floating) else v for v in values]


def test_compiled_timed_car_move_is_bit_identical_and_is_the_law_then_the_move(
    monkeypatch,
) -> None:
    """The timed car's whole step (law, steering, then the body's move on its route) is
    the compiled kernel's and the Python code's bit for bit, and is what ``_timed_car``
    then ``Vehicle.step`` give: every phase, standing and moving cars, the watcher's say
    (nothing moves), crosswind and low friction."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_controllers, "_TIMED_MOVE", None)  # load it now, compiled
    fast = _controllers._timed_move_kernel()
    assert fast is not _controllers._timed_car_move  # numba compiled it
    path = _path.Path(tuple(float(k) for k in range(120)), tuple(0.01 * k * k for k in range(120)))
    pts = (path.xs, path.ys, path.hs, path.ss)
    arr = np.array(pts)
    route = path.tracker().args[0]
    # what drive passes: the steering's points then the tracking's, one array per route
    both = _controllers._car_move_points(path, route)
    assert both is _controllers._car_move_points(path, route)
    assert np.array_equal(both, np.concatenate((arr, route)))
    rnd = random.Random(9)
    moved = set()
    for _ in range(5000):
        vehicle = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)
        p = vehicle.p
        k = (3.0, rnd.uniform(10, 30), 4.17, 0.5, 0.5, 0.1, rnd.choice([0.0, 1.0]))
        k += (rnd.choice([40.0, math.inf]), 45.0, 0.8, 4.0, p.lr, p.wheelbase, p.steer_max)
        s = rnd.uniform(-5, 125)
        x, y, _ = path.point_at(s)
        speed = rnd.choice([0.0, 0.0, rnd.uniform(0.0, 0.2), rnd.uniform(0.0, 12.0)])
        yaw = rnd.uniform(-4, 4)
        vx, vy, r = speed, rnd.choice([0.0, rnd.uniform(-0.3, 0.3)]), rnd.choice([0.0, 0.1])
        vx, vy, r = (0.0, 0.0, 0.0) if speed == 0.0 else (vx, vy, r)
        law = (rnd.randint(0, 2), rnd.uniform(-5, 60), rnd.choice([0.0, speed, 5.0]))
        hint = rnd.randint(0, 110)
        mu, lat = rnd.choice([1.0, 0.1]), rnd.choice([0.0, 0.7])
        react = rnd.choice([0, 0, 1, 2, 3])
        kc = _dynamics._constants(vehicle._k, True)
        args = (*law, s, x + rnd.uniform(-1, 1), y + rnd.uniform(-1, 1), yaw, vx, vy, r)
        tail = (hint, mu, lat, _dynamics.DT, _dynamics.SUBSTEPS, react)
        want = _controllers._timed_car_move((*pts, *route), (*k, *vehicle._k), *args, *tail)
        kk, both = np.concatenate((np.array(k), kc)), np.concatenate((arr, route))
        assert _bits(fast(both, kk, *args, *tail)) == _bits(want), (k, args, tail)
        moved.add((want[0], want[4]))
        # the law, then Vehicle.step (when the watcher has no say)
        phase, thr, brk, steer = _controllers._timed_car(pts, k, *args[:-1])
        assert want[:4] == (phase, thr, brk, steer)
        if want[4]:
            vehicle.x, vehicle.y, vehicle.yaw = args[4], args[5], args[6]
            vehicle.vx, vehicle.vy, vehicle.r = vx, vy, r
            tracked = vehicle.step(thr, brk, steer, mu, lat, route=route, hint=hint)
            state = (vehicle.x, vehicle.y, vehicle.yaw, vehicle.vx, vehicle.vy, vehicle.r)
            assert _bits(want[5:]) == _bits((*state, *tracked))
    assert {(0, 1), (1, 1), (1, 2), (2, 2), (1, 0), (2, 0)} <= moved


def test_compiled_box_on_area_gives_the_corner_tests_answers(monkeypatch) -> None:
    """The road monitor's exact test (all four corners on the drivable area, compiled)
    says what ``DrivableArea.contains`` of each corner says, on every shipped map, for
    boxes on, across and off the road edges at any heading (both answers tested)."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_collision, "_AREA", None)  # load it now, compiled
    assert _collision.box_on_area_fn() is not _collision.box_on_area  # numba compiled it
    from sitcov.sim.embedded._map import load_map

    rnd = random.Random(12)
    answers = []
    for name in ("t-junction", "crossroads", "roundabout", "merge"):
        area = load_map(name).drivable_area
        flat = [v for edges in area._edges for edge in edges for v in edge]
        ends = list(itertools.accumulate(len(edges) for edges in area._edges))
        for _ in range(3000):
            poly = rnd.choice(area.polygons)  # a point in it, then up to 3 m away
            w = [rnd.random() for _ in poly]
            x = sum(wi * px for wi, (px, _) in zip(w, poly, strict=True)) / sum(w)
            y = sum(wi * py for wi, (_, py) in zip(w, poly, strict=True)) / sum(w)
            x, y = x + rnd.uniform(-3.0, 3.0), y + rnd.uniform(-3.0, 3.0)
            yaw, hl, hw = rnd.uniform(-4.0, 4.0), rnd.uniform(0.2, 2.5), rnd.uniform(0.2, 1.0)
            c, s = math.cos(yaw), math.sin(yaw)
            corners = ((hl, hw), (hl, -hw), (-hl, -hw), (-hl, hw))
            want = all(area.contains(x + a * c - b * s, y + a * s + b * c) for a, b in corners)
            assert _collision.box_on_area(flat, ends, x, y, yaw, hl, hw) is want
            assert area.contains_box(x, y, yaw, hl, hw) is want
            answers.append(want)
    assert 1000 < sum(answers) < len(answers) - 1000


def test_compiled_pem_frame_is_bit_identical_and_is_the_sensors_python_loop(monkeypatch) -> None:
    """The PEM's per-actor frame kernel (view, noise, score, gate, jitter) is the Python
    code's bit for bit, and a sensor using it gives the very detections of its Python
    loop (the same draws in the same order): cars, cyclists and pedestrians in and out of
    view, new and continued noise tracks, frames skipped, rain and dry scenes."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_pem, "_FRAME_FN", None)  # load it now, compiled
    fast = _pem._frame_kernel()
    assert fast and fast is not _pem._pem_frame  # numba compiled it
    from types import SimpleNamespace

    from sitcov.perception import PEMSensor
    from sitcov.perception._base import ActorView, Pose
    from sitcov.weather._conditions import Conditions

    rnd = random.Random(13)
    for _ in range(3000):  # the kernel against its Python code
        q = np.array(_view_array(rnd))
        c = [rnd.uniform(0.0, 0.9), rnd.choice([0.0, 0.2]), rnd.choice([0.0, 0.3]), 1.0, 0.5]
        c += [rnd.choice([1.0, 0.7]), rnd.choice([0.0, -0.3]), rnd.choice([0.0, 0.4]), 1.2]
        c += [rnd.choice([0.1, 0.5]), 0.05, rnd.choice([0.0, 0.02]), rnd.random(), 800.0, 450.0]
        c += rnd.choice([[0.0] * 4, [0.1, 0.05, -0.1, -0.12]])  # the box's mean offsets
        c += [rnd.choice([0.05, 0.02])]  # the vertical corner noise
        # outlier frames (their cut: none or ~10 %, their ratio) and the upper size power
        c += [rnd.choice([-math.inf, -1.28]), rnd.choice([1.0, 3.0]), rnd.choice([0.0, -0.6])]
        c += [rnd.choice([0.0, 0.4])]  # the lower tail's curvature
        c += [rnd.choice([1.0, 1.5]), rnd.choice([60.0, 100.0])]  # the windy rain's upper factor
        c += [rnd.choice([0.0, 0.3]), 25.0, 450.0]  # the AR part's size gain, reference, clamp
        c += rnd.choice([[0.0, 0.0, 1.0], [-0.2, 0.45, 0.6]])  # the score's ceiling (or none)
        track = [rnd.gauss(0, 1), rnd.gauss(0, 1), rnd.gauss(0, 1), 3.0, rnd.choice([0.0, 1.0])]
        normals = [rnd.gauss(0, 1) for _ in range(_pem.FRAME_NORMALS + 3)]
        ex, ey, eyaw = rnd.uniform(-50, 50), rnd.uniform(-50, 50), rnd.uniform(-4, 4)
        pose = (ex + rnd.uniform(-30, 30), ey + rnd.uniform(-30, 30), rnd.uniform(-4, 4))
        args = (rnd.randint(0, 3), float(rnd.randint(4, 9)), ex, ey, eyaw, *pose)
        s_py = np.concatenate((c, track, q))  # the Python code writes the track in place
        s_c = s_py.copy()
        want = _pem._pem_frame(s_py, normals, *args)
        got = fast(s_c, np.array(normals), *args)
        assert _bits(got) == _bits(want), (c, args)
        assert _bits(s_c.tolist()) == _bits(s_py.tolist()), (c, args)
    ego = SimpleNamespace(x=0.0, y=0.0, yaw=0.0)
    kinds = [("car", 4.6, 1.8, 1.5), ("cyclist", 1.8, 0.6, 1.7), ("pedestrian", 0.5, 0.5, 1.8)]
    # the shipped car PEM, and it with outlier frames, an upper size gain, a lower tail and
    # a wider upper spread in windy rain and a noise that forgets faster on a larger box,
    # and a score ceiling
    wide = {"noise_outlier_share": 0.1, "noise_outlier_ratio": 3.0, "noise_up_size_gain": -0.4,
            "noise_low_tail": 0.4, "noise_up_rain_wind_gain": 0.8,
            "noise_tau_size_gain": 0.3, "noise_ceiling_logit": -0.2,
            "noise_ceiling_size_gain": 0.45, "noise_ceiling_slope": 0.6}  # fmt: skip
    for rain, car_params in ((0.0, None), (0.6, None), (0.0, wide), (0.6, wide)):
        cond = Conditions(rain_noise=rain, rain_wind=rain * 0.7)
        runs = {}
        for frame_fn in (False, None):  # the Python loop, then the compiled frame
            monkeypatch.setattr(_pem, "_FRAME_FN", frame_fn)
            sensor = PEMSensor(car_params)
            sensor.reset(frame_dt=0.1)
            looks = [  # one per detection: a cyclist gives its rider and its bicycle
                look
                for k, ln, w, h in kinds
                for look in sensor.prepare_parts(
                    ActorView(Pose(0, 0, 0), ln, w, h, 0.0, (90, 90, 200), k), cond
                )
            ]
            normals = _pem.NormalStream(np.random.default_rng(4), 128)
            walk = random.Random(5)
            frames = []
            for t in range(600):
                seen = []
                for i, look in enumerate(looks):
                    far = 40.0 - 0.06 * t + 5.0 * i
                    body = SimpleNamespace(x=far, y=walk.uniform(-6, 6), yaw=walk.uniform(-4, 4))
                    if walk.random() < 0.85:
                        seen.append((look, body))
                out = sensor.detect_prepared(ego.x, ego.y, ego.yaw, seen, cond, normals)
                frames.append(out)
            runs[frame_fn] = frames
        assert runs[False] == runs[None]
        assert sum(map(len, runs[None])) > 300  # detections of every kind
        assert {d.label for f in runs[None] for d in f} >= {"car", "person"}


def test_compiled_move_tracked_is_bit_identical(monkeypatch) -> None:
    """A car's move on its route with the commands' clamps (compiled) against the Python
    code: commands out of range, standing with and without drive, crosswind, low
    friction; and ``Vehicle.step`` returns its tracking and keeps its state so."""
    need_module("numba", "fast")
    monkeypatch.delenv("SITCOV_NO_JIT", raising=False)  # about the compiled path
    monkeypatch.setattr(_dynamics, "_MOVE", None)  # load it now, compiled
    fast = _dynamics._move_kernel()
    assert fast is not _dynamics.move_tracked  # numba compiled it
    path = _path.Path(tuple(float(k) for k in range(120)), tuple(0.01 * k * k for k in range(120)))
    route = path.tracker().args[0]
    rnd = random.Random(21)
    moved = set()
    for _ in range(5000):
        vehicle = _dynamics.Vehicle(_dynamics.default_params(), 0.0, 0.0, 0.0)
        kc = _dynamics._constants(vehicle._k, True)
        s = rnd.uniform(0, 110)
        x, y, yaw = path.point_at(s)
        standing = rnd.random() < 0.3
        state = (0.0, 0.0, 0.0) if standing else (rnd.uniform(0, 12), rnd.uniform(-0.3, 0.3), 0.1)
        cmd = (rnd.choice([0.0, -0.2, rnd.uniform(0, 1.3)]), rnd.uniform(-0.2, 1.2))
        cmd += (rnd.uniform(-1.5, 1.5),)
        env = (rnd.choice([1.0, 0.1]), rnd.choice([0.0, 0.8]), _dynamics.DT, _dynamics.SUBSTEPS)
        args = (vehicle.p.steer_max, x, y, yaw, *state, *cmd, *env, route, rnd.randint(0, 100))
        want = _dynamics.move_tracked(vehicle._k, *args)
        assert _bits(fast(kc, *args)) == _bits(want), args
        moved.add(want[0])
        vehicle.x, vehicle.y, vehicle.yaw = x, y, yaw
        vehicle.vx, vehicle.vy, vehicle.r = state
        tracked = vehicle.step(*cmd, *env, route=route, hint=args[-1])
        assert _bits(tracked) == _bits(want[8:])
        now = (vehicle.x, vehicle.y, vehicle.yaw, vehicle.vx, vehicle.vy, vehicle.r)
        assert _bits(now) == _bits(want[2:8])
    assert moved == {True, False}
