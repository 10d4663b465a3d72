"""Jee & Lee 2007's three-axis integrated cross-coupling controller."""

from __future__ import annotations

import numpy as np

from .base import Controller, per_axis

# Axial P gain and cross-coupling proportional gain (C_I = 2.62 C_P, C_D = 0.02 C_P, the
# paper's §3 ratios), found by scripts/tune_controllers.py on the realistic jee-circle3d case:
# its one-period computation delay shrinks the Jury range of Table 1's drives (0 < K_P < 16.64
# without delay). On the ideal plant K_P = 12, C_P = 10 meets the paper's design goal
# (contour error ≤ 25 µm with tracking error ≤ 250 µm).
DEFAULT_KP = 6.0
DEFAULT_CP = 4.0


class JeeCCCController(Controller):
    """P axial controllers plus a PID cross-coupling controller on the 3-D contour error
    (Jee & Lee 2007, eqs. 8, 11–13):

        U(z) = K_P E(z) + G_C(z) ε(z),  G_C(z) = C_P + C_I T z/(z − 1) + C_D (z − 1)/(T z)

    with E = x_d − x the tracking error vector and ε = M E its contour error vector. Jee's
    M (eq. 13) combines the projected-plane estimates of eqs. 2–7; for a general 3-D path we
    use the same first-order model in the local frame, ε = (I − t tᵀ) E (the part of E normal
    to the path), which reduces to eqs. 2–7 on each projected plane. The drives take a
    velocity command (``input_kind == "velocity-command"``), as in the paper; force-input
    plants are rejected.

    Parameters: K_P (per axis), C_P, and C_I, C_D (default 2.62 C_P and 0.02 C_P, the
    paper's example ratios).
    """

    name = "jee-ccc"

    def __init__(self, K_P=DEFAULT_KP, C_P=DEFAULT_CP, C_I=None, C_D=None):
        super().__init__()
        self._kp = K_P
        self.C_P = float(C_P)
        self.C_I = 2.62 * self.C_P if C_I is None else float(C_I)
        self.C_D = 0.02 * self.C_P if C_D is None else float(C_D)

    def configure(self) -> None:
        if self.nominal.input_kind != "velocity-command":
            raise ValueError(
                f"controller 'jee-ccc': needs a velocity-command drive (jee-triaxial); plant "
                f"{self.nominal.name!r} takes a force command"
            )
        self.K_P = per_axis("K_P", self._kp, self.n_axes)

    def reset(self, mask=None) -> None:
        shape = (self.n_envs, self.n_axes)
        if mask is None or not hasattr(self, "_sum"):
            self._sum = np.zeros(shape)
            self._prev = np.zeros(shape)
            self._started = np.zeros(self.n_envs, dtype=bool)
        else:
            self._sum[mask] = 0.0
            self._prev[mask] = 0.0
            self._started[mask] = False

    def act(self, signals: dict) -> np.ndarray:
        E = signals["reference_position"] - signals["measured_position"]
        t = signals["frame"][:, :, 0]
        eps = E - np.sum(t * E, axis=1, keepdims=True) * t
        B = E.shape[0]
        T = self.servo_period_s
        self._sum[:B] += eps * T
        started = self._started[:B, None]
        d_eps = np.where(started, (eps - self._prev[:B]) / T, 0.0)
        self._prev[:B] = eps
        self._started[:B] = True
        return self.K_P * E + self.C_P * eps + self.C_I * self._sum[:B] + self.C_D * d_eps
