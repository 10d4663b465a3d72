"""Per-axis PD position control (Lee, Dixon & Ziegert 2012, §4)."""

from __future__ import annotations

import numpy as np

from .base import Controller, per_axis
from .parameters import AXES, Param

# Closed-loop natural frequency (rad/s) per plant for the default gains: the same on every
# axis ("balanced", Lee §4), critically damped (no overshoot). The largest ω of
# scripts/tune_controllers.py's grid (40–400 rad/s) whose loops keep gain margin ≥ 6 dB and
# phase margin ≥ 30° on the realistic plant over the ±20 % mass corners, and stay stable with
# the two-mass mode (gain margin ≥ 2 dB, phase margin ≥ 10°) — agents.margins. The one-period
# computation delay, the current-loop lag and (hsm2, friction-table) the structural mode
# bound it; the margins are in the README's controller table.
DEFAULT_BANDWIDTH_RAD_S = {
    "hsm2": 80.0,
    "jee-triaxial": 150.0,
    "linear-motor": 400.0,
    "friction-table": 75.0,
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
    COMPILED_LAW = "pd"  # agents.compiled.forms: the compiled law of this exact class
    # command-line parameters (``pd:w=80``; :mod:`agents.parameters`)
    PARAMETERS = {
        "w": Param(
            "bandwidth_rad_s",
            "closed-loop bandwidth ω of every axis, rad/s (default per plant)",
            check=">0",
        ),
        "zeta": Param("damping", "damping ratio ζ of the axis poles (default 1)", check=">0"),
        "p": Param("P", "proportional gain P, N/m (overrides w)", AXES, ">=0"),
        "d": Param("D", "derivative gain D, N s/m (overrides w, zeta)", AXES, ">=0"),
    }

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

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        """u = P E + D (E_k − E_{k−1})/T (backward-difference velocity): diagonal, no frame."""
        n = self.n_axes
        return np.diag(self.P), np.diag(self.D), np.zeros((n, n))
