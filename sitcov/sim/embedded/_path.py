"""Polylines with arc length: lane centre lines and routes as pure geometry."""

from __future__ import annotations

import functools
import math
from bisect import bisect_right
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np


def wrap_angle(angle: float) -> float:
    """``angle`` wrapped to (-pi, pi] [rad]."""
    return math.atan2(math.sin(angle), math.cos(angle))


@dataclass(frozen=True)
class Path:
    """A polyline through (x, y) points [m] with cumulative arc length ``s`` [m].

    Points are about 1 m apart (closer on arcs); headings are of the segment leaving each
    point (the last repeats the one before).
    """

    xs: tuple[float, ...]
    ys: tuple[float, ...]
    ss: tuple[float, ...] = field(init=False)
    hs: tuple[float, ...] = field(init=False)

    def __post_init__(self) -> None:
        if len(self.xs) != len(self.ys) or len(self.xs) < 2:
            raise ValueError("Path: need at least two points and as many x as y")
        ss = [0.0]
        hs = []
        for i in range(1, len(self.xs)):
            dx, dy = self.xs[i] - self.xs[i - 1], self.ys[i] - self.ys[i - 1]
            ss.append(ss[-1] + math.hypot(dx, dy))
            hs.append(math.atan2(dy, dx))
        hs.append(hs[-1])
        object.__setattr__(self, "ss", tuple(ss))
        object.__setattr__(self, "hs", tuple(hs))

    def __hash__(self) -> int:
        """The points' hash, computed once: paths key the per-route caches that every run's
        setup looks up (hashing the point tuples costs ~5 us each time)."""
        h = self.__dict__.get("_hash")
        if h is None:
            h = self.__dict__["_hash"] = hash((self.xs, self.ys))
        return h

    @classmethod
    def from_points(cls, points: Sequence[tuple[float, float]]) -> Path:
        """A path through ``points``, dropping consecutive duplicates."""
        xs: list[float] = []
        ys: list[float] = []
        for x, y in points:
            if xs and math.hypot(x - xs[-1], y - ys[-1]) < 1e-6:
                continue
            xs.append(float(x))
            ys.append(float(y))
        return cls(tuple(xs), tuple(ys))

    @property
    def length(self) -> float:
        """Total arc length [m]."""
        return self.ss[-1]

    @functools.cached_property
    def points(self) -> tuple[tuple[float, float], ...]:
        """The (x, y) points [m] (made once: a run's setup reads them)."""
        return tuple(zip(self.xs, self.ys, strict=False))

    @functools.cached_property
    def max_curvature(self) -> float:
        """Largest curvature |dh/ds| between successive segments [1/m]."""
        best = 0.0
        for i in range(1, len(self.xs) - 1):
            ds = 0.5 * (self.ss[i + 1] - self.ss[i - 1])
            dh = abs(wrap_angle(self.hs[i] - self.hs[i - 1]))
            if ds > 0 and dh / ds > best:
                best = dh / ds
        return best

    def point_at(self, s: float) -> tuple[float, float, float]:
        """(x, y, heading) at arc length ``s`` (clamped to the path; linear between points)."""
        return _point_at(self.xs, self.ys, self.hs, self.ss, s)

    def project(
        self, x: float, y: float, hint: int = 0, back: int = 2, ahead: int = 4
    ) -> tuple[float, int]:
        """Arc length of the closest point to (x, y), searching near segment ``hint``.

        A local search (``back`` segments behind, ``ahead`` in front) keeps per-step
        tracking cheap: a vehicle moves less than one segment per control step. Pass
        ``hint=-1`` for a global search. Returns (s [m], segment index).
        """
        xs, ys, ss = self.xs, self.ys, self.ss
        last = len(xs) - 2
        if hint < 0:
            lo, hi = 0, last
        else:
            lo, hi = max(0, hint - back), min(last, hint + ahead)
        best_d, best_s, best_i = math.inf, 0.0, lo
        for i in range(lo, hi + 1):
            x0, y0 = xs[i], ys[i]
            dx, dy = xs[i + 1] - x0, ys[i + 1] - y0
            seg2 = dx * dx + dy * dy
            f = ((x - x0) * dx + (y - y0) * dy) / seg2 if seg2 > 0 else 0.0
            f = 0.0 if f < 0.0 else (1.0 if f > 1.0 else f)
            px, py = x0 + f * dx - x, y0 + f * dy - y
            d = px * px + py * py
            if d < best_d:
                best_d, best_s, best_i = d, ss[i] + f * (ss[i + 1] - ss[i]), i
        return best_s, best_i

    def track(self, x: float, y: float, i: int) -> tuple[float, int]:
        """Arc length of (x, y) projected on segment ``i`` or its neighbours, moving forward.

        The cheap per-step version of :meth:`project` for a vehicle that moves less than a
        segment per call: walks from segment ``i`` while the projection falls off its end.
        Returns (s [m], segment index). :meth:`tracker` gives the same, faster.
        """
        return _track((self.xs, self.ys, self.ss), x, y, i)

    def tracker(self) -> Callable[[float, float, int], tuple[float, int]]:
        """:meth:`track` as the world calls it every step: compiled by numba when it is
        installed (``_jit.py``; the same bits), with this path's points bound (a new one
        per call, so nothing compiled is kept on the path, which stays picklable)."""
        fast = _track_kernel()
        pts: Any = (self.xs, self.ys, self.ss)
        if fast is not _track:  # compiled: the points as one array (one type check)
            pts = self._track_array
        return functools.partial(fast, pts)

    @functools.cached_property
    def _track_array(self) -> np.ndarray:
        """(xs, ys, ss) as one float array, made once per path (a map's routes are cached,
        so runs share it; the kernel only reads it)."""
        return np.array((self.xs, self.ys, self.ss), dtype=np.float64)

    def lateral_offset(self, x: float, y: float, hint: int = -1) -> float:
        """Signed distance of (x, y) from the path [m], positive to the left."""
        s, i = self.project(x, y, hint)
        px, py, h = self.point_at(s)
        return -(x - px) * math.sin(h) + (y - py) * math.cos(h)

    def sub(self, s0: float, s1: float, step: float = 1.0) -> Path:
        """The part between arc lengths ``s0`` and ``s1``, resampled at most ``step`` apart."""
        s0, s1 = max(0.0, s0), min(self.length, s1)
        if s1 <= s0:
            raise ValueError(f"Path.sub: empty range {s0}..{s1}")
        marks = [s0]
        inner = [s for s in self.ss if s0 < s < s1]
        for s in [*inner, s1]:
            base = marks[-1]  # fixed: a lazy generator would read the growing list
            gap = s - base
            n = max(1, math.ceil(gap / step - 1e-9))
            marks.extend([base + gap * k / n for k in range(1, n + 1)])
        return Path.from_points([self.point_at(s)[:2] for s in marks])

    def resampled(self, step: float) -> list[tuple[float, float]]:
        """Points every ``step`` metres (including both ends)."""
        n = max(1, math.ceil(self.length / step))
        return [self.point_at(self.length * k / n)[:2] for k in range(n + 1)]


def _track(pts: Any, x: float, y: float, i: int) -> tuple[float, int]:
    """:meth:`Path.track` on the path's (xs, ys, ss) (plain floats, so numba compiles it)."""
    xs, ys, ss = pts[0], pts[1], pts[2]
    last = len(xs) - 2
    i = 0 if i < 0 else (last if i > last else i)
    step = 0  # direction of the walk; never reverses, so corners cannot make it loop
    while True:
        x0, y0 = xs[i], ys[i]
        dx, dy = xs[i + 1] - x0, ys[i + 1] - y0
        seg2 = dx * dx + dy * dy
        f = ((x - x0) * dx + (y - y0) * dy) / seg2 if seg2 > 0 else 0.0
        if f > 1.0 and i < last and step >= 0:
            i, step = i + 1, 1
        elif f < 0.0 and i > 0 and step <= 0:
            i, step = i - 1, -1
        else:
            break
    f = 0.0 if f < 0.0 else (1.0 if f > 1.0 else f)
    return ss[i] + f * (ss[i + 1] - ss[i]), i


_TRACK: Any = None


def _track_kernel() -> Any:
    """:func:`_track` compiled by numba when it is installed, else itself (loaded once)."""
    global _TRACK
    if _TRACK is None:
        from sitcov._jit import compiled, typed_entry

        pts = np.array([[0.0, 1.0, 2.0], [0.0, 0.0, 0.0], [0.0, 1.0, 2.0]])
        _TRACK = typed_entry(compiled(_track, pts, 0.5, 0.1, 0)) or _track
    return _TRACK


def _point_at(
    xs: Sequence[float], ys: Sequence[float], hs: Sequence[float], ss: Sequence[float], s: float
) -> tuple[float, float, float]:
    """:meth:`Path.point_at` on the path's coordinates (plain floats, so numba compiles it)."""
    if s <= 0.0:
        return xs[0], ys[0], hs[0]
    if s >= ss[-1]:
        return xs[-1], ys[-1], hs[-2]
    i = bisect_right(ss, s) - 1
    seg = ss[i + 1] - ss[i]
    f = (s - ss[i]) / seg if seg > 0 else 0.0
    x = xs[i] + f * (xs[i + 1] - xs[i])
    y = ys[i] + f * (ys[i + 1] - ys[i])
    return x, y, hs[i]


def _bisect_right(a: Sequence[float], x: float) -> int:
    """``bisect.bisect_right`` (the same search, so the same index) for numba, which
    cannot call the C builtin."""
    lo, hi = 0, len(a)
    while lo < hi:
        mid = (lo + hi) // 2
        if x < a[mid]:
            hi = mid
        else:
            lo = mid + 1
    return lo
