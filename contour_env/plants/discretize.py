"""Linear part of each axis as a state-space model, discretised exactly over a hold interval.

State layout per axis (the same for every axis of a plant; position is index 0, the velocity on
which friction, ripple and disturbance act is index 1):

- rigid body:            z = [x, v]                   (+ [f] with a current-loop lag)
- two-mass ball screw:   z = [x_load, v_load, x_motor, v_motor]   (+ [f])

The actuator command u is held constant over the interval (zero-order hold). The nonlinear
force w (friction + ripple + disturbance, with sign: it enters as +w on the load) is taken as
varying linearly over the interval (first-order hold), which is exact for a linear-in-time w
and second-order accurate in a predictor–corrector scheme.
"""

from __future__ import annotations

import numpy as np
from scipy.linalg import expm

from .params import PlantParams


def state_size(params: PlantParams) -> int:
    n = 4 if params.has_structural_mode else 2
    if np.any(params.current_loop_time_constant_s > 0):
        n += 1
    return n


def continuous_model(params: PlantParams) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Continuous (A, B_u, B_w) per axis: shapes (n_axes, ns, ns), (n_axes, ns), (n_axes, ns)."""
    ns = state_size(params)
    n_axes = params.n_axes
    A = np.zeros((n_axes, ns, ns))
    Bu = np.zeros((n_axes, ns))
    Bw = np.zeros((n_axes, ns))
    two_mass = params.has_structural_mode
    lag = ns in (3, 5)
    f_idx = ns - 1
    for i in range(n_axes):
        m = params.mass_kg[i]
        b = params.viscous_Ns_m[i]
        tau_c = params.current_loop_time_constant_s[i]
        A[i, 0, 1] = 1.0
        if two_mass:
            k = params.structural_stiffness_N_m[i]
            c = params.structural_damping_Ns_m[i]
            m_load = params.load_mass_fraction[i] * m
            m_motor = m - m_load
            # load (table): guideway viscous friction and the nonlinear force act here
            A[i, 1, 0] = -k / m_load
            A[i, 1, 1] = -(c + b) / m_load
            A[i, 1, 2] = k / m_load
            A[i, 1, 3] = c / m_load
            A[i, 2, 3] = 1.0
            A[i, 3, 0] = k / m_motor
            A[i, 3, 1] = c / m_motor
            A[i, 3, 2] = -k / m_motor
            A[i, 3, 3] = -c / m_motor
            drive_row, drive_mass = 3, m_motor
            Bw[i, 1] = 1.0 / m_load
        else:
            A[i, 1, 1] = -b / m
            drive_row, drive_mass = 1, m
            Bw[i, 1] = 1.0 / m
        if lag and tau_c > 0:
            A[i, drive_row, f_idx] = 1.0 / drive_mass
            A[i, f_idx, f_idx] = -1.0 / tau_c
            Bu[i, f_idx] = 1.0 / tau_c
        else:
            Bu[i, drive_row] = 1.0 / drive_mass
    return A, Bu, Bw


def discretize(A: np.ndarray, Bu: np.ndarray, Bw: np.ndarray, h: float):
    """Exact discretisation over h seconds, batched over leading axes.

    Returns Phi (..., ns, ns), Gu (..., ns) for a held u, and Ga, Gb (..., ns) such that
    z(h) = Phi z0 + Gu u + Ga w0 + Gb w1 for w varying linearly from w0 to w1.
    """
    ns = A.shape[-1]
    lead = A.shape[:-2]
    M = np.zeros((*lead, ns + 3, ns + 3))
    M[..., :ns, :ns] = A
    M[..., :ns, ns] = Bu
    M[..., :ns, ns + 1] = Bw
    M[..., ns + 1, ns + 2] = 1.0  # w' = r (slope state)
    E = expm(M * h)
    Phi = np.ascontiguousarray(E[..., :ns, :ns])
    Gu = np.ascontiguousarray(E[..., :ns, ns])
    G1 = E[..., :ns, ns + 1]
    G2 = E[..., :ns, ns + 2]
    Gb = np.ascontiguousarray(G2 / h)
    Ga = np.ascontiguousarray(G1 - Gb)
    return Phi, Gu, Ga, Gb
