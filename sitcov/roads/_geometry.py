"""OpenDRIVE plan-view geometry: the road reference line as a function of ``s``.

One class per record of ``<planView>`` (line, arc, spiral, poly3, paramPoly3), each
evaluating a batch of local arc lengths ``ds`` [m] into world ``x``, ``y`` [m] and heading
``h`` [rad]. Elevation and superelevation are ignored: sitcov's world is flat, so a road
is its projection on the ground plane (what esmini's ``odrplot`` x, y columns are too).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import fresnel

#: Samples per metre used to invert a polynomial's arc length (poly3, paramPoly3).
_ARC_SAMPLES_PER_M = 20


@dataclass(frozen=True)
class Geometry:
    """A plan-view record: start ``s`` [m], start pose ``x``, ``y`` [m] and ``hdg`` [rad],
    ``length`` [m]."""

    s: float
    x: float
    y: float
    hdg: float
    length: float

    def local(self, ds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(u, v, heading change) in the record's start frame for local arc lengths ``ds``."""
        raise NotImplementedError

    def evaluate(self, ds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World (x, y, heading) at local arc lengths ``ds`` (0 <= ds <= length) [m]."""
        u, v, dh = self.local(np.asarray(ds, dtype=float))
        c, s = math.cos(self.hdg), math.sin(self.hdg)
        return self.x + c * u - s * v, self.y + s * u + c * v, self.hdg + dh


@dataclass(frozen=True)
class Line(Geometry):
    """A straight line."""

    def local(self, ds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return ds, np.zeros_like(ds), np.zeros_like(ds)


@dataclass(frozen=True)
class Arc(Geometry):
    """A circular arc of constant ``curvature`` [1/m] (positive: turning left)."""

    curvature: float = 0.0

    def local(self, ds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k = self.curvature
        if abs(k) < 1e-12:
            return Line.local(self, ds)  # type: ignore[arg-type]
        a = k * ds
        return np.sin(a) / k, (1.0 - np.cos(a)) / k, a


@dataclass(frozen=True)
class Spiral(Geometry):
    """A clothoid whose curvature changes linearly from ``curv_start`` to ``curv_end`` [1/m].

    Evaluated exactly with Fresnel integrals: the record is the piece of the standard
    clothoid (curvature ``c * u``, ``c`` the curvature rate) from ``u0 = curv_start / c``
    to ``u0 + length``, moved so that its start lies on the record's start pose.
    """

    curv_start: float = 0.0
    curv_end: float = 0.0

    def local(self, ds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        k0 = self.curv_start
        c = (self.curv_end - k0) / self.length if self.length > 0 else 0.0
        if abs(c) < 1e-12:
            return Arc.local(self, ds)  # type: ignore[arg-type]
        u0 = k0 / c
        x0, y0 = _clothoid(np.array([u0]), c)
        xs, ys = _clothoid(u0 + ds, c)
        h0 = 0.5 * c * u0 * u0
        dx, dy = xs - x0[0], ys - y0[0]
        cr, sr = math.cos(-h0), math.sin(-h0)
        dh = k0 * ds + 0.5 * c * ds * ds
        return cr * dx - sr * dy, sr * dx + cr * dy, dh


def _clothoid(u: np.ndarray, c: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of the clothoid with curvature ``c * u`` starting at the origin heading +x."""
    scale = math.sqrt(math.pi / abs(c))
    s_fresnel, c_fresnel = fresnel(u / scale)
    return scale * c_fresnel, math.copysign(1.0, c) * scale * s_fresnel


@dataclass(frozen=True)
class ParamPoly3(Geometry):
    """Parametric cubic ``u(p)``, ``v(p)`` in the start frame (``poly3`` is the special case
    ``u = p``, ``v = a + b p + c p^2 + d p^3``).

    ``p`` runs over ``[0, length]`` (``p_range="arcLength"``) or ``[0, 1]``
    (``"normalized"``); a point at arc length ``ds`` is found by inverting the curve's
    arc length numerically (as esmini does), since ``p`` is only approximately arc length.
    """

    u_coef: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 0.0)
    v_coef: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)
    p_max: float = 1.0

    def _table(self) -> tuple[np.ndarray, np.ndarray]:
        n = max(16, math.ceil(self.length * _ARC_SAMPLES_PER_M))
        p = np.linspace(0.0, self.p_max, n + 1)
        u, v = _poly(self.u_coef, p), _poly(self.v_coef, p)
        arc = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(u), np.diff(v)))))
        return p, arc

    def local(self, ds: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p_tab, arc = self._table()
        # scale so that the curve's own length maps onto the record's length
        p = np.interp(ds * arc[-1] / max(self.length, 1e-12), arc, p_tab)
        du, dv = _dpoly(self.u_coef, p), _dpoly(self.v_coef, p)
        return _poly(self.u_coef, p), _poly(self.v_coef, p), np.arctan2(dv, du)


def poly3(s: float, x: float, y: float, hdg: float, length: float, a, b, c, d) -> ParamPoly3:
    """A ``<poly3>`` record as the parametric cubic ``u = p``, ``v = a + b p + c p^2 + d p^3``.

    The range of ``u`` is where the curve's arc length reaches ``length``.
    """
    coef = (float(a), float(b), float(c), float(d))
    # u_max: arc length of (u, v(u)) equals length; found on a fine grid
    u = np.linspace(0.0, 2.0 * length, max(32, math.ceil(2 * length * _ARC_SAMPLES_PER_M)) + 1)
    arc = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(u), np.diff(_poly(coef, u))))))
    u_max = float(np.interp(length, arc, u))
    return ParamPoly3(s, x, y, hdg, length, (0.0, 1.0, 0.0, 0.0), coef, u_max)


def _poly(coef: tuple[float, float, float, float], p: np.ndarray) -> np.ndarray:
    a, b, c, d = coef
    return a + p * (b + p * (c + p * d))


def _dpoly(coef: tuple[float, float, float, float], p: np.ndarray) -> np.ndarray:
    _, b, c, d = coef
    return b + p * (2.0 * c + 3.0 * d * p)


class PlanView:
    """A road's reference line: its geometry records in order of ``s``."""

    def __init__(self, records: list[Geometry]) -> None:
        self.records = sorted(records, key=lambda g: g.s)
        self._starts = np.array([g.s for g in self.records])

    def evaluate(self, s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """World (x, y, heading) of the reference line at road arc lengths ``s`` [m]."""
        s = np.atleast_1d(np.asarray(s, dtype=float))
        idx = np.clip(np.searchsorted(self._starts, s, side="right") - 1, 0, len(self.records) - 1)
        x, y, h = np.empty_like(s), np.empty_like(s), np.empty_like(s)
        for i in np.unique(idx):
            g = self.records[i]
            mask = idx == i
            ds = np.clip(s[mask] - g.s, 0.0, g.length)
            x[mask], y[mask], h[mask] = g.evaluate(ds)
        return x, y, h
