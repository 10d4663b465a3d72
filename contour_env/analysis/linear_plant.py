"""The linear part of a plant as a discrete-time MIMO system, for loop analysis.

The per-axis model is the one the compiled kernel integrates (:func:`contour_env.plants.
discretize.continuous_model`: mass, viscous friction, current-loop lag, optional two-mass
mode), sampled with a zero-order hold at the servo period by python-control's ``c2d``, with
the one-period computation delay as a factor z⁻¹ when the plant has it. Input: the actuator
command (N, or the velocity command of ``jee-triaxial``); output: the position the encoder
reads (m): the table, or with the two-mass mode the drive side (semi-closed loop). Left out,
because they are not linear: Coulomb/static friction, ripple, saturation and encoder
quantisation (their effect is what the simulations score).
"""

from __future__ import annotations

import control
import numpy as np

from contour_env.plants import PlantParams
from contour_env.plants.discretize import continuous_model

#: With the two-mass mode the encoder reads the drive (motor) side, state index 2 (as the
#: compiled env does: semi-closed loop); otherwise the table, index 0.
MEASURED_STATE_TWO_MASS = 2


def axis_plant(params: PlantParams, axis: int) -> control.StateSpace:
    """Discrete SISO model of one axis: command → load position, ZOH and delay included."""
    A, Bu, _ = continuous_model(params)
    ns = A.shape[-1]
    C = np.zeros((1, ns))
    C[0, MEASURED_STATE_TWO_MASS if params.has_structural_mode else 0] = 1.0
    cont = control.ss(A[axis], Bu[axis][:, None], C, np.zeros((1, 1)))
    T = params.servo_period_s
    disc = control.c2d(cont, T, method="zoh")
    if params.computation_delay:
        disc = disc * control.ss(np.zeros((1, 1)), [[1.0]], [[1.0]], [[0.0]], T)  # z⁻¹
    return disc


def discrete_plant(params: PlantParams) -> control.StateSpace:
    """The decoupled axes as one MIMO system (A inputs, A outputs), dt = servo period."""
    return control.append(*(axis_plant(params, i) for i in range(params.n_axes)))


def controller_system(A0, A1, A2, servo_period_s: float) -> control.StateSpace:
    """u = A0 E + A1 (E_k − E_{k−1})/T + A2 T Σ E (see ``Controller.loop_gains``) as a
    discrete MIMO state-space system E → u."""
    A0, A1, A2 = (np.asarray(a, dtype=np.float64) for a in (A0, A1, A2))
    n = A0.shape[0]
    T = float(servo_period_s)
    I = np.eye(n)
    # states: E_{k−1} (backward difference), and T Σ_{j<k} Vᵀ E_j for the r directions the
    # integral term acts on (A2 = U S Vᵀ, rank r), so that no integrator is left without input
    # or output (a hidden pole at z = 1 would read as marginal instability)
    U, S, Vt = np.linalg.svd(A2)
    r = int(np.sum(S > 1e-12 * max(1.0, float(S.max(initial=0.0)))))
    A = np.zeros((n + r, n + r))
    A[n:, n:] = np.eye(r)
    B = np.vstack([I, T * Vt[:r]])
    C = np.hstack([-A1 / T, U[:, :r] * S[:r]])
    D = A0 + A1 / T + T * A2
    return control.ss(A, B, C, D, T)
