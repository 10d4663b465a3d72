"""Per-axis PD position control (Lee, Dixon & Ziegert 2012, §4)."""

from __future__ import annotations

import numpy as np

from .base import Controller, per_axis

# Closed-loop natural frequency (rad/s) per plant for the default gains: the same on every
# axis ("balanced", Lee §4), critically damped (no overshoot). Found by
# scripts/tune_controllers.py (criterion there); the realistic plants' one-period delay and
# current-loop lag bound it.
DEFAULT_BANDWIDTH_RAD_S = {
    "hsm2": 150.0,
    "jee-triaxial": 250.0,
    "linear-motor": 400.0,
    "friction-table": 200.0,
}
DEFAULT_DAMPING = 1.0


class PDController(Controller):
    """u_i = P_i e_i + D_i ė_i per axis, e = x_d − x from the encoder (Lee 2012 §4).

    Lee tunes each axis for the lowest following error without overshoot, then balances the
    axes. With the nominal model m ẍ + b ẋ = u, P = m ω², D = 2 ζ m ω − b puts both poles of
    every axis at the same critically damped ω: balanced axes by construction.

    Parameters
    ----------
    bandwidth_rad_s : float, optional
        ω (rad/s); default per plant from ``DEFAULT_BANDWIDTH_RAD_S``.
    damping : float
        ζ (default 1).
    P, D : scalar or per-axis, optional
        Explicit gains (N/m, N s/m) overriding the pole placement.
    """

    name = "pd"

    def __init__(self, bandwidth_rad_s=None, damping=DEFAULT_DAMPING, P=None, D=None):
        super().__init__()
        self.bandwidth_rad_s = bandwidth_rad_s
        self.damping = float(damping)
        self._P_user = P
        self._D_user = D

    def configure(self) -> None:
        m, b = self.nominal.mass_kg, self.nominal.viscous_Ns_m
        w = self.bandwidth_rad_s
        if w is None:
            w = DEFAULT_BANDWIDTH_RAD_S.get(self.nominal.name, 100.0)
        if not (np.isfinite(w) and w > 0):
            raise ValueError(f"bandwidth_rad_s: must be > 0, got {w!r}")
        self.omega = float(w)
        n = self.n_axes
        self.P = m * w**2 if self._P_user is None else per_axis("P", self._P_user, n)
        self.D = (
            np.maximum(2 * self.damping * m * w - b, 0.0)
            if self._D_user is None
            else per_axis("D", self._D_user, n)
        )

    def act(self, signals: dict) -> np.ndarray:
        e = signals["reference_position"] - signals["measured_position"]
        de = signals["reference_velocity"] - signals["measured_velocity"]
        return self.P * e + self.D * de
