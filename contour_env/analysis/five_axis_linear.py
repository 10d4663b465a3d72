"""The five-axis plant's joint dynamics linearised at a pose, as a discrete-time MIMO system,
for loop analysis (``agents.five_axis_margins``).

At a pose ξ₀ (at rest) the true plant of :mod:`contour_env.plants.five_axis` is, to first order,

    M(ξ₀) δξ̈ + B δξ̇ + K_g(ξ₀) δξ = τ_a,        T_c τ̇_a = u − τ_a

with M the true (realistic) inertia matrix at the pose, optionally scaled per joint for the
inertia corners (M → D M D, D = diag(√f): the diagonal M_jj × f_j, the couplings by
√(f_i f_j), still positive definite), B = diag(viscous friction), K_g = ∂g/∂ξ the gravity
stiffness (the cradle's and the table's pendulum terms on A and C), T_c the per-joint
current-loop lag. It is sampled with a zero-order hold at the servo period (python-control's
``c2d``), with the one-period computation delay as z⁻¹ on every input when the plant has it.
Input: the five joint commands (N, N, N, N·m, N·m); output: the measured joints (m, rad).

Left out, as in :mod:`contour_env.analysis.linear_plant` for the feed drives, because they are
not linear: Coulomb/static friction (the smoothed sgn of the plant), saturation and encoder
quantisation; and, because they vanish at rest and stay small along the paths, the Coriolis
and centrifugal terms (they scale with m₄ e₄ = 0.5 kg m times the rates, against the loop's
M ω² of thousands).
"""

from __future__ import annotations

import control
import numpy as np

from contour_env.plants.five_axis import FiveAxisParams, gravity, mass_matrix

N_JOINTS = 5
_FD_STEP = 1e-6  # rad / m: central-difference step of the gravity stiffness


def gravity_stiffness(q, inertia) -> np.ndarray:
    """K_g = ∂g/∂ξ (5, 5) at joints q (5,) (N/m, N·m/rad), by central differences of
    :func:`contour_env.plants.five_axis.gravity` (g is smooth; the error is ~1e-10 relative)."""
    q = np.asarray(q, dtype=np.float64)
    K = np.empty((N_JOINTS, N_JOINTS))
    for j in range(N_JOINTS):
        d = np.zeros(N_JOINTS)
        d[j] = _FD_STEP
        K[:, j] = (gravity(q + d, inertia) - gravity(q - d, inertia)) / (2 * _FD_STEP)
    return K


def scaled_mass_matrix(q, inertia, mass_scale=None) -> np.ndarray:
    """M(q) (5, 5) with joint j's inertia scaled by ``mass_scale[j]`` (D M D, D = diag(√f));
    None: unscaled."""
    M = mass_matrix(np.asarray(q, dtype=np.float64), inertia)
    if mass_scale is None:
        return M
    f = np.asarray(mass_scale, dtype=np.float64)
    if f.shape != (N_JOINTS,) or not np.all(np.isfinite(f) & (f > 0)):
        raise ValueError(f"mass_scale: expected 5 finite factors > 0, got {mass_scale!r}")
    d = np.sqrt(f)
    return d[:, None] * M * d[None, :]


def continuous_joint_model(params: FiveAxisParams, q, mass_scale=None):
    """(A, B, C) of the continuous linearised plant at pose q: states (δξ, δξ̇, τ_a of the
    joints with a current lag), input the command u (5,), output δξ (5,)."""
    n = N_JOINTS
    M = scaled_mass_matrix(q, params.inertia, mass_scale)
    Minv = np.linalg.inv(M)
    visc = np.diag(np.asarray(params.viscous_Ns_m_Nms_rad, dtype=np.float64))
    Kg = gravity_stiffness(q, params.inertia)
    tc = np.asarray(params.current_loop_time_constant_s, dtype=np.float64)
    lag = [j for j in range(n) if tc[j] > 0]
    m = len(lag)
    A = np.zeros((2 * n + m, 2 * n + m))
    B = np.zeros((2 * n + m, n))
    A[:n, n : 2 * n] = np.eye(n)
    A[n : 2 * n, :n] = -Minv @ Kg
    A[n : 2 * n, n : 2 * n] = -Minv @ visc
    # the applied torque: the lagged state where there is a current loop, else the command
    for i, j in enumerate(lag):
        A[n : 2 * n, 2 * n + i] = Minv[:, j]
        A[2 * n + i, 2 * n + i] = -1.0 / tc[j]
        B[2 * n + i, j] = 1.0 / tc[j]
    for j in range(n):
        if j not in lag:
            B[n : 2 * n, j] = Minv[:, j]
    C = np.hstack([np.eye(n), np.zeros((n, n + m))])
    return A, B, C


def discrete_joint_model(params: FiveAxisParams, q, mass_scale=None) -> control.StateSpace:
    """The plant linearised at pose q, sampled with a zero-order hold (python-control's
    ``c2d``), without the computation delay: command → measured joints, dt = servo period."""
    A, B, C = continuous_joint_model(params, q, mass_scale)
    cont = control.ss(A, B, C, np.zeros((N_JOINTS, N_JOINTS)))
    return control.c2d(cont, params.servo_period_s, method="zoh")


def delay_line(params: FiveAxisParams) -> control.StateSpace:
    """The computation delay: z⁻¹ on every input when the plant has it, else the identity."""
    n, T = N_JOINTS, params.servo_period_s
    zero, eye = np.zeros((n, n)), np.eye(n)
    if params.computation_delay:
        return control.ss(zero, eye, eye, zero, T)
    return control.ss([], np.zeros((0, n)), np.zeros((n, 0)), eye, T)


def joint_plant(params: FiveAxisParams, q, mass_scale=None) -> control.StateSpace:
    """Discrete MIMO model (5 inputs, 5 outputs, dt = servo period) of the plant linearised at
    pose q: command → measured joints, ZOH, current lag and computation delay included."""
    return discrete_joint_model(params, q, mass_scale) * delay_line(params)
