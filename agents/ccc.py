"""Cross-coupled control (Koren 1980) with variable gains (Koren & Lo 1991)."""

from __future__ import annotations

import numpy as np

from .base import per_axis
from .pd import PDController

# Proportional cross-coupling gain W_p (1/s², an acceleration per metre of contour error,
# scaled by each axis's nominal mass) per plant; found by scripts/tune_controllers.py.
DEFAULT_WP = {
    "hsm2": 6.0e4,
    "jee-triaxial": 9.0e4,
    "linear-motor": 3.0e5,
    "friction-table": 6.0e4,
}


def contour_error_estimate(signals: dict) -> tuple[np.ndarray, np.ndarray | None]:
    """Koren & Lo's variable-gain contour error estimate in the local frame (batched).

    With E = x_d − x, the frame columns t, n (, b) and signed curvature κ:
    ε_n = −(n·E + κ |E|² / 2), ε_b = −b·E (3-D). For a straight line this is Koren's
    ε = −E_x sin θ + E_y cos θ (up to sign); on a circle the κ|E|²/2 term is Koren & Lo's
    variable-gain correction (C_x = sin θ − E_x / 2R, C_y = cos θ + E_y / 2R). Positive ε_n:
    the tool is off the path on the +n side. Returns (ε_n (B,), ε_b (B,) or None), metres.
    """
    E = signals["reference_position"] - signals["measured_position"]
    F = signals["frame"]
    n = F[:, :, 1]
    eps_n = -(np.sum(n * E, axis=1) + 0.5 * signals["curvature"] * np.sum(E * E, axis=1))
    eps_b = -np.sum(F[:, :, 2] * E, axis=1) if F.shape[2] == 3 else None
    return eps_n, eps_b


class CCCController(PDController):
    """Axial PD loops (the PD controller's gains) plus Koren's cross-coupled correction.

    The contour error estimate ε̂ (:func:`contour_error_estimate`; Koren 1980 eqs. for a line,
    Koren & Lo 1991 variable gains for curves, general paths through the local frame) feeds a
    compensator C(ε̂) = W_p ε̂ + W_d dε̂/dt whose output is distributed to the axes along the
    path normal (the variable gains C_x, C_y of the path angle): u = u_PD − M C(ε̂) n (and
    along the binormal in 3-D). Lee 2012 uses the proportional law (W_d = 0) as its benchmark.

    Parameters: bandwidth_rad_s, damping, P, D as :class:`PDController`; W_p (1/s²) and
    W_d (1/s) cross-coupling gains (default per plant ``DEFAULT_WP``, W_d = 0).
    """

    name = "ccc"

    def __init__(self, W_p=None, W_d=0.0, **pd_kwargs):
        super().__init__(**pd_kwargs)
        self._Wp_user = W_p
        self.W_d = float(W_d)

    def configure(self) -> None:
        super().configure()
        wp = (
            self._Wp_user if self._Wp_user is not None else DEFAULT_WP.get(self.nominal.name, 3.0e4)
        )
        self.W_p = float(wp)
        if not (np.isfinite(self.W_p) and self.W_p >= 0):
            raise ValueError(f"W_p: must be >= 0, got {wp!r}")
        self.mass = per_axis("mass", self.nominal.mass_kg, self.n_axes)

    def reset(self, mask=None) -> None:
        shape = (self.n_envs, 2)
        if mask is None or not hasattr(self, "_prev"):
            self._prev = np.zeros(shape)
            self._started = np.zeros(self.n_envs, dtype=bool)
        else:
            self._prev[mask] = 0.0
            self._started[mask] = False

    def act(self, signals: dict) -> np.ndarray:
        u = super().act(signals)
        eps_n, eps_b = contour_error_estimate(signals)
        T = self.servo_period_s
        B = eps_n.shape[0]
        prev = self._prev[:B]
        started = self._started[:B]
        d_n = np.where(started, (eps_n - prev[:, 0]) / T, 0.0)
        c_n = self.W_p * eps_n + self.W_d * d_n
        u = u - self.mass * c_n[:, None] * signals["frame"][:, :, 1]
        prev[:, 0] = eps_n
        if eps_b is not None:
            d_b = np.where(started, (eps_b - prev[:, 1]) / T, 0.0)
            c_b = self.W_p * eps_b + self.W_d * d_b
            u = u - self.mass * c_b[:, None] * signals["frame"][:, :, 2]
            prev[:, 1] = eps_b
        started[:] = True
        return u
