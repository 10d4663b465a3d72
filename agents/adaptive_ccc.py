"""Adaptive nonlinear contour coupling control (Lee, Dixon & Ziegert 2012, eqs. 19–26, 38)."""

from __future__ import annotations

import numpy as np

from .base import Controller, per_axis

# Feedback bandwidth ω (rad/s): k_i = 2 m_i ω and α = ω / 2 give the same proportional and
# derivative action as the PD controller (k α = m ω², k = 2 m ω), so the comparison isolates
# the cross-coupling and adaptive terms. Found by scripts/tune_controllers.py.
DEFAULT_BANDWIDTH_RAD_S = {
    "hsm2": 150.0,
    "jee-triaxial": 250.0,
    "linear-motor": 400.0,
    "friction-table": 200.0,
}
# adaptation gains per unit nominal parameter: Γ_m = γ_m m_nom, Γ_b = γ_b b_nom (or m_nom
# where b_nom = 0)
DEFAULT_GAMMA = {
    "hsm2": (0.3, 1.0),
    "jee-triaxial": (50.0, 200.0),
    "linear-motor": (1.0, 5.0),
    "friction-table": (3.0, 15.0),
}


def _R(curvature, torsion, n_axes):
    """Lee 2012 eq. 15 (3-D) / eq. 37 (2-D) for a batch: R = [[0, κ, 0], [−κ, 0, τ], [0, −τ, 0]]."""
    B = curvature.shape[0]
    R = np.zeros((B, n_axes, n_axes))
    R[:, 0, 1] = curvature
    R[:, 1, 0] = -curvature
    if n_axes == 3:
        R[:, 1, 2] = torsion
        R[:, 2, 1] = -torsion
    return R


class AdaptiveCCCController(Controller):
    """Lee 2012's adaptive CCC for n axes, in its inertial form, eq. 38:

        T = k v (F R Fᵀ)(x_d − x) + (α k + 1)(x_d − x) + k (ẋ_d − ẋ) + F Y_d θ̂

    i.e. T = k F r + F e + F Y_d θ̂ with the task-frame errors e = Fᵀ(x_d − x) (eq. 19),
    r = ė + α e (eq. 20), T̄ = (k₁ + k_n ζ₁²) r + Y_d θ̂ + e (eq. 25) and T = F T̄ (eq. 9),
    using Ḟᵀ = v R Fᵀ (eq. 14). θ = [m₁..m_n, b₁..b_n] are the unknown diagonal inertia and
    viscous friction, Y_d = Fᵀ [diag(ẍ_d), diag(ẋ_d)] the desired regression (eqs. 13, 22),
    and the adaptation law is θ̂̇ = Γ Y_dᵀ r (eq. 26), θ̂(0) = the nominal model, integrated
    once per servo period (estimates kept ≥ 0). k = k₁ + k_n ζ₁² is used per axis
    (k_i = 2 m_i ω) so that axes of very different mass are balanced; α = ω / 2.

    Parameters: bandwidth_rad_s (ω), k (per axis, N s/m) and alpha (1/s) overriding it,
    gamma = (γ_m, γ_b) with Γ = diag(γ_m m_nom, γ_b b_nom) (default per plant).
    """

    name = "adaptive-ccc"

    def __init__(self, bandwidth_rad_s=None, k=None, alpha=None, gamma=None):
        super().__init__()
        self.bandwidth_rad_s = bandwidth_rad_s
        self._k_user, self._alpha_user = k, alpha
        self._gamma_user = gamma

    def configure(self) -> None:
        m, b = self.nominal.mass_kg, self.nominal.viscous_Ns_m
        w = self.bandwidth_rad_s or DEFAULT_BANDWIDTH_RAD_S.get(self.nominal.name, 100.0)
        if not (np.isfinite(w) and w > 0):
            raise ValueError(f"bandwidth_rad_s: must be > 0, got {w!r}")
        n = self.n_axes
        gamma = self._gamma_user or DEFAULT_GAMMA.get(self.nominal.name, (1.0, 5.0))
        self.gamma = tuple(float(g) for g in gamma)
        if len(self.gamma) != 2 or any(not np.isfinite(g) or g < 0 for g in self.gamma):
            raise ValueError(f"gamma: two adaptation gains >= 0, got {gamma!r}")
        self.k = 2 * m * w if self._k_user is None else per_axis("k", self._k_user, n)
        self.alpha = w / 2 if self._alpha_user is None else float(self._alpha_user)
        self.theta0 = np.concatenate([m, b])
        scale_b = np.where(b > 0, b, m)
        self.Gamma = np.concatenate([self.gamma[0] * m, self.gamma[1] * scale_b])

    def reset(self, mask=None) -> None:
        if mask is None or not hasattr(self, "theta_hat"):
            self.theta_hat = np.tile(self.theta0, (self.n_envs, 1))
        else:
            self.theta_hat[mask] = self.theta0

    def act(self, signals: dict) -> np.ndarray:
        n = self.n_axes
        E = signals["reference_position"] - signals["measured_position"]
        Ed = signals["reference_velocity"] - signals["measured_velocity"]
        F = signals["frame"]
        B = E.shape[0]
        R = _R(signals["curvature"], signals["torsion"], n)
        FtE = np.einsum("bji,bj->bi", F, E)
        FRFtE = np.einsum("bij,bj->bi", F, np.einsum("bij,bj->bi", R, FtE))
        Fr = Ed + self.alpha * E + signals["feedrate"][:, None] * FRFtE  # F r, inertial frame
        th = self.theta_hat[:B]
        acc_d = signals["reference_acceleration"]
        vel_d = signals["reference_velocity"]
        feedforward = th[:, :n] * acc_d + th[:, n:] * vel_d  # F Y_d θ̂ = M̂ ẍ_d + B̂ ẋ_d
        T = self.k * Fr + E + feedforward
        # θ̂̇ = Γ Y_dᵀ r = Γ [diag(ẍ_d); diag(ẋ_d)] F r  (eq. 26), one servo period
        dt = self.servo_period_s
        th[:, :n] += dt * self.Gamma[:n] * acc_d * Fr
        th[:, n:] += dt * self.Gamma[n:] * vel_d * Fr
        np.maximum(th, 0.0, out=th)
        return T
