"""Joint-space rigid-body dynamics of the A–C table machine (Chen, Khong & Hsieh 2022):

    M(ξ) ξ̈ + C(ξ, ξ̇) ξ̇ + g(ξ) = τ                      (eq. 4)
    ξ̈ = f + G u,   f = −M⁻¹ (C ξ̇ + g),   G = M⁻¹         (eq. 5)

ξ = (x, y, z, A, C), τ in (N, N, N, N·m, N·m). The paper gives no masses or offsets; the
bodies (y saddle, x table, A cradle, C table with fixture and workpiece, spindle head) and
their values are in :class:`~contour_env.plants.five_axis.params.FiveAxisInertia` and
docs/FIVE_AXIS.md. M and g are closed-form results of Lagrange's equations for those bodies
(derived and checked with sympy by ``scripts/derive_five_axis_dynamics.py``); C is built
from the Christoffel symbols of M, so Ṁ − 2C is skew-symmetric.

Everything here takes the packed inertial vector ``ip`` (indices I_*), so the compiled
step can call it; the Python wrappers at the end accept a FiveAxisInertia as well.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

# indices into the packed inertial-parameter vector (FiveAxisInertia.packed())
(
    I_M1,  # y saddle (+ x motor and screw), kg
    I_M2,  # x table (+ A drive and trunnion supports), kg
    I_M3,  # A cradle (+ C drive), kg
    I_R3,  # cradle centre of mass along the cradle z axis from the A axis, m
    I_J3,  # cradle inertia about the A direction through its centre of mass, kg m²
    I_M4,  # C table + fixture + workpiece, kg
    I_H4,  # its centre of mass along the C axis from the A axis, m
    I_E4,  # its centre-of-mass eccentricity from the C axis (C-frame x), m
    I_J4R,  # its radial inertia about its centre of mass, kg m²
    I_J4Z,  # its axial inertia about its centre of mass, kg m²
    I_M5,  # spindle head (z slide), kg
    I_G,  # gravitational acceleration, m/s² (along −z of the machine)
) = range(12)
IP_SIZE = 12
N_JOINTS = 5


@njit(cache=True, inline="always")
def _pose_terms(q, ip):
    # what M and its partials read: sin A, cos A, sin C, cos C and the cradle's and table's
    # masses and offsets m3, m4, r3, h4, e4
    sa, ca = math.sin(q[3]), math.cos(q[3])
    sc, cc = math.sin(q[4]), math.cos(q[4])
    return sa, ca, sc, cc, ip[I_M3], ip[I_M4], ip[I_R3], ip[I_H4], ip[I_E4]


@njit(cache=True, inline="always")
def _zero_5x5(m):
    for i in range(5):
        for j in range(5):
            m[i, j] = 0.0


@njit(cache=True)
def mass_matrix_into(q, ip, m):
    """M(ξ) of eq. 4 into m (5, 5); depends on A and C only."""
    sa, ca, sc, cc, m3, m4, r3, h4, e4 = _pose_terms(q, ip)
    _zero_5x5(m)
    m[0, 0] = ip[I_M2] + m3 + m4
    m[1, 1] = ip[I_M1] + ip[I_M2] + m3 + m4
    m[2, 2] = ip[I_M5]
    m[3, 3] = ip[I_J3] + ip[I_J4R] + m3 * r3 * r3 + m4 * (h4 * h4 + e4 * e4 * sc * sc)
    m[4, 4] = ip[I_J4Z] + m4 * e4 * e4
    m[0, 4] = m[4, 0] = m4 * e4 * sc
    m[1, 3] = m[3, 1] = m3 * r3 * ca + m4 * (h4 * ca + e4 * sa * sc)
    m[1, 4] = m[4, 1] = -m4 * e4 * ca * cc
    m[3, 4] = m[4, 3] = -m4 * e4 * h4 * cc


@njit(cache=True)
def mass_matrix_partials_into(q, ip, dma, dmc):
    """∂M/∂A into dma and ∂M/∂C into dmc (5, 5); ∂M/∂x = ∂M/∂y = ∂M/∂z = 0."""
    sa, ca, sc, cc, m3, m4, r3, h4, e4 = _pose_terms(q, ip)
    _zero_5x5(dma)
    _zero_5x5(dmc)
    dma[1, 3] = dma[3, 1] = -m3 * r3 * sa + m4 * (-h4 * sa + e4 * ca * sc)
    dma[1, 4] = dma[4, 1] = m4 * e4 * sa * cc
    dmc[0, 4] = dmc[4, 0] = m4 * e4 * cc
    dmc[1, 3] = dmc[3, 1] = m4 * e4 * sa * cc
    dmc[1, 4] = dmc[4, 1] = m4 * e4 * ca * sc
    dmc[3, 3] = 2.0 * m4 * e4 * e4 * sc * cc
    dmc[3, 4] = dmc[4, 3] = m4 * e4 * h4 * sc


@njit(cache=True)
def coriolis_matrix_into(q, qd, ip, c, dma, dmc):
    """C(ξ, ξ̇) of eq. 4 into c (5, 5) from the Christoffel symbols of M:

        C_kj = Σ_i ½ (∂M_kj/∂ξ_i + ∂M_ki/∂ξ_j − ∂M_ij/∂ξ_k) ξ̇_i

    (only i, j, k ∈ {A, C} carry derivatives). dma, dmc (5, 5) are work space.
    """
    mass_matrix_partials_into(q, ip, dma, dmc)
    wa, wc = qd[3], qd[4]
    for k in range(5):
        for j in range(5):
            # Σ_i ∂M_kj/∂ξ_i ξ̇_i
            acc = dma[k, j] * wa + dmc[k, j] * wc
            # Σ_i ∂M_ki/∂ξ_j ξ̇_i (nonzero for j = A, C)
            if j == 3:
                for i in range(5):
                    acc += dma[k, i] * qd[i]
            elif j == 4:
                for i in range(5):
                    acc += dmc[k, i] * qd[i]
            # − Σ_i ∂M_ij/∂ξ_k ξ̇_i (nonzero for k = A, C)
            if k == 3:
                for i in range(5):
                    acc -= dma[i, j] * qd[i]
            elif k == 4:
                for i in range(5):
                    acc -= dmc[i, j] * qd[i]
            c[k, j] = 0.5 * acc


@njit(cache=True)
def gravity_into(q, ip, g):
    """g(ξ) = ∂V/∂ξ of eq. 4 into g (5,): the spindle head's weight on z, the cradle's and
    the table's unbalance on A, the table's eccentricity on C."""
    sa, ca = math.sin(q[3]), math.cos(q[3])
    sc, cc = math.sin(q[4]), math.cos(q[4])
    grav, m4, e4 = ip[I_G], ip[I_M4], ip[I_E4]
    g[0] = 0.0
    g[1] = 0.0
    g[2] = grav * ip[I_M5]
    g[3] = -grav * (ip[I_M3] * ip[I_R3] * sa + m4 * (ip[I_H4] * sa - e4 * ca * sc))
    g[4] = grav * m4 * e4 * sa * cc


@njit(cache=True)
def bias_into(q, qd, ip, h, dma, dmc):
    """h = C(ξ, ξ̇) ξ̇ + g(ξ) into h (5,), without forming C:
    (C ξ̇)_k = Σ_ij (∂M_kj/∂ξ_i − ½ ∂M_ij/∂ξ_k) ξ̇_i ξ̇_j."""
    mass_matrix_partials_into(q, ip, dma, dmc)
    gravity_into(q, ip, h)
    wa, wc = qd[3], qd[4]
    qa = 0.0  # ξ̇ᵀ ∂M/∂A ξ̇
    qc = 0.0  # ξ̇ᵀ ∂M/∂C ξ̇
    for i in range(5):
        ra = 0.0
        rc = 0.0
        for j in range(5):
            ra += dma[i, j] * qd[j]
            rc += dmc[i, j] * qd[j]
        # Σ_i ∂M_kj/∂ξ_i ξ̇_i ξ̇_j = (∂M/∂A ξ̇)_k ξ̇_A + (∂M/∂C ξ̇)_k ξ̇_C
        h[i] += ra * wa + rc * wc
        qa += qd[i] * ra
        qc += qd[i] * rc
    h[3] -= 0.5 * qa
    h[4] -= 0.5 * qc


@njit(cache=True)
def potential_energy(q, ip):
    """V(ξ), J, zero at the home pose's heights (A = 0, z = 0)."""
    sa, ca = math.sin(q[3]), math.cos(q[3])
    sc = math.sin(q[4])
    m3, m4 = ip[I_M3], ip[I_M4]
    # heights of the cradle's and the table's centres of mass above the A axis
    z3 = ip[I_R3] * ca
    z4 = ip[I_H4] * ca + ip[I_E4] * sa * sc
    return ip[I_G] * (ip[I_M5] * q[2] + m3 * (z3 - ip[I_R3]) + m4 * (z4 - ip[I_H4]))


@njit(cache=True)
def cholesky_solve_into(m, b, x, work):
    """x = m⁻¹ b for symmetric positive definite m (5, 5); work (5, 5) receives the factor."""
    n = 5
    for i in range(n):
        for j in range(i + 1):
            s = m[i, j]
            for k in range(j):
                s -= work[i, k] * work[j, k]
            if i == j:
                work[i, i] = math.sqrt(s)
            else:
                work[i, j] = s / work[j, j]
    for i in range(n):
        s = b[i]
        for k in range(i):
            s -= work[i, k] * x[k]
        x[i] = s / work[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s -= work[k, i] * x[k]
        x[i] = s / work[i, i]


# ---------------------------------------------------------------- Python-level wrappers


def _packed(inertia) -> np.ndarray:
    ip = inertia.packed() if hasattr(inertia, "packed") else np.asarray(inertia, dtype=np.float64)
    if ip.shape != (IP_SIZE,):
        raise ValueError(f"inertia: expected FiveAxisInertia or a ({IP_SIZE},) vector")
    return ip


def _joints(value, name: str) -> np.ndarray:
    arr = np.asarray(value, dtype=np.float64)
    if arr.ndim == 0 or arr.shape[-1] != N_JOINTS:
        raise ValueError(f"{name}: expected shape (..., 5), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: must be finite (got NaN or inf)")
    return arr


def mass_matrix(q, inertia) -> np.ndarray:
    """M(ξ) (..., 5, 5) for joints q (..., 5) (eq. 4)."""
    q = _joints(q, "q")
    ip = _packed(inertia)
    flat = q.reshape(-1, 5)
    out = np.empty((flat.shape[0], 5, 5))
    for b in range(flat.shape[0]):
        mass_matrix_into(flat[b], ip, out[b])
    return out.reshape(q.shape + (5,))


def coriolis_matrix(q, qd, inertia) -> np.ndarray:
    """C(ξ, ξ̇) (..., 5, 5) (eq. 4; Christoffel symbols of M)."""
    q = _joints(q, "q")
    qd = _joints(qd, "qd")
    q, qd = np.broadcast_arrays(q, qd)
    ip = _packed(inertia)
    fq, fqd = q.reshape(-1, 5), qd.reshape(-1, 5)
    out = np.empty((fq.shape[0], 5, 5))
    dma, dmc = np.empty((5, 5)), np.empty((5, 5))
    for b in range(fq.shape[0]):
        coriolis_matrix_into(fq[b], fqd[b], ip, out[b], dma, dmc)
    return out.reshape(q.shape + (5,))


def gravity(q, inertia) -> np.ndarray:
    """g(ξ) (..., 5) in N / N·m (eq. 4)."""
    q = _joints(q, "q")
    ip = _packed(inertia)
    flat = q.reshape(-1, 5)
    out = np.empty_like(flat)
    for b in range(flat.shape[0]):
        gravity_into(flat[b], ip, out[b])
    return out.reshape(q.shape)


def energy(q, qd, inertia) -> np.ndarray:
    """Kinetic + potential energy ½ ξ̇ᵀ M ξ̇ + V(ξ) (...), J."""
    q = _joints(q, "q")
    qd = _joints(qd, "qd")
    ip = _packed(inertia)
    m = mass_matrix(q, ip)
    kin = 0.5 * np.einsum("...i,...ij,...j->...", qd, m, qd)
    flat = q.reshape(-1, 5)
    pot = np.array([potential_energy(flat[b], ip) for b in range(flat.shape[0])])
    return kin + pot.reshape(q.shape[:-1])


def drift_and_gain(q, qd, inertia) -> tuple[np.ndarray, np.ndarray]:
    """f = −M⁻¹ (C ξ̇ + g) (..., 5) and G = M⁻¹ (..., 5, 5) of eq. 5 (ξ̈ = f + G u)."""
    q = _joints(q, "q")
    qd = _joints(qd, "qd")
    m = mass_matrix(q, inertia)
    h = np.einsum("...ij,...j->...i", coriolis_matrix(q, qd, inertia), qd) + gravity(q, inertia)
    gain = np.linalg.inv(m)
    return -np.einsum("...ij,...j->...i", gain, h), gain
