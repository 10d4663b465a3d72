"""Jee & Lee 2007's three-axis integrated cross-coupling controller."""

from __future__ import annotations

import numpy as np

from .base import Controller, per_axis
from .parameters import AXES, Param

# Axial P gain and cross-coupling proportional gain (C_I = 2.62 C_P, C_D = 0.02 C_P, the
# paper's §3 ratios), chosen from the realistic-plant design chart (Jee Fig. 5,
# contour_env.app.jee_chart.design(realistic=True); `contour-env stability
# --cross-coupling`), not by simulation: admissible gains are those with gain margin ≥ 6 dB and
# phase margin ≥ 30° on the realistic plant (one-period computation delay, masses ±20 %;
# agents.margins.loop_margins gives GM 6.2 dB, PM 30.3° here). No admissible point meets the
# paper's goal (contour error ≤ 25 µm with tracking error ≤ 250 µm at 10 m/min): the phase
# margin of the x axis's P loop caps K_P near 0.6, while 250 µm at 10 m/min is not reached even
# at the delay's stability limit K_P = 5.57. So the chart's closest point is taken (the largest
# admissible K_P, then the C_P of least contour error, which the normal loop's gain margin
# caps), rounded down from K_P = 0.607, C_P = 2.14. Predicted on a 50 mm circle at 10 m/min
# (worst of the xy, yz, zx planes): 189 µm contour, 3.3 mm tracking error. The former gains
# (K_P = 6, C_P = 4) are unstable in the linear model (a 25 Hz pole at |z| = 1.0023).
DEFAULT_KP = 0.6
DEFAULT_CP = 2.1


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
    COMPILED_LAW = "jee-ccc"
    # command-line parameters (``jee-ccc:kp=8``; :mod:`agents.parameters`)
    PARAMETERS = {
        # the drive takes a K-normalised velocity command (m): K_P and C_P are dimensionless
        "kp": Param("K_P", f"axial P gain K_P, 1 (default {DEFAULT_KP:g})", AXES, ">0"),
        "cp": Param("C_P", f"cross-coupling P gain C_P, 1 (default {DEFAULT_CP:g})", check=">=0"),
        "ci": Param("C_I", "cross-coupling I gain C_I, 1/s (default 2.62 C_P)", check=">=0"),
        "cd": Param("C_D", "cross-coupling D gain C_D, s (default 0.02 C_P)", check=">=0"),
    }

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
        """Eqs. 11–12 (see the class docstring): the compiled law ``jee-ccc``
        (:func:`agents.compiled.laws.law`, the one definition the fused loops run too)."""
        from .compiled.forms import run_law

        return run_law(self, "jee-ccc", signals)

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        """Eqs. 11–12 with ε = (I − t tᵀ) E: U = [K_P + G_C(z) (I − t tᵀ)] E (eq. 8 for G_C)."""
        t = np.asarray(frame, dtype=np.float64)[:, 0]
        Pi = np.eye(self.n_axes) - np.outer(t, t)
        return np.diag(self.K_P) + self.C_P * Pi, self.C_D * Pi, self.C_I * Pi
