"""numba compilation of the hot loop's arithmetic, bit-identical to the Python code.

numba is a dependency (until session 6 the optional ``fast`` extra): :func:`compiled` turns a
plain-float function of the hot loop into machine code (a car's integrator and route
tracking ``_dynamics.integrate_tracked``, with the commands' clamps
``_dynamics.move_tracked``, the camera projection
``perception._camera._project``, the PEM's projection, features and logit of one actor
``perception._pem._pem_view``, the box distance ``_collision.box_distance_flat``, the
route tracking ``_path._track``, the cars' steering ``_controllers._car_steer``, a timed
car's law and steering ``_controllers._timed_car`` and with its move
``_controllers._timed_car_move``, the proximity monitor's distance and TTC
``_monitors.proximity`` (with the ego's route offset ``_monitors.proximity_route``),
the road monitor's exact test ``_collision.box_on_area``, the
PEM's whole frame of one actor ``perception._pem._pem_frame``, the reference stack's route
following ``av._reference._route_step``); the hot ones are called through
:func:`typed_entry`; without
numba, or with the environment variable ``SITCOV_NO_JIT`` set (to anything but ``0`` or
an empty string), the Python function runs as it is. Either way a run gives the same bits:

- numba compiles the very same code object, with the same operations in the same order
  and no fast-math (LLVM then neither reorders nor fuses floating-point operations);
- ``sin``, ``cos``, ``tan``, ``atan``, ``atan2``, ``tanh`` and ``sqrt`` call the same C
  library functions CPython calls;
- the projection's view angle needs ``math.remainder``, which numba lacks:
  ``perception._camera._view_angle`` writes out CPython's computation of it (tested bit for
  bit, halfway cases included);
- ``math.hypot`` is the exception: CPython (3.10+) computes a correctly rounded
  ``sqrt(x*x + y*y)`` with its own algorithm, numba calls the C library's ``hypot``,
  which is not always correctly rounded (about 2 in 1000 random pairs differ in the last
  bit). :func:`hypot_cr` computes the correctly rounded value in double-double
  arithmetic (the squares and their sum split exactly into a high and a low part, one
  Newton correction of the square root), so it agrees with CPython's.

Compiled code is cached on disk next to this module (numba's ``cache=True``), so a new
process loads it instead of compiling it again (a few seconds; importing numba itself
costs about a second of CPU per process).
``tests/sim/test_sim_jit.py`` checks each compiled kernel against its Python code bit
for bit.

A call into compiled code costs about 0.4 us plus about 0.06 us per float argument and
0.3 us per array (numba checks each argument's type); a tuple argument costs far more.
With numba's reference-counted memory manager (NRT) each array argument also costs a
``malloc``, a ``free`` and a GIL ensure and release per call, so kernels are compiled
without it unless they make arrays or lists of their own (:func:`compiled`'s ``nrt``).
So the kernels are few and large (one per car and step for its body and route
position), take floats and float arrays, and are called only where they replace more
Python work than that.
"""

from __future__ import annotations

import copy
import hashlib
import math
import os
import tempfile
import types
import warnings
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from sitcov.errors import SitcovError

#: Veltkamp's splitting constant for doubles: 2**27 + 1.
_SPLIT = 134217729.0
#: Below this magnitude the squares would lose bits to underflow: scale up first.
_TINY = 2.0**-900
_UP = 2.0**600


def enabled() -> bool:
    """Whether numba is importable and not switched off by ``SITCOV_NO_JIT``."""
    if os.environ.get("SITCOV_NO_JIT", "") not in ("", "0"):
        return False
    try:
        import numba  # noqa: F401
    except ImportError:
        return False
    return True


def _two_prod(a: float, b: float) -> tuple[float, float]:
    """``a * b`` as ``(p, e)`` with ``p + e`` exact (Dekker's product, no fused ops)."""
    p = a * b
    t = _SPLIT * a
    ah = t - (t - a)
    al = a - ah
    t = _SPLIT * b
    bh = t - (t - b)
    bl = b - bh
    return p, ((ah * bh - p) + ah * bl + al * bh) + al * bl


def _hypot_cr(x: float, y: float) -> float:
    """Correctly rounded ``sqrt(x*x + y*y)`` (see the module docstring), for numba."""
    x, y = abs(x), abs(y)
    if x < y:
        x, y = y, x
    if y == 0.0 or x == math.inf:
        return x
    if x != x or y != y:
        return math.nan
    back = 1.0
    if x < _TINY:  # scaled up exactly, down again at the end
        x, y, back = x * _UP, y * _UP, _UP
    scale = math.ldexp(1.0, -math.frexp(x)[1])  # x * scale in [0.5, 1): exact
    xs, ys = x * scale, y * scale
    ph, pl = _two_prod(xs, xs)
    qh, ql = _two_prod(ys, ys)
    sh = ph + qh
    sl = (ph - sh) + qh + (pl + ql)  # ph >= qh: the sum's rounding error, exactly
    h = math.sqrt(sh + sl)
    th, tl = _two_prod(h, h)
    h += (((sh - th) - tl) + sl) / (2.0 * h)
    return h / scale / back


_HYPOT: Any = None


def hypot_cr() -> Callable[[float, float], float]:
    """The compiled correctly rounded hypot (numba must be installed)."""
    global _HYPOT
    if _HYPOT is None:
        _HYPOT = _hypot_dispatcher(cache=True)
    return _HYPOT


def _hypot_dispatcher(*, cache: bool) -> Any:
    """:func:`_hypot_cr` as a numba dispatcher, on numba's disk cache when ``cache``."""
    import numba

    two_prod = numba.njit(cache=cache, inline="always")(_two_prod)
    fn = types.FunctionType(
        _hypot_cr.__code__, {**_hypot_cr.__globals__, "_two_prod": two_prod}, "_hypot_cr"
    )
    return numba.njit(cache=cache)(fn)


def compiled(
    fn: Callable[..., Any],
    *example: Any,
    helpers: tuple[Callable[..., Any] | tuple[str, Callable[..., Any]], ...] = (),
    nrt: bool = False,
) -> Callable[..., Any] | None:
    """``fn`` compiled by numba (its ``hypot`` global bound to :func:`hypot_cr`), or None
    when numba is not :func:`enabled`.

    ``nrt``: compile ``fn`` with numba's reference-counted memory manager (NRT), which
    a kernel needs only to make arrays or lists of its own (the helpers ``fn`` calls are
    compiled as ``fn`` is). Without it (the default) each call takes its array
    arguments as they are; with it numba wraps every array argument of every call in a
    new ``MemInfo`` (a ``malloc``, then at the call's end a GIL ensure, a ``free`` and a
    GIL release): about 4 % of the time of the default campaign's runs (six arrays a
    step), 5.5 % of their instructions. The machine code of the arithmetic is the same
    either way (the same bits). A kernel that allocates fails to compile without it
    (numba's "NRT required but not enabled"): pass ``nrt=True``.

    ``helpers`` are the plain-float functions ``fn`` calls by their global names; they are
    compiled the same way and bound under those names (in ``fn`` and in each other); a
    ``(name, function)`` pair binds ``function`` under another name (e.g. a compilable
    stand-in for a C builtin that gives the same result).
    With ``example`` arguments the function is compiled (or loaded from the cache) right
    away by calling it once; if numba fails there (e.g. a numba too old or too new for
    the installed numpy), a warning says so and None is returned: the Python code runs.
    The example first runs as Python (:func:`check_example`).

    Raises:
        SitcovError: the example does not run as Python (a bug of the caller's).
    """
    if not enabled():
        return None
    if example:
        check_example(fn, example)
    with cache_lock():  # one process at a time compiles or loads kernels (docstring below)
        return _compiled(fn, example, helpers, nrt)


def check_example(fn: Callable[..., Any], example: tuple[Any, ...]) -> None:
    """Run ``fn``'s Python code once on a copy of ``example`` (its arrays may be written
    in place).

    Why: compiled code does not check array bounds. An example array shorter than the
    layout it stands for makes the compiled example call read past its end, and what lies
    there differs from process to process. That was the intermittent "numba could not
    compile _pem_frame (ZeroDivisionError)" of sessions 20 to 22: the frame kernel's
    example lacked the last two values of the view array's layout, and now and then the
    bytes after it were a zero the kernel divided by. Python raises ``IndexError`` there
    every time.

    Raises:
        SitcovError: the Python code raises on the example (naming the function).
    """
    try:
        fn(*copy.deepcopy(example))
    except Exception as exc:  # noqa: BLE001 - any error: the example is wrong
        raise SitcovError(
            f"the compile example of {fn.__name__} does not run as Python "
            f"({type(exc).__name__}: {exc}); fix the example where {fn.__name__} is compiled"
        ) from exc


@contextmanager
def cache_lock() -> Iterator[None]:
    """Hold this machine's lock on numba's disk cache (per user) for the block.

    Why: kernels share cached helpers (the PEM's view and frame kernels both compile
    ``_logit``, ``_project``, ...), and numba numbers a function's cached overloads per
    index file without a lock of its own (numba issues #4807, #10128). Two processes that
    compile different kernels at once from an empty cache (two xdist workers, two campaign
    workers) could write the same overload file for two signatures: the one that reads it
    next would run the other's machine code. Without ``fcntl`` (not POSIX) the cache is
    used unguarded, as numba does.

    The lock cannot cover a compile numba starts by itself (a kernel called with argument
    types it has not seen). So :func:`_compiled` also compiles afresh, without the disk
    cache, a kernel whose example call fails after loading: a damaged entry would cost one
    compile, not the compiled path. (The "could not compile _pem_frame" failure this lock
    and that retry were first written against was not the cache's: a short example,
    :func:`check_example`.)"""
    try:
        import fcntl
    except ImportError:
        yield
        return
    path = Path(tempfile.gettempdir()) / f"sitcov-numba-cache-{os.getuid()}.lock"
    with path.open("a") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def _compiled(
    fn: Callable[..., Any],
    example: tuple[Any, ...],
    helpers: tuple[Callable[..., Any] | tuple[str, Callable[..., Any]], ...],
    nrt: bool,
) -> Callable[..., Any] | None:
    """:func:`compiled`'s work, under :func:`cache_lock`."""
    try:
        fast = _build(fn, helpers, cache=True, nrt=nrt)
        if example:
            try:
                fast(*example)
            except Exception:  # noqa: BLE001 - a damaged cache entry: compile afresh
                # numba's cache has races the lock cannot cover (cache_lock): a kernel
                # loaded from a damaged entry would fail its example, so this process
                # compiles it and its helpers in memory instead (the same code)
                fast = _build(fn, helpers, cache=False, nrt=nrt)
                fast(*example)
    except Exception as exc:  # noqa: BLE001 - any numba failure: run the Python code
        warnings.warn(
            f"numba could not compile {fn.__name__} ({type(exc).__name__}: {exc}); "
            "running the Python code (same results, slower)",
            RuntimeWarning,
            stacklevel=3,  # the caller of compiled()
        )
        return None
    return fast


def _build(
    fn: Callable[..., Any],
    helpers: tuple[Callable[..., Any] | tuple[str, Callable[..., Any]], ...],
    *,
    cache: bool,
    nrt: bool = False,
) -> Any:
    """``fn`` and its ``helpers`` as numba dispatchers (``hypot`` bound to
    :func:`hypot_cr`), on numba's disk cache when ``cache``; without it nothing comes from
    the cache, the shared hypot included. ``nrt``: :func:`compiled`'s (numba compiles the
    helpers that ``fn`` calls with ``fn``'s options)."""
    import numba

    bound: dict[str, Any] = {"hypot": hypot_cr() if cache else _hypot_dispatcher(cache=False)}
    codes = [_hypot_cr.__code__, _two_prod.__code__, fn.__code__]
    for helper in helpers:  # in call order: a helper may call the ones before it
        name, func = helper if isinstance(helper, tuple) else (helper.__name__, helper)
        bound[name] = numba.njit(cache=cache)(_clone(func, bound))
        codes.append(func.__code__)
    main = _clone(fn, bound)
    # numba's disk cache checks only the source file of ``fn``; a helper from another
    # file compiled into it would go stale unseen. The code's digest in the cached
    # name makes any change to ``fn`` or a helper compile afresh. The cache does not
    # key its entries by numba's options either: ``nrt`` is in the digest too.
    text = "".join(map(_code_text, codes)) + ("" if nrt else "no-nrt")
    digest = hashlib.sha1(text.encode()).hexdigest()
    main.__qualname__ += "_" + digest[:12]
    return numba.njit(cache=cache, _nrt=nrt)(main)


def typed_entry(fast: Callable[..., Any] | None) -> Callable[..., Any] | None:
    """The machine code of ``fast`` (a :func:`compiled` kernel, already called once with
    its example) for its one compiled signature, called without numba's dispatch; None
    for None, ``fast`` itself when that entry is not there (another numba, more than one
    signature).

    numba's dispatcher works out the types of every argument on every call to pick the
    machine code for them (about 0.2 us of a hot kernel's 0.4-0.9 us call); the entry
    point only converts the arguments to the signature's types. So it is the same code
    (the same bits) as long as every call passes those very types: float arrays as the
    example's (C-contiguous float64), ints where the example had ints. A float where an
    int was compiled would be truncated silently, an int array read as floats: with the
    environment variable ``SITCOV_JIT_CHECK`` set (to anything but ``0`` or an empty
    string) each call checks its argument types against the signature instead and raises
    ``TypeError`` on a mismatch (``tests/sim/test_sim_jit.py`` runs scenes of every kind so).
    """
    if fast is None:
        return None
    overloads = getattr(fast, "overloads", None)
    if not overloads or len(overloads) != 1:
        return fast
    ((sig, result),) = overloads.items()
    entry = getattr(result, "entry_point", None)
    if entry is None:
        return fast
    if os.environ.get("SITCOV_JIT_CHECK", "") not in ("", "0"):
        return _checked(entry, sig, fast)
    return entry


def _checked(entry: Callable[..., Any], sig: tuple[Any, ...], fast: Any) -> Callable[..., Any]:
    """``entry`` behind a check that each argument has the type of ``sig`` (numba's)."""
    import numba

    name = fast.py_func.__name__

    def call(*args: Any) -> Any:
        got = tuple(numba.typeof(a) for a in args)
        if got != tuple(sig):
            raise TypeError(f"{name}: called with {got}, compiled for {tuple(sig)}")
        return entry(*args)

    return call


def _code_text(code: types.CodeType) -> str:
    """A text that changes whenever the code's operations, names or constants do (and is
    the same in every process, unlike ``marshal``'s reference flags or ``repr`` of code)."""
    consts = [_code_text(c) if isinstance(c, types.CodeType) else repr(c) for c in code.co_consts]
    return repr((code.co_code, code.co_names, code.co_varnames, consts))


def _clone(fn: Callable[..., Any], bound: dict[str, Any]) -> Callable[..., Any]:
    """A copy of ``fn`` whose globals named in ``bound`` are replaced (numba compiles it)."""
    clone = types.FunctionType(
        fn.__code__, {**fn.__globals__, **bound}, fn.__name__, fn.__defaults__
    )
    clone.__qualname__ = fn.__qualname__
    clone.__module__ = fn.__module__
    return clone
