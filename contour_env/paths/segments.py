"""Path segments (line, arc/helix, cubic piece) in metres: exact lengths, arc-length derivatives
and the packed rows of docs/ARCHITECTURE.md that the numba kernels read."""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from .checks import finite_number

SEG_LINE, SEG_ARC, SEG_CUBIC = 0, 1, 2

# Orthonormality tolerance for an arc's u, v: builders produce them to ~1e-16, G-code uses unit
# axes; anything worse than this is a caller error, not round-off.
ORTHONORMAL_TOL = 1e-9

# A cubic whose speed |dp/dq| drops below this fraction of its peak has (nearly) a cusp: its
# arc-length parameterisation, tangent and curvature are undefined there.
CUBIC_REGULAR_TOL = 1e-9

# Gauss–Legendre nodes on [-1, 1]. The speed of a cubic is sqrt(quartic), smooth on a regular
# piece; 16 nodes per panel plus panel doubling until two levels agree gives ~1e-15 relative.
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)
_MAX_PANELS = 4096
_LENGTH_RTOL = 1e-14

# Samples per chunk in vectorised cubic work: bounds the (chunk, 16, 3) temporaries (~25 MB).
_CHUNK = 16384


def _vec3(name: str, value) -> np.ndarray:
    """A 2-D or 3-D point/vector as a finite float64 (3,) array (2-D padded with z = 0)."""
    try:
        arr = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected 2 or 3 numbers, got {value!r}") from None
    if arr.shape == (2,):
        arr = np.array([arr[0], arr[1], 0.0])
    if arr.shape != (3,):
        raise ValueError(f"{name}: expected 2 or 3 coordinates, got shape {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: values must be finite, got {arr.tolist()}")
    return arr


def _finite(name: str, value) -> float:
    return finite_number(name, value, bools=True)


def _pad(radius: float, centre: np.ndarray) -> float:
    # a few ulps of slack so that round-off in the distance check never puts a point outside
    return float(radius * (1.0 + 1e-12) + 1e-15 * (1.0 + float(np.max(np.abs(centre)))))


# ------------------------------------------------------------------ vectorised kernels
# Each takes packed rows data (n, 16) and local arc lengths s (n,) in [0, length] (m) and
# returns position and d/ds, d²/ds², d³/ds³, each (n, 3).


def line_derivatives(data: np.ndarray, s: np.ndarray):
    """Line rows (type 0): position (m), unit tangent, and zero d²p/ds², d³p/ds³."""
    p0, p1 = data[:, 0:3], data[:, 3:6]
    chord = p1 - p0
    length = np.linalg.norm(chord, axis=1)
    t = chord / length[:, None]
    # interpolate by q = s / L so that s = L lands on p1 up to one rounding
    pos = p0 + (s / length)[:, None] * chord
    zeros = np.zeros_like(pos)
    return pos, t, zeros, zeros.copy()


def arc_derivatives(data: np.ndarray, s: np.ndarray):
    """Arc/helix rows (type 1), closed form: θ − θ0 = sign(sweep) s / sqrt(r² + pitch²)."""
    c, u, v, w = data[:, 0:3], data[:, 3:6], data[:, 6:9], data[:, 9:12]
    r, theta0, sweep, pitch = data[:, 12], data[:, 13], data[:, 14], data[:, 15]
    ell = np.hypot(r, pitch)  # |dp/dθ|, constant along an arc or helix
    sig = np.sign(sweep)
    rel = sig * s / ell  # θ − θ0
    th = theta0 + rel
    cs, sn = np.cos(th)[:, None], np.sin(th)[:, None]
    rr, pp = r[:, None], pitch[:, None]
    radial = cs * u + sn * v
    tang = -sn * u + cs * v
    pos = c + rr * radial + (pitch * rel)[:, None] * w
    d1 = (sig / ell)[:, None] * (rr * tang + pp * w)
    d2 = -(r / ell**2)[:, None] * radial
    d3 = -(sig * r / ell**3)[:, None] * tang
    return pos, d1, d2, d3


def _cubic_q_derivatives(coef: np.ndarray, q: np.ndarray):
    """Position and dp/dq, d²p/dq², d³p/dq³ of cubic rows coef (n, 4, 3) at q (n,)."""
    a, b, c, d = coef[:, 0], coef[:, 1], coef[:, 2], coef[:, 3]
    qq = q[:, None]
    pos = a + qq * (b + qq * (c + qq * d))
    p1 = b + qq * (2.0 * c + 3.0 * qq * d)
    p2 = 2.0 * c + 6.0 * qq * d
    p3 = 6.0 * d
    return pos, p1, p2, p3


def _chain_rule(p1, p2, p3):
    """dp/ds, d²p/ds², d³p/ds³ from q-derivatives, with σ = |p'| and d/ds = (1/σ) d/dq."""
    sig = np.linalg.norm(p1, axis=1)[:, None]
    dot12 = np.sum(p1 * p2, axis=1)[:, None]
    dot22 = np.sum(p2 * p2, axis=1)[:, None]
    dot13 = np.sum(p1 * p3, axis=1)[:, None]
    dsig = dot12 / sig  # dσ/dq
    d1 = p1 / sig
    d2 = p2 / sig**2 - p1 * dot12 / sig**4
    d3 = (
        p3 / sig**2
        - 2.0 * p2 * dsig / sig**3
        - p2 * dot12 / sig**4
        - p1 * (dot22 + dot13) / sig**4
        + 4.0 * p1 * dot12 * dsig / sig**5
    ) / sig
    return d1, d2, d3


def _speed(coef: np.ndarray, q: np.ndarray) -> np.ndarray:
    """|dp/dq| of cubic rows coef (n, 4, 3) at q (n, m) -> (n, m)."""
    # per component on (n, m) arrays: avoids (n, m, 3) temporaries and keeps the vector form,
    # which stays accurate where the speed is small (an expanded |p'|² quartic would cancel)
    sq = np.zeros(q.shape)
    for k in range(3):
        b, c, d = coef[:, 1, k, None], coef[:, 2, k, None], coef[:, 3, k, None]
        if not (b.any() or c.any() or d.any()):
            continue  # e.g. z of a planar xy spline
        comp = b + q * (2.0 * c + 3.0 * q * d)
        sq += comp * comp
    return np.sqrt(sq)


def _gl(coef: np.ndarray, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """∫ |p'| dq from q0 to q1 per row (16-point Gauss–Legendre)."""
    half = 0.5 * (q1 - q0)
    nodes = (0.5 * (q0 + q1))[:, None] + half[:, None] * _GL_X[None, :]
    return half * (_speed(coef, nodes) @ _GL_W)


def _panel_lengths(coef: np.ndarray, n_panels: int) -> np.ndarray:
    """Arc length of each of n_panels equal q-panels, per row: (n, n_panels)."""
    n = coef.shape[0]
    edges = np.linspace(0.0, 1.0, n_panels + 1)
    rows = np.repeat(coef, n_panels, axis=0)
    q0 = np.tile(edges[:-1], n)
    q1 = np.tile(edges[1:], n)
    return _gl(rows, q0, q1).reshape(n, n_panels)


def _n_panels(coef_row: np.ndarray) -> int:
    """Fewest equal panels (power of 2) for which composite GL has converged to ~1e-14."""
    coef = coef_row[None]
    panels = 1
    prev = float(_panel_lengths(coef, 1).sum())
    while panels < _MAX_PANELS:
        cur = float(_panel_lengths(coef, 2 * panels).sum())
        if abs(cur - prev) <= _LENGTH_RTOL * cur:
            return panels
        panels, prev = 2 * panels, cur
    return panels


class CubicTable:
    """Arc-length tables for a list of cubic pieces (all with the same number of q-panels).

    ``cum[k, j]`` is the arc length (m) of piece k from q = 0 to q = j / P. Arc length at any q
    is the table value plus a 16-point Gauss–Legendre integral over the partial panel; the
    inverse s -> q is a safeguarded Newton iteration on that (tolerance 1e-13 m).
    """

    def __init__(self, coef: np.ndarray, n_panels: int):
        self.coef = np.ascontiguousarray(coef, dtype=np.float64)  # (k, 4, 3)
        self.n_panels = int(n_panels)
        lens = _panel_lengths(self.coef, self.n_panels)
        self.cum = np.concatenate([np.zeros((len(lens), 1)), np.cumsum(lens, axis=1)], axis=1)
        self.length = self.cum[:, -1].copy()
        # normalised, row-offset keys: one searchsorted call finds every sample's panel
        self._keys = (
            4.0 * np.arange(len(lens))[:, None] + self.cum / self.length[:, None]
        ).reshape(-1)

    def arc_length(self, rows: np.ndarray, q: np.ndarray) -> np.ndarray:
        """Arc length (m) from q = 0 to q ∈ [0, 1] on pieces ``rows``."""
        P = self.n_panels
        j = np.minimum(np.floor(q * P).astype(np.int64), P - 1)
        qa = j / P
        return self.cum[rows, j] + _gl(self.coef[rows], qa, q)

    def q_of_s(self, rows: np.ndarray, s: np.ndarray) -> np.ndarray:
        """Invert the arc length: q with arc_length(q) = s (m, clamped to [0, length])."""
        out = np.empty(s.shape[0])
        for i0 in range(0, s.shape[0], _CHUNK):
            sl = slice(i0, i0 + _CHUNK)
            out[sl] = self._q_of_s(rows[sl], s[sl])
        return out

    def _q_of_s(self, rows, s):
        P = self.n_panels
        L = self.length[rows]
        s = np.clip(s, 0.0, L)
        # initial guess: linear interpolation inside the panel that holds s
        key = 4.0 * rows + s / L
        flat = np.searchsorted(self._keys, key, side="right") - 1
        j = np.clip(flat - rows * (P + 1), 0, P - 1)
        c0, c1 = self.cum[rows, j], self.cum[rows, j + 1]
        frac = np.clip((s - c0) / np.maximum(c1 - c0, 1e-300), 0.0, 1.0)
        q = (j + frac) / P
        lo, hi = np.zeros_like(q), np.ones_like(q)
        # 1e-13 m as asked, but never below what float64 can resolve on a long piece
        tol = np.maximum(1e-13, 8.0 * np.finfo(float).eps * L)
        act = np.arange(q.shape[0])
        for _ in range(100):
            r = rows[act]
            f = self.arc_length(r, q[act]) - s[act]
            done = (np.abs(f) <= tol[act]) | (hi[act] - lo[act] <= 4.0 * np.finfo(float).eps)
            act, f, r = act[~done], f[~done], r[~done]
            if act.size == 0:
                break
            qa = q[act]
            lo[act] = np.where(f < 0, qa, lo[act])
            hi[act] = np.where(f > 0, qa, hi[act])
            step = f / np.maximum(_speed(self.coef[r], qa[:, None])[:, 0], 1e-300)
            qn = qa - step
            # Newton, falling back to bisection when a step leaves the bracket
            bad = (qn <= lo[act]) | (qn >= hi[act])
            q[act] = np.where(bad, 0.5 * (lo[act] + hi[act]), qn)
        return q

    def derivatives(self, rows: np.ndarray, s: np.ndarray):
        """Position and d/ds, d²/ds², d³/ds³ (each (n, 3)) at local arc lengths s (m)."""
        n = s.shape[0]
        out = tuple(np.empty((n, 3)) for _ in range(4))
        for i0 in range(0, n, _CHUNK):  # chunks keep the temporaries small
            sl = slice(i0, i0 + _CHUNK)
            r = rows[sl]
            q = self._q_of_s(r, s[sl])
            pos, p1, p2, p3 = _cubic_q_derivatives(self.coef[r], q)
            out[0][sl] = pos
            out[1][sl], out[2][sl], out[3][sl] = _chain_rule(p1, p2, p3)
        return out


# ------------------------------------------------------------------------- segments


@dataclass(frozen=True, eq=False)
class Line:
    """Straight segment from ``start`` to ``end`` (2-D or 3-D points, m; end != start)."""

    start: np.ndarray
    end: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "start", _vec3("start", self.start))
        object.__setattr__(self, "end", _vec3("end", self.end))
        if not np.linalg.norm(self.end - self.start) > 0.0:
            raise ValueError("end: a line needs end != start (zero-length line)")

    @property
    def length(self) -> float:
        """Arc length (m), exact."""
        return float(np.linalg.norm(self.end - self.start))

    @property
    def start_point(self) -> np.ndarray:
        return self.start.copy()

    @property
    def end_point(self) -> np.ndarray:
        return self.end.copy()

    def derivatives(self, s) -> tuple:
        """Position and d/ds, d²/ds², d³/ds³ (each (n, 3)) at local arc lengths s ∈ [0, L] m."""
        s = np.clip(np.atleast_1d(np.asarray(s, dtype=np.float64)), 0.0, self.length)
        return line_derivatives(np.broadcast_to(self.pack()[1], (s.shape[0], 16)), s)

    def pack(self) -> tuple[int, np.ndarray, np.ndarray]:
        """(type 0, data (16,), bounding sphere [cx, cy, cz, r]) per docs/ARCHITECTURE.md."""
        data = np.zeros(16)
        data[:3], data[3:6] = self.start, self.end
        mid = 0.5 * (self.start + self.end)
        return SEG_LINE, data, np.array([*mid, _pad(0.5 * self.length, mid)])


@dataclass(frozen=True, eq=False)
class Arc:
    """Arc or helix p(θ) = c + r (cos θ u + sin θ v) + pitch (θ − θ0) w for θ from θ0 to θ0 + sweep.

    ``center`` (m), ``u``, ``v`` orthonormal (w = u × v, checked to 1e-9), ``radius`` > 0 (m),
    ``theta0`` (rad), ``sweep`` ≠ 0 signed (rad; negative runs clockwise about w; |sweep| may
    exceed 2π), ``pitch`` rise along w per radian (m/rad; 0 for a plane arc).
    """

    center: np.ndarray
    u: np.ndarray
    v: np.ndarray
    radius: float
    theta0: float
    sweep: float
    pitch: float = 0.0

    def __post_init__(self):
        put = object.__setattr__
        put(self, "center", _vec3("center", self.center))
        put(self, "u", _vec3("u", self.u))
        put(self, "v", _vec3("v", self.v))
        for name in ("radius", "theta0", "sweep", "pitch"):
            put(self, name, _finite(name, getattr(self, name)))
        if not self.radius > 0:
            raise ValueError(f"radius: must be > 0 m, got {self.radius!r}")
        if self.sweep == 0:
            raise ValueError("sweep: must be non-zero (rad)")
        nu, nv = np.linalg.norm(self.u), np.linalg.norm(self.v)
        if (
            abs(nu - 1) > ORTHONORMAL_TOL
            or abs(nv - 1) > ORTHONORMAL_TOL
            or abs(float(self.u @ self.v)) > ORTHONORMAL_TOL
        ):
            raise ValueError(
                f"u, v: must be orthonormal (|u| = {nu:.12g}, |v| = {nv:.12g}, "
                f"u·v = {float(self.u @ self.v):.3g})"
            )

    @property
    def w(self) -> np.ndarray:
        """Unit axis u × v; the arc runs counter-clockwise about it when sweep > 0."""
        return np.cross(self.u, self.v)

    @property
    def length(self) -> float:
        """Arc length (m), exact: |sweep| sqrt(radius² + pitch²)."""
        return abs(self.sweep) * math.hypot(self.radius, self.pitch)

    def point(self, theta) -> np.ndarray:
        """Points (n, 3) at angles theta (rad)."""
        th = np.atleast_1d(np.asarray(theta, dtype=np.float64))
        return (
            self.center
            + self.radius * (np.cos(th)[:, None] * self.u + np.sin(th)[:, None] * self.v)
            + (self.pitch * (th - self.theta0))[:, None] * self.w
        )

    @property
    def start_point(self) -> np.ndarray:
        return self.point(self.theta0)[0]

    @property
    def end_point(self) -> np.ndarray:
        return self.point(self.theta0 + self.sweep)[0]

    def derivatives(self, s) -> tuple:
        """Position and d/ds, d²/ds², d³/ds³ (each (n, 3)) at local arc lengths s ∈ [0, L] m."""
        s = np.clip(np.atleast_1d(np.asarray(s, dtype=np.float64)), 0.0, self.length)
        return arc_derivatives(np.broadcast_to(self.pack()[1], (s.shape[0], 16)), s)

    def pack(self) -> tuple[int, np.ndarray, np.ndarray]:
        """(type 1, data (16,), bounding sphere [cx, cy, cz, r]) per docs/ARCHITECTURE.md."""
        w = self.w
        data = np.concatenate(
            [self.center, self.u, self.v, w, [self.radius, self.theta0, self.sweep, self.pitch]]
        )
        # The projection on the plane ⟂ w is a circular arc: within its chord-diameter disk
        # when |sweep| ≤ π (Thales), else within the full circle. The rise along w spans
        # [0, pitch·sweep]; a sphere around that disk-times-interval cylinder holds the segment.
        half = 0.5 * self.sweep
        if abs(self.sweep) <= math.pi:
            tm = self.theta0 + half
            disk_c = self.center + self.radius * math.cos(half) * (
                math.cos(tm) * self.u + math.sin(tm) * self.v
            )
            disk_r = self.radius * abs(math.sin(half))
        else:
            disk_c, disk_r = self.center, self.radius
        half_rise = self.pitch * half
        centre = disk_c + half_rise * w
        return SEG_ARC, data, np.array([*centre, _pad(math.hypot(disk_r, half_rise), centre)])


@dataclass(frozen=True, eq=False)
class Cubic:
    """Cubic piece p(q) = a + b q + c q² + d q³ for q ∈ [0, 1] (q is not arc length; metres).

    The piece must be regular: its speed |dp/dq| may not drop below 1e-9 of its peak on [0, 1]
    (a cusp has no tangent, so no arc-length derivatives).
    """

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray

    def __post_init__(self):
        for name in ("a", "b", "c", "d"):
            object.__setattr__(self, name, _vec3(name, getattr(self, name)))
        lo, hi, q_lo = self._speed_range()
        if not hi > 0:
            raise ValueError("b, c, d: the cubic piece has zero length (b = c = d = 0)")
        if lo <= CUBIC_REGULAR_TOL * hi:
            raise ValueError(
                f"b, c, d: the cubic piece is not regular (its speed |dp/dq| vanishes near "
                f"q = {q_lo:.6g}); arc-length derivatives need a curve without cusps"
            )

    def _speed_range(self) -> tuple[float, float, float]:
        # |p'|² is a quartic; its extrema on [0, 1] are at the ends or where p'·p'' = 0 (cubic)
        p1 = [self.b, 2 * self.c, 3 * self.d]  # p'(q) = Σ p1[k] q^k
        p2 = [2 * self.c, 6 * self.d]
        g = np.zeros(4)
        for i, x in enumerate(p1):
            for k, y in enumerate(p2):
                g[i + k] += float(x @ y)
        cand = [0.0, 1.0]
        if np.any(g != 0):
            roots = np.roots(np.trim_zeros(g[::-1], "f"))
            cand += [float(r.real) for r in roots if abs(r.imag) < 1e-9 and 0 < r.real < 1]
        q = np.array(cand)
        sp = np.linalg.norm(self.b + q[:, None] * (2 * self.c + 3 * q[:, None] * self.d), axis=1)
        return float(sp.min()), float(sp.max()), float(q[np.argmin(sp)])

    @property
    def coef(self) -> np.ndarray:
        """Coefficients as a (4, 3) array [a, b, c, d]."""
        return np.array([self.a, self.b, self.c, self.d])

    @cached_property
    def n_panels(self) -> int:
        """Equal q-panels that 16-point Gauss–Legendre needs for ~1e-14 relative length."""
        return _n_panels(self.coef)

    @cached_property
    def _table(self) -> CubicTable:
        return CubicTable(self.coef[None], self.n_panels)

    @property
    def length(self) -> float:
        """Arc length (m): composite 16-point Gauss–Legendre, ~1e-14 relative."""
        return float(self._table.length[0])

    @property
    def start_point(self) -> np.ndarray:
        return self.a.copy()

    @property
    def end_point(self) -> np.ndarray:
        return self.a + self.b + self.c + self.d

    def point(self, q) -> np.ndarray:
        """Points (n, 3) at parameters q ∈ [0, 1]."""
        q = np.atleast_1d(np.asarray(q, dtype=np.float64))
        return _cubic_q_derivatives(np.broadcast_to(self.coef, (q.shape[0], 4, 3)), q)[0]

    def arc_length_to(self, q) -> np.ndarray:
        """Arc length (m) from q = 0 to each q ∈ [0, 1]."""
        q = np.clip(np.atleast_1d(np.asarray(q, dtype=np.float64)), 0.0, 1.0)
        return self._table.arc_length(np.zeros(q.shape[0], dtype=np.int64), q)

    def q_of_s(self, s) -> np.ndarray:
        """Parameter q at local arc lengths s ∈ [0, length] m (Newton, tolerance 1e-13 m)."""
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))
        return self._table.q_of_s(np.zeros(s.shape[0], dtype=np.int64), s)

    def derivatives(self, s) -> tuple:
        """Position and d/ds, d²/ds², d³/ds³ (each (n, 3)) at local arc lengths s ∈ [0, L] m."""
        s = np.atleast_1d(np.asarray(s, dtype=np.float64))
        return self._table.derivatives(np.zeros(s.shape[0], dtype=np.int64), s)

    def pack(self) -> tuple[int, np.ndarray, np.ndarray]:
        """(type 2, data (16,), bounding sphere [cx, cy, cz, r]) per docs/ARCHITECTURE.md.

        The sphere holds the Bézier control points, so (being convex) their convex hull,
        which holds the piece.
        """
        data = np.zeros(16)
        data[:12] = self.coef.reshape(-1)
        ctrl = np.array(
            [
                self.a,
                self.a + self.b / 3,
                self.a + 2 * self.b / 3 + self.c / 3,
                self.end_point,
            ]
        )
        centre = 0.5 * (ctrl.min(axis=0) + ctrl.max(axis=0))
        radius = float(np.max(np.linalg.norm(ctrl - centre, axis=1)))
        return SEG_CUBIC, data, np.array([*centre, _pad(radius, centre)])
