"""The five-axis test paths of Chen, Khong & Hsieh (2022, §4) as joint-space references, and
their algebraic path functions (equivalent errors, eqs. 6–7, 13 and the circle's equations).

Convention: joints ξ = q = (x, y, z, A, C) in (m, m, m, rad, rad) as in
:mod:`contour_env.plants.five_axis.kinematics`; tip p_w and unit tool vector o_w in the
workpiece frame (m); arrays carry a leading sample or batch axis; SI units throughout.

The reference is exact: the tip moves along the path with the cosine S-curve of
:class:`~contour_env.paths.feed.FeedProfile`, the tool points from X_c through the tip
(eq. 3) and ξ_d follows by the closed-form inverse kinematics (eq. 2, C unwrapped). Its
derivatives dᵏξ_d/dsᵏ (k ≤ 3) come from Taylor arithmetic through the inverse kinematics
(no finite differences), and the time derivatives from the chain rule with the feed's
ṡ, s̈ and s⃛ in closed form.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..plants.five_axis.kinematics import FiveAxisGeometry, inverse, tool_towards
from .builders import inclined_circle, line
from .feed import FeedProfile
from .geometry import PathGeometry

__all__ = [
    "FIVE_AXIS_PATHS",
    "FiveAxisPath",
    "FiveAxisReference",
    "feed_jerk",
    "five_axis_path",
]

FIVE_AXIS_PATHS = ("five-axis-line", "five-axis-circle")

# Paper §4: both paths run 2.35 s, sampled at the 1 ms servo period
PAPER_DURATION_S = 2.35
# The paper says only "S-type velocity profile" (refs. 16, 19, 20). Our choice: one cosine
# S-curve from rest to rest with ramps of a third of the motion time each (accelerate,
# cruise, decelerate for equal times); the jerk limit is set so the acceleration limit
# decides the ramp time.
DEFAULT_RAMP_FRACTION = 1.0 / 3.0

# paper §4: line X1 → X2 with the tool towards X_c; circle r = 0.1 m in the plane y = z
# (45° about x_w) about the origin with the tool towards X_c
_LINE = dict(start=(0.08, 0.03, 0.02), end=(0.01, 0.05, 0.07), xc=(0.0, -0.05, -0.5))
_CIRCLE = dict(radius=0.1, tilt_rad=math.pi / 4, xc=(0.0, 0.8, -0.8))


# ------------------------------------------------------------------------ Taylor arithmetic


class _Taylor:
    """Truncated Taylor series c[0] + c[1] h + … + c[K] h^K, c (K + 1, ...) (normalised
    coefficients cₖ = f⁽ᵏ⁾ / k!). Exact derivatives of compositions of +, −, ×, ÷, sqrt,
    sin, cos, arccos and atan2, up to order K."""

    __slots__ = ("c",)

    def __init__(self, c):
        self.c = np.asarray(c, dtype=np.float64)

    @property
    def order(self) -> int:
        return self.c.shape[0] - 1

    @property
    def value(self) -> np.ndarray:
        return self.c[0]

    def _lift(self, other) -> _Taylor:
        if isinstance(other, _Taylor):
            return other
        out = np.zeros((self.c.shape[0],) + np.broadcast_shapes(self.c.shape[1:], np.shape(other)))
        out[0] = other
        return _Taylor(out)

    def __add__(self, other):
        if isinstance(other, _Taylor):
            return _Taylor(self.c + other.c)
        other = np.asarray(other, dtype=np.float64)
        shape = (self.c.shape[0],) + np.broadcast_shapes(self.c.shape[1:], other.shape)
        c = np.broadcast_to(self.c, shape).copy()
        c[0] += other
        return _Taylor(c)

    __radd__ = __add__

    def __neg__(self):
        return _Taylor(-self.c)

    def __sub__(self, other):
        return self + (-other)

    def __rsub__(self, other):
        return (-self) + other

    def __mul__(self, other):
        if not isinstance(other, _Taylor):
            return _Taylor(self.c * np.asarray(other, dtype=np.float64))
        a, b = self.c, other.c
        k_max = min(a.shape[0], b.shape[0])
        out = [sum(a[j] * b[k - j] for j in range(k + 1)) for k in range(k_max)]
        return _Taylor(np.stack(out))

    __rmul__ = __mul__

    def __truediv__(self, other):
        if not isinstance(other, _Taylor):
            return _Taylor(self.c / np.asarray(other, dtype=np.float64))
        a, b = self.c, other.c
        k_max = min(a.shape[0], b.shape[0])
        out = []
        for k in range(k_max):
            acc = a[k] - sum(b[j] * out[k - j] for j in range(1, k + 1))
            out.append(acc / b[0])
        return _Taylor(np.stack(out))

    def __rtruediv__(self, other):
        return self._lift(other) / self

    def truncated(self, order: int) -> _Taylor:
        return _Taylor(self.c[: order + 1])

    def derivative(self) -> _Taylor:
        """d/dh as a series of one order less."""
        k = np.arange(1, self.c.shape[0], dtype=np.float64).reshape(
            (-1,) + (1,) * (self.c.ndim - 1)
        )
        return _Taylor(self.c[1:] * k)

    @staticmethod
    def integral(value, rate: _Taylor) -> _Taylor:
        """The series with constant term ``value`` whose derivative is ``rate``."""
        k = np.arange(1, rate.c.shape[0] + 1, dtype=np.float64)
        k = k.reshape((-1,) + (1,) * (rate.c.ndim - 1))
        first = np.broadcast_to(np.asarray(value, dtype=np.float64), rate.c.shape[1:])[None]
        return _Taylor(np.concatenate([first, rate.c / k]))


def _sqrt(a: _Taylor) -> _Taylor:
    c = a.c
    out = [np.sqrt(c[0])]
    for k in range(1, c.shape[0]):
        acc = c[k] - sum(out[j] * out[k - j] for j in range(1, k))
        out.append(acc / (2.0 * out[0]))
    return _Taylor(np.stack(out))


def _sin_cos(a: _Taylor) -> tuple[_Taylor, _Taylor]:
    c = a.c
    s, co = [np.sin(c[0])], [np.cos(c[0])]
    for k in range(1, c.shape[0]):
        s.append(sum(j * c[j] * co[k - j] for j in range(1, k + 1)) / k)
        co.append(-sum(j * c[j] * s[k - j] for j in range(1, k + 1)) / k)
    return _Taylor(np.stack(s)), _Taylor(np.stack(co))


def _arccos(u: _Taylor) -> _Taylor:
    if u.order == 0:
        return _Taylor(np.arccos(u.c))
    low = u.truncated(u.order - 1)
    return _Taylor.integral(np.arccos(u.value), -u.derivative() / _sqrt(1.0 - low * low))


def _atan2(y: _Taylor, x: _Taylor) -> _Taylor:
    if y.order == 0:
        return _Taylor(np.arctan2(y.c, x.c))
    k = y.order - 1
    yl, xl = y.truncated(k), x.truncated(k)
    rate = (xl * y.derivative() - yl * x.derivative()) / (xl * xl + yl * yl)
    return _Taylor.integral(np.arctan2(y.value, x.value), rate)


def _series(coefficients) -> _Taylor:
    return _Taylor(np.stack([np.asarray(c, dtype=np.float64) for c in coefficients]))


def _forward_series(q, geom: FiveAxisGeometry):
    """Eq. 1 on series: tip (3 series), tool (3 series) of joints q (5 series); the same
    rigid-body form as :func:`~contour_env.plants.five_axis.kinematics.forward`."""
    x, y, z, a, c = q
    sa, ca = _sin_cos(a)
    sc, cc = _sin_cos(c)
    zt = z + geom.tip_offset_m
    wy = ca * y + sa * zt
    wz = -(sa * y) + ca * zt
    tip = (cc * x + sc * wy, -(sc * x) + cc * wy, wz - geom.d4_m)
    return tip, (sa * sc, sa * cc, ca)


def _inverse_series(tip, tool, geom: FiveAxisGeometry, a_branch: int):
    """Eq. 2 on series (as kinematics.inverse; C's constant term wrapped to (−π, π])."""
    px, py, pz = tip[0], tip[1], tip[2] + geom.d4_m
    a = a_branch * _arccos(tool[2])
    c = _atan2(a_branch * tool[0], a_branch * tool[1])
    sa, ca = _sin_cos(a)
    sc, cc = _sin_cos(c)
    uy = sc * px + cc * py
    return (cc * px - sc * py, ca * uy - sa * pz, sa * uy + ca * pz - geom.tip_offset_m, a, c)


# ------------------------------------------------------------------------------ feed jerk


def feed_jerk(profile: FeedProfile, t) -> np.ndarray:
    """s⃛(t) (m/s³) of an exact-stop cosine S-curve (the derivative of FeedProfile.sample's
    s̈ in closed form): ½ F ω² cos(ω τ) on each ramp (τ from the ramp's rest end, ω = π/Ta),
    0 while cruising and at rest. Not defined for the look-ahead profile."""
    if not all(hasattr(sec, "ramp_time") for sec in profile.sections):
        raise ValueError("feed_jerk: only the exact-stop profile (Section rows) is supported")
    t = np.atleast_1d(np.asarray(t, dtype=np.float64))
    out = np.zeros_like(t)
    for sec in profile.sections:
        ta, tc = sec.ramp_time, sec.cruise_time
        w = math.pi / ta
        tau = t - sec.t_start
        up = (tau >= 0.0) & (tau < ta)
        rem = sec.t_end - t  # time left to the stop
        down = (tau >= ta + tc) & (rem > 0.0)
        out[up] = 0.5 * sec.peak_feed * w * w * np.cos(w * tau[up])
        out[down] = 0.5 * sec.peak_feed * w * w * np.cos(w * rem[down])
    return out


# ------------------------------------------------------------------------------ reference


@dataclass(frozen=True, eq=False)
class FiveAxisReference:
    """Joint-space reference at t_k = k T, k = 0 … n − 1 (float64, SI).

    time_s (n,); arc_length_m s, feedrate_m_s ṡ, feed_accel_m_s2 s̈, feed_jerk_m_s3 s⃛ (n,)
    of the tool tip along the path; tip_m p_w (n, 3) and tool o_w (n, 3) in the workpiece
    frame; joints ξ_d (n, 5) with C unwrapped, joint_rate ξ̇_d, joint_accel ξ̈_d, joint_jerk
    ξ⃛_d (n, 5); joints_ds, joints_ds2, joints_ds3 (n, 5): dξ_d/ds, d²ξ_d/ds², d³ξ_d/ds³
    (per metre of tip path; the time derivatives are their chain rule with ṡ, s̈, s⃛).
    After the feed profile ends the reference holds the end pose at rest.
    """

    time_s: np.ndarray
    arc_length_m: np.ndarray
    feedrate_m_s: np.ndarray
    feed_accel_m_s2: np.ndarray
    feed_jerk_m_s3: np.ndarray
    tip_m: np.ndarray
    tool: np.ndarray
    joints: np.ndarray
    joint_rate: np.ndarray
    joint_accel: np.ndarray
    joint_jerk: np.ndarray
    joints_ds: np.ndarray
    joints_ds2: np.ndarray
    joints_ds3: np.ndarray
    servo_period_s: float

    @property
    def n_steps(self) -> int:
        return int(self.time_s.shape[0])


def _tip_series(kind: str, spec: dict, s: np.ndarray, geometry: PathGeometry):
    """Tip position as a 3rd-order series in the arc length about each s (3 series (4, n))."""
    n = s.shape[0]
    if kind == "line":
        p0 = np.asarray(spec["start"])
        d = np.asarray(spec["end"]) - p0
        u = d / np.linalg.norm(d)
        pos = p0[None, :] + s[:, None] * u[None, :]
        rate = np.broadcast_to(u, (n, 3))
        coef = [pos, rate, np.zeros((n, 3)), np.zeros((n, 3))]
    else:
        r = spec["radius"]
        seg = geometry.segments[0]
        cu, cv = np.asarray(seg.u), np.asarray(seg.v)
        th = s / r
        cs, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        radial = cs * cu + sn * cv
        tangent = -sn * cu + cs * cv
        # p, p', p''/2, p'''/6 of p(s) = r (cos(s/r) u + sin(s/r) v)
        coef = [r * radial, tangent, -radial / (2.0 * r), -tangent / (6.0 * r * r)]
    return tuple(_series([c[:, i] for c in coef]) for i in range(3))


def _build_reference(kind, spec, geom, tip_path, profile, servo_period_s, settle_time_s):
    n = int(round((profile.duration + settle_time_s) / servo_period_s)) + 1
    t = np.arange(n) * servo_period_s
    s, sd, sdd = profile.sample(t)
    sddd = feed_jerk(profile, t)
    tip = _tip_series(kind, spec, s, tip_path)
    xc = np.asarray(spec["xc"], dtype=np.float64)
    diff = tuple(tip[i] - xc[i] for i in range(3))
    norm = _sqrt(diff[0] * diff[0] + diff[1] * diff[1] + diff[2] * diff[2])
    tool = tuple(d / norm for d in diff)
    q = _inverse_series(tip, tool, geom, a_branch=-1)
    tip_m = np.stack([p.value for p in tip], axis=-1)
    tool_v = np.stack([o.value for o in tool], axis=-1)
    c_unwrapped = np.unwrap(q[4].value)
    joints = inverse(tip_m, tool_v, geom, c_ref=c_unwrapped, a_branch=-1, check=True)
    dq = np.stack([qi.c[1] for qi in q], axis=-1)
    d2q = 2.0 * np.stack([qi.c[2] for qi in q], axis=-1)
    d3q = 6.0 * np.stack([qi.c[3] for qi in q], axis=-1)
    v, a, j = sd[:, None], sdd[:, None], sddd[:, None]
    return FiveAxisReference(
        time_s=t,
        arc_length_m=s,
        feedrate_m_s=sd,
        feed_accel_m_s2=sdd,
        feed_jerk_m_s3=sddd,
        tip_m=tip_m,
        tool=tool_v,
        joints=joints,
        joint_rate=dq * v,
        joint_accel=d2q * v * v + dq * a,
        joint_jerk=d3q * v**3 + 3.0 * d2q * v * a + dq * j,
        joints_ds=dq,
        joints_ds2=d2q,
        joints_ds3=d3q,
        servo_period_s=float(servo_period_s),
    )


# ---------------------------------------------------------------------- the path functions


@dataclass(frozen=True, eq=False)
class FiveAxisPath:
    """A five-axis test path: tip path, tool towards X_c, joint reference and the algebraic
    path functions of the equivalent errors (Chen 2022, eqs. 6–7).

    Path functions in machine coordinates, ε = p(ξ) = p̂(T(ξ), ξ) (eq. 6), with (x_w, y_w,
    z_w) = T(ξ) the forward kinematics (eq. 1) and L = ‖p_w − X_c‖²:

    * line (eq. 13): ε₁ = n₁·p_w − n₁·X₁, ε₂ = n₂·p_w − n₂·X₁ with the planes through the
      line parallel to z_w and x_w, n₁ = (−d_y/d_x, 1, 0), n₂ = (0, 1, −d_y/d_z) (for the
      paper's X₁, X₂: ε₁ = 2/7 x_w + y_w − 37/700, ε₂ = y_w − 2/5 z_w − 11/500);
    * circle (§4): ε₁ = x_w² + 2 y_w² − r² (elliptical cylinder), ε₂ = y_w − z_w (the 45°
      plane);
    * tool towards X_c (eqs. 14–16, both paths): ε₃ = (x_w − x_c) cos C − (y_w − y_c) sin C,
      ε₄ = (z_w − z_c)² − L cos² A, both zero on the path. ε₃ is the paper's printed
      (x_w − x_c) cos θ_C + (y_w − y_c) sin θ_C with θ_C = −C: our kinematics are the mirror
      image of eq. 1 (θ_A = −A, θ_C = −C; o_w = (sin A sin C, sin A cos C, cos A), see
      :mod:`contour_env.plants.five_axis.kinematics`). ε₄ is not the printed one: the paper
      prints (x_w − x_c)² − L cos² θ_A (from "O_wx = (x_w − x_c)/L = cos θ_A"), which cannot
      be right: cos A is o_z = (z_w − z_c)/√L, not o_x, so on the path the printed form equals
      (x_w − x_c)² − (z_w − z_c)², not 0 (−0.32…−0.26 m² on the line, −0.76…−0.53 m² on the
      circle), and the law would drive the tool off the path. We use the z form, which the
      paper's own derivation (tool vector towards X_c, O_wz = cos θ_A) gives.

    Tangential error (eq. 7): e = wᵀ (ξ − ξ_d) with w = ξ̇_d in the paper. ``tangent_floor_m_s``
    v₀ ≥ 0 of the methods below uses w = dξ_d/ds (ṡ + v₀) instead: v₀ = 0 is the paper's
    (singular where ξ̇_d = 0, at the start and end of the S-curve), v₀ > 0 keeps e defined
    and Γ of eq. 7 invertible at rest.

    Attributes: name, kind ("line" / "circle"), xc_m (3,), geometry (FiveAxisGeometry),
    tip_path (PathGeometry of the tip in the workpiece frame), reference (FiveAxisReference),
    profile (FeedProfile), and ``spec`` (the paper's numbers).
    """

    name: str
    kind: str
    xc_m: np.ndarray
    geometry: FiveAxisGeometry
    tip_path: PathGeometry
    profile: FeedProfile
    reference: FiveAxisReference
    spec: dict

    # -- task space

    def tool_at(self, tip) -> np.ndarray:
        """Reference tool vector at tip points (..., 3): towards X_c (eq. 3)."""
        return tool_towards(tip, self.xc_m)

    # -- equivalent contour errors

    def _contour_series(self, q):
        tip, _ = _forward_series(q, self.geometry)
        x, y, z = tip
        if self.kind == "line":
            x1 = np.asarray(self.spec["start"])
            d = np.asarray(self.spec["end"]) - x1
            k1, k2 = -d[1] / d[0], -d[1] / d[2]
            e1 = k1 * x + y - (k1 * x1[0] + x1[1])
            e2 = y + k2 * z - (x1[1] + k2 * x1[2])
        else:
            r = self.spec["radius"]
            e1 = x * x + 2.0 * (y * y) - r * r
            e2 = y - z
        xc = self.xc_m
        dx, dy, dz = x - xc[0], y - xc[1], z - xc[2]
        sa, ca = _sin_cos(q[3])
        sc, cc = _sin_cos(q[4])
        e3 = dx * cc - dy * sc
        dist2 = dx * dx + dy * dy + dz * dz
        e4 = dz * dz - dist2 * (ca * ca)
        return e1, e2, e3, e4

    def _evaluate(self, q, directions, order):
        q = np.asarray(q, dtype=np.float64)
        directions = np.asarray(directions, dtype=np.float64)
        q, directions = np.broadcast_arrays(q, directions)
        zeros = [np.zeros_like(q[..., 0])] * (order - 1)
        series = [_series([q[..., i], directions[..., i], *zeros]) for i in range(5)]
        return self._contour_series(series)

    def contour_errors(self, q) -> np.ndarray:
        """ε = p(ξ) (..., 4) at joints q (..., 5) (eq. 6): m, m, m, m² (line); m², m, m, m²
        (circle)."""
        out = self._evaluate(q, np.zeros(5), 1)
        return np.stack([e.value for e in out], axis=-1)

    def contour_jacobian(self, q) -> np.ndarray:
        """∂p/∂ξ (..., 4, 5) at q (..., 5) (exact, by Taylor arithmetic)."""
        q = np.asarray(q, dtype=np.float64)
        out = self._evaluate(q[..., None, :], np.eye(5), 1)
        return np.stack([e.c[1] for e in out], axis=-2)

    def contour_hessian_term(self, q, qd) -> np.ndarray:
        """h (..., 4), hₖ = Σᵢⱼ ∂²pₖ/∂ξᵢ∂ξⱼ ξ̇ᵢ ξ̇ⱼ (eq. 7), so ε̈ = (∂p/∂ξ) ξ̈ + h."""
        out = self._evaluate(q, qd, 2)
        return np.stack([2.0 * e.c[2] for e in out], axis=-1)

    # -- tangential error

    def tangent_weights(self, k: int, tangent_floor_m_s: float = 0.0):
        """(w, ẇ, ẅ) (5,) each at sample k: w = dξ_d/ds (ṡ + v₀) (= ξ̇_d for v₀ = 0)."""
        ref = self.reference
        k = min(max(int(k), 0), ref.n_steps - 1)
        d1, d2, d3 = ref.joints_ds[k], ref.joints_ds2[k], ref.joints_ds3[k]
        v, a, j = ref.feedrate_m_s[k], ref.feed_accel_m_s2[k], ref.feed_jerk_m_s3[k]
        g = v + tangent_floor_m_s
        w = d1 * g
        wd = d2 * v * g + d1 * a
        wdd = d3 * v * v * g + d2 * (a * g + 2.0 * v * a) + d1 * j
        return w, wd, wdd

    def tangential_error(self, q, qd, k: int, tangent_floor_m_s: float = 0.0):
        """(e, ė) at sample k (eq. 7): e = wᵀ (ξ − ξ_d), ė = ẇᵀ (ξ − ξ_d) + wᵀ (ξ̇ − ξ̇_d)."""
        ref = self.reference
        k = min(max(int(k), 0), ref.n_steps - 1)
        w, wd, _ = self.tangent_weights(k, tangent_floor_m_s)
        dq = np.asarray(q, dtype=np.float64) - ref.joints[k]
        dqd = np.asarray(qd, dtype=np.float64) - ref.joint_rate[k]
        return float(w @ dq), float(wd @ dq + w @ dqd)

    def equivalent_errors(self, q, qd, k: int, tangent_floor_m_s: float = 0.0):
        """η = (ε₁…ε₄, e) and η̇ (5,) each at joints q, rates qd (5,) and sample k (eq. 6)."""
        q = np.asarray(q, dtype=np.float64)
        qd = np.asarray(qd, dtype=np.float64)
        out = self._evaluate(q, qd, 1)
        e, ed = self.tangential_error(q, qd, k, tangent_floor_m_s)
        eta = np.array([s.value for s in out] + [e])
        eta_dot = np.array([s.c[1] for s in out] + [ed])
        return eta, eta_dot

    def error_dynamics(self, q, qd, k: int, drift, gain, tangent_floor_m_s: float = 0.0):
        """(Ω (5,), Γ (5, 5)) of η̈ = Ω + Γ u (eq. 7) for the model ξ̈ = f + G u (eq. 5):

            Ω = [h + J f ;  wᵀ f + 2 ẇᵀ (ξ̇ − ξ̇_d) + ẅᵀ (ξ − ξ_d) − wᵀ ξ̈_d],   Γ = [J ; wᵀ] G

        (with w = ξ̇_d the paper's Ω_e = ξ̇_dᵀ f + ξ̈_dᵀ (2 ξ̇ − 3 ξ̇_d) + ξ⃛_dᵀ (ξ − ξ_d)).
        """
        ref = self.reference
        k = min(max(int(k), 0), ref.n_steps - 1)
        q = np.asarray(q, dtype=np.float64)
        qd = np.asarray(qd, dtype=np.float64)
        jac = self.contour_jacobian(q)
        h = self.contour_hessian_term(q, qd)
        w, wd, wdd = self.tangent_weights(k, tangent_floor_m_s)
        omega_e = (
            w @ drift
            + 2.0 * wd @ (qd - ref.joint_rate[k])
            + wdd @ (q - ref.joints[k])
            - w @ ref.joint_accel[k]
        )
        omega = np.concatenate([h + jac @ drift, [omega_e]])
        gamma = np.vstack([jac, w[None, :]]) @ gain
        return omega, gamma


def _ramp_limits(length_m: float, duration_s: float, ramp_fraction: float):
    # peak feed F and the limits that make FeedProfile's ramp time Ta = fraction × duration:
    # L = F (T − Ta), Ta = π F / (2 a); the jerk limit is twice what that ramp needs
    ta = ramp_fraction * duration_s
    feed = length_m / (duration_s - ta)
    accel = math.pi * feed / (2.0 * ta)
    jerk = 2.0 * math.pi**2 * feed / (2.0 * ta * ta)
    return feed, accel, jerk


def five_axis_path(
    name: str,
    *,
    geometry: FiveAxisGeometry | None = None,
    servo_period_s: float = 1e-3,
    duration_s: float = PAPER_DURATION_S,
    ramp_fraction: float = DEFAULT_RAMP_FRACTION,
    settle_time_s: float = 0.0,
) -> FiveAxisPath:
    """One of the paper's test paths (``FIVE_AXIS_PATHS``) as a FiveAxisPath.

    name : "five-axis-line" (X₁ = [0.08, 0.03, 0.02] → X₂ = [0.01, 0.05, 0.07] m, tool
        towards X_c = [0, −0.05, −0.5] m) or "five-axis-circle" (r = 0.1 m about the origin
        in the plane y_w = z_w, from (r, 0, 0) counter-clockwise about (0, −1, 1)/√2, tool
        towards X_c = [0, 0.8, −0.8] m).
    geometry : machine offsets and travel (default FiveAxisGeometry()); the reference is
        checked against the travel.
    servo_period_s : sample period T > 0 s (paper: 1 ms).
    duration_s : motion time > 0 s (paper: 2.35 s).
    ramp_fraction : each S-curve ramp's share of the motion time, in (0, 0.5) (our choice,
        default 1/3: the paper does not give it).
    settle_time_s : ≥ 0 s of rest at the end pose appended to the reference.
    """
    if name not in FIVE_AXIS_PATHS:
        raise ValueError(f"name: unknown five-axis path {name!r}; known: {FIVE_AXIS_PATHS}")
    geom = FiveAxisGeometry() if geometry is None else geometry
    if not isinstance(geom, FiveAxisGeometry):
        raise ValueError(f"geometry: expected FiveAxisGeometry, got {geometry!r}")
    for label, value in (("servo_period_s", servo_period_s), ("duration_s", duration_s)):
        if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
            raise ValueError(f"{label}: must be a finite number > 0 s, got {value!r}")
    if not 0.0 < ramp_fraction < 0.5:
        raise ValueError(f"ramp_fraction: must lie in (0, 0.5), got {ramp_fraction!r}")
    if not (math.isfinite(settle_time_s) and settle_time_s >= 0):
        raise ValueError(f"settle_time_s: must be a finite number >= 0 s, got {settle_time_s!r}")
    if name == "five-axis-line":
        kind, spec = "line", dict(_LINE)
        tip_path = line(spec["start"], spec["end"])
    else:
        kind, spec = "circle", dict(_CIRCLE)
        tip_path = inclined_circle((0.0, 0.0, 0.0), spec["radius"], spec["tilt_rad"])
    feed, accel, jerk = _ramp_limits(tip_path.total_length, duration_s, ramp_fraction)
    profile = FeedProfile.build(tip_path, feed, max_accel_m_s2=accel, max_jerk_m_s3=jerk)
    reference = _build_reference(kind, spec, geom, tip_path, profile, servo_period_s, settle_time_s)
    return FiveAxisPath(
        name=name,
        kind=kind,
        xc_m=np.asarray(spec["xc"], dtype=np.float64),
        geometry=geom,
        tip_path=tip_path,
        profile=profile,
        reference=reference,
        spec=spec,
    )
