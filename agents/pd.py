"""Per-axis PD position control (Lee, Dixon & Ziegert 2012, §4)."""

from __future__ import annotations

import warnings

import numpy as np

from contour_env.plants.gains import tuned_gain

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
# ω on a plant with no tuned value (neither named nor tuned by ``contour-env tune``): not
# margin-checked on it, so PD warns (``UntunedGainsWarning``)
FALLBACK_BANDWIDTH_RAD_S = 100.0


class UntunedGainsWarning(UserWarning):
    """A controller runs on a plant it has no tuned gains for (a plant file, custom
    parameters) and falls back to gains that may not suit it."""


def default_bandwidth(nominal) -> tuple[float, bool]:
    """(ω in rad/s, tuned) for the nominal plant parameters: the ω ``contour-env tune``
    wrote into the plant (``controller_gains.pd``), else the named plant's
    ``DEFAULT_BANDWIDTH_RAD_S``, else ``FALLBACK_BANDWIDTH_RAD_S`` (tuned = False)."""
    w = tuned_gain(nominal, "pd", "bandwidth_rad_s")
    if w is None:
        w = DEFAULT_BANDWIDTH_RAD_S.get(nominal.name)
    if w is None:
        return FALLBACK_BANDWIDTH_RAD_S, False
    return float(w), True


def warn_untuned(controller: str, what: list[str], plant_name: str) -> None:
    """One warning: ``controller`` has no tuned ``what`` for ``plant_name`` and uses the
    fallbacks listed; says how to tune them (``contour-env tune``) or give and check them."""
    warnings.warn(
        f"{controller}: no tuned gains for plant {plant_name!r} (named plants: "
        f"{', '.join(DEFAULT_BANDWIDTH_RAD_S)}): {'; '.join(what)}, not margin-checked on it; "
        "tune them with contour-env tune --plant plant.json --out plant.json, or give them "
        f"({controller}:...) and check them with contour-env margins --plant plant.json "
        f"--controller {controller}:... --check",
        UntunedGainsWarning,
        stacklevel=4,
    )


class PDController(Controller):
    """u_i = P_i e_i + D_i ė_i per axis, e = x_d − x from the encoder (Lee 2012 §4).

    Lee tunes each axis for the lowest following error without overshoot, then balances the
    axes. With the nominal model m ẍ + b ẋ = u, P = m ω², D = 2 ζ m ω − b puts both poles of
    every axis at the same critically damped ω: balanced axes by construction.

    Parameters
    ----------
    bandwidth_rad_s : float, optional
        ω (rad/s); default per plant: the plant's tuned ``controller_gains`` (``contour-env
        tune``), else ``DEFAULT_BANDWIDTH_RAD_S``, else 100 rad/s with an
        ``UntunedGainsWarning``.
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
        self.configure_pd()
        if self.untuned:
            warn_untuned(self.name, self.untuned, self.nominal.name)

    def configure_pd(self) -> None:
        """P and D from ω and ζ (or as given); ``self.untuned`` lists what fell back to an
        untuned value (the caller warns)."""
        m, b = self.nominal.mass_kg, self.nominal.viscous_Ns_m
        w = self.bandwidth_rad_s
        self.untuned = []
        if w is None:
            w, tuned = default_bandwidth(self.nominal)
            if not tuned and (self._P_user is None or self._D_user is None):
                self.untuned.append(f"ω = {w:g} rad/s")
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
        """u = P e + D ė per axis, e = x_d − x: the compiled law ``pd``
        (:func:`agents.compiled.laws.law`, the one definition the fused loops run too)."""
        from .compiled.forms import run_law

        return run_law(self, "pd", signals)

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        """u = P E + D (E_k − E_{k−1})/T (backward-difference velocity): diagonal, no frame."""
        n = self.n_axes
        return np.diag(self.P), np.diag(self.D), np.zeros((n, n))
