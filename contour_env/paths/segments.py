"""Path segments (line, arc/helix, cubic piece) with exact lengths, arc-length derivatives and
the packed form of docs/ARCHITECTURE.md that the numba kernels read. Metres throughout."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SEG_LINE, SEG_ARC, SEG_CUBIC = 0, 1, 2

# Gauss–Legendre nodes on [-1, 1]: 16 points integrate a cubic's speed to ~1e-14 relative
_GL_X, _GL_W = np.polynomial.legendre.leggauss(16)


def _vec3(name: str, value) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64).reshape(-1)
    if arr.shape == (2,):
        arr = np.array([arr[0], arr[1], 0.0])
    if arr.shape != (3,):
        raise ValueError(f"{name}: expected a 2-D or 3-D point, got shape {np.shape(value)}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: values must be finite, got {arr.tolist()}")
    return arr


def _finite(name: str, value: float) -> float:
    value = float(value)
    if not np.isfinite(value):
        raise ValueError(f"{name}: must be finite, got {value}")
    return value


@dataclass(frozen=True, eq=False)
class Line:
    """Straight segment from ``start`` to ``end`` (m)."""

    start: np.ndarray
    end: np.ndarray

    def __post_init__(self):
        object.__setattr__(self, "start", _vec3("start", self.start))
        object.__setattr__(self, "end", _vec3("end", self.end))
        if np.linalg.norm(self.end - self.start) <= 0.0:
            raise ValueError("end: a line needs end != start (zero-length line)")

    @property
    def length(self) -> float:
        return float(np.linalg.norm(self.end - self.start))

    @property
    def start_point(self) -> np.ndarray:
        return self.start

    @property
    def end_point(self) -> np.ndarray:
        return self.end

    def derivatives(self, s: np.ndarray):
        """Position and d/ds, d²/ds², d³/ds³ at local arc lengths s (m), each (n, 3)."""
        t = (self.end - self.start) / self.length
        n = s.shape[0]
        pos = self.start + s[:, None] * t
        return pos, np.broadcast_to(t, (n, 3)).copy(), np.zeros((n, 3)), np.zeros((n, 3))

    def pack(self):
        data = np.zeros(16)
        data[:3], data[3:6] = self.start, self.end
        mid = 0.5 * (self.start + self.end)
        return SEG_LINE, data, np.array([*mid, 0.5 * self.length])


@dataclass(frozen=True, eq=False)
class Arc:
    """Arc or helix: p(θ) = c + r (cos θ u + sin θ v) + pitch (θ − θ0) w, θ ∈ θ0 → θ0 + sweep.

    u, v orthonormal (w = u × v); radius > 0 (m); sweep ≠ 0 signed (rad, negative: clockwise
    about w); pitch: rise along w per radian (m/rad).
    """

    center: np.ndarray
    u: np.ndarray
    v: np.ndarray
    radius: float
    theta0: float
    sweep: float
    pitch: float = 0.0

    def __post_init__(self):
        s = object.__setattr__
        s(self, "center", _vec3("center", self.center))
        s(self, "u", _vec3("u", self.u))
        s(self, "v", _vec3("v", self.v))
        for name in ("radius", "theta0", "sweep", "pitch"):
            s(self, name, _finite(name, getattr(self, name)))
        if self.radius <= 0:
            raise ValueError(f"radius: must be > 0 m, got {self.radius}")
        if self.sweep == 0:
            raise ValueError("sweep: must be non-zero (rad)")
        if (
            abs(np.linalg.norm(self.u) - 1) > 1e-9
            or abs(np.linalg.norm(self.v) - 1) > 1e-9
            or abs(float(self.u @ self.v)) > 1e-9
        ):
            raise ValueError("u, v: must be orthonormal vectors")

    @property
    def w(self) -> np.ndarray:
        return np.cross(self.u, self.v)

    @property
    def _ell(self) -> float:
        return float(np.hypot(self.radius, self.pitch))

    @property
    def length(self) -> float:
        return abs(self.sweep) * self._ell

    def point(self, theta) -> np.ndarray:
        theta = np.atleast_1d(np.asarray(theta, dtype=np.float64))
        return (
            self.center
            + self.radius * (np.cos(theta)[:, None] * self.u + np.sin(theta)[:, None] * self.v)
            + (self.pitch * (theta - self.theta0))[:, None] * self.w
        )

    @property
    def start_point(self) -> np.ndarray:
        return self.point(self.theta0)[0]

    @property
    def end_point(self) -> np.ndarray:
        return self.point(self.theta0 + self.sweep)[0]

    def derivatives(self, s: np.ndarray):
        sig = np.sign(self.sweep)
        ell = self._ell
        th = self.theta0 + sig * s / ell
        c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        r, u, v, w = self.radius, self.u, self.v, self.w
        pos = self.point(th)
        d1 = (sig / ell) * (r * (-sn * u + c * v) + self.pitch * w)
        d2 = (1.0 / ell**2) * (-r * (c * u + sn * v))
        d3 = (sig / ell**3) * (r * (sn * u - c * v))
        return pos, d1, d2, d3

    def pack(self):
        data = np.concatenate(
            [
                self.center,
                self.u,
                self.v,
                self.w,
                [self.radius, self.theta0, self.sweep, self.pitch],
            ]
        )
        half_rise = 0.5 * self.pitch * self.sweep
        centre = self.center + half_rise * self.w
        return SEG_ARC, data, np.array([*centre, float(np.hypot(self.radius, half_rise))])


@dataclass(frozen=True, eq=False)
class Cubic:
    """Cubic piece p(q) = a + b q + c q² + d q³, q ∈ [0, 1] (q is not arc length)."""

    a: np.ndarray
    b: np.ndarray
    c: np.ndarray
    d: np.ndarray

    def __post_init__(self):
        for name in ("a", "b", "c", "d"):
            object.__setattr__(self, name, _vec3(name, getattr(self, name)))
        if self.length <= 0:
            raise ValueError("a, b, c, d: the cubic piece has zero length")

    def _dq(self, q):
        q = q[:, None]
        p1 = self.b + 2 * self.c * q + 3 * self.d * q**2
        p2 = 2 * self.c + 6 * self.d * q
        p3 = np.broadcast_to(6 * self.d, p1.shape)
        return p1, p2, p3

    def _speed(self, q):
        return np.linalg.norm(self._dq(q)[0], axis=1)

    def arc_length_to(self, q: np.ndarray) -> np.ndarray:
        """Arc length from q = 0 to q (Gauss–Legendre, 16 points)."""
        q = np.asarray(q, dtype=np.float64)
        nodes = 0.5 * q[:, None] * (_GL_X[None, :] + 1.0)
        sp = self._speed(nodes.reshape(-1)).reshape(nodes.shape)
        return 0.5 * q * (sp @ _GL_W)

    @property
    def length(self) -> float:
        return float(self.arc_length_to(np.array([1.0]))[0])

    @property
    def start_point(self) -> np.ndarray:
        return self.a.copy()

    @property
    def end_point(self) -> np.ndarray:
        return self.a + self.b + self.c + self.d

    def q_of_s(self, s: np.ndarray) -> np.ndarray:
        """Invert the arc length by safeguarded Newton (tolerance 1e-13 m)."""
        L = self.length
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, L)
        q = s / L
        lo, hi = np.zeros_like(q), np.ones_like(q)
        for _ in range(100):
            f = self.arc_length_to(q) - s
            if np.all(np.abs(f) < 1e-13):
                break
            lo = np.where(f < 0, q, lo)
            hi = np.where(f > 0, q, hi)
            q_new = q - f / np.maximum(self._speed(q), 1e-300)
            # Newton, falling back to bisection when it leaves the bracket
            outside = (q_new < lo) | (q_new > hi)
            q = np.where(np.abs(f) < 1e-13, q, np.where(outside, 0.5 * (lo + hi), q_new))
        return q

    def derivatives(self, s: np.ndarray):
        q = self.q_of_s(s)
        p1, p2, p3 = self._dq(q)
        qq = q[:, None]
        pos = self.a + self.b * qq + self.c * qq**2 + self.d * qq**3
        sig = np.linalg.norm(p1, axis=1)[:, None]
        dot12 = np.sum(p1 * p2, axis=1)[:, None]
        dot22 = np.sum(p2 * p2, axis=1)[:, None]
        dot13 = np.sum(p1 * p3, axis=1)[:, None]
        dsig = dot12 / sig  # dσ/dq
        d1 = p1 / sig
        d2 = p2 / sig**2 - p1 * dot12 / sig**4
        d3 = (
            p3 / sig**2
            - 2 * p2 * dsig / sig**3
            - p2 * dot12 / sig**4
            - p1 * (dot22 + dot13) / sig**4
            + 4 * p1 * dot12 * dsig / sig**5
        ) / sig
        return pos, d1, d2, d3

    def pack(self):
        data = np.zeros(16)
        data[:3], data[3:6], data[6:9], data[9:12] = self.a, self.b, self.c, self.d
        ctrl = np.array(
            [self.a, self.a + self.b / 3, self.a + 2 * self.b / 3 + self.c / 3, self.end_point]
        )
        centre = ctrl.mean(axis=0)
        radius = float(np.max(np.linalg.norm(ctrl - centre, axis=1)))
        return SEG_CUBIC, data, np.array([*centre, radius * (1 + 1e-12) + 1e-15])
