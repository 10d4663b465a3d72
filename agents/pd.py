"""Per-axis PD position control (Lee, Dixon & Ziegert 2012, §4)."""

from __future__ import annotations

import numpy as np

from .base import Controller

# Closed-loop natural frequency (rad/s) per plant for the default gains: the same on every
# axis ("balanced", Lee §4), critically damped (no overshoot). Chosen below the limit that
# the one-period computation delay and the current-loop lag of the realistic plants allow.
DEFAULT_BANDWIDTH_RAD_S = {
    "hsm2": 100.0,
    "jee-triaxial": 200.0,
    "linear-motor": 300.0,
    "friction-table": 150.0,
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
    P, D : array-like, optional
        Explicit gains per axis (N/m, N s/m) overriding the pole placement.
    """

    name = "pd"

    def __init__(self, bandwidth_rad_s=None, damping=DEFAULT_DAMPING, P=None, D=None):
        super().__init__()
        self.bandwidth_rad_s = bandwidth_rad_s
        self.damping = float(damping)
        self._P_user = None if P is None else np.asarray(P, dtype=np.float64)
        self._D_user = None if D is None else np.asarray(D, dtype=np.float64)

    def configure(self) -> None:
        m, b = self.nominal.mass_kg, self.nominal.viscous_Ns_m
        w = self.bandwidth_rad_s
        if w is None:
            w = DEFAULT_BANDWIDTH_RAD_S.get(self.nominal.name, 100.0)
        if not (np.isfinite(w) and w > 0):
            raise ValueError(f"bandwidth_rad_s: must be > 0, got {w!r}")
        self.P = m * w**2 if self._P_user is None else self._P_user
        self.D = (
            np.maximum(2 * self.damping * m * w - b, 0.0)
            if self._D_user is None
            else (self._D_user)
        )
        for name, g in (("P", self.P), ("D", self.D)):
            if np.shape(g) not in ((), (self.n_axes,)):
                raise ValueError(f"{name}: expected a scalar or {self.n_axes} per-axis gains")

    def act(self, signals: dict) -> np.ndarray:
        e = signals["reference_position"] - signals["measured_position"]
        de = signals["reference_velocity"] - signals["measured_velocity"]
        return self.P * e + self.D * de
