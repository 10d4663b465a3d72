"""Cross-coupled control (Koren 1980) with variable gains (Koren & Lo 1991)."""

from __future__ import annotations

import numpy as np

from contour_env.plants.gains import tuned_gain

from .base import per_axis
from .parameters import Param
from .pd import PDController, UntunedGainsWarning, warn_untuned

__all__ = [
    "CORNER_TURN_RAD",
    "DEFAULT_GAINS",
    "FALLBACK_GAINS",
    "CCCController",
    "UntunedGainsWarning",
    "contour_error_estimate",
]

# Cross-coupling gains per plant (per unit nominal axis mass: W_p in 1/s², W_i in 1/s³, W_d in
# 1/s), found by scripts/tune_controllers.py under the margin constraints stated there (gain
# margin ≥ 6 dB, phase margin ≥ 30° over ±20 % mass; bounded with the two-mass mode) on its
# tuning paths, which are not the named cases. The integral is what the margins leave room
# for; W_d never helped on the tuning paths.
DEFAULT_GAINS = {
    "hsm2": {"W_p": 3.0e3, "W_i": 3.0e5, "W_d": 0.0},
    "jee-triaxial": {"W_p": 1.0e4, "W_i": 1.0e6, "W_d": 0.0},
    "linear-motor": {"W_p": 3.0e4, "W_i": 3.0e6, "W_d": 0.0},
    "friction-table": {"W_p": 0.0, "W_i": 3.0e5, "W_d": 0.0},
}
FALLBACK_GAINS = {"W_p": 0.0, "W_i": 0.0, "W_d": 0.0}
# a tangent turning by more than this within one servo period is a corner (exact stop), not a
# curve: 0.1 rad per sample is a 10 mm radius at 10 m/s with a 1 ms period
CORNER_TURN_RAD = 0.1


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


def _coupling_gain(keyword: str, kind: str, unit: str) -> Param:
    """The command-line parameter of one cross-coupling gain (``ccc:wp=3e4``)."""
    return Param(
        keyword, f"cross-coupling {kind} gain {keyword}, {unit} (default per plant)", check=">=0"
    )


class CCCController(PDController):
    """Axial PD loops (the PD controller's gains) plus Koren's cross-coupled correction.

    The contour error estimate ε̂ (:func:`contour_error_estimate`; Koren 1980 for a line,
    Koren & Lo 1991 variable gains for curves, general paths through the local frame) feeds a
    PID compensator, the form of Koren & Lo 1991 and of Jee & Lee 2007 eq. 8,

        C(ε̂) = W_p ε̂ + W_i T Σ ε̂ + W_d (ε̂_k − ε̂_{k−1}) / T,

    whose output is distributed to the axes along the path normal (the variable gains C_x, C_y
    of the path angle) and scaled by the nominal axis masses: u = u_PD − M C(ε̂_n) n
    (− M C(ε̂_b) b in 3-D). Lee 2012's benchmark is the proportional part alone.

    The integral is the part that earns its place under a margin constraint: the proportional
    and derivative parts raise the normal loop's crossover like a stiffer PD would, so they
    are bounded by the same delay-limited margins as PD's ω, while the integral adds gain only
    below the crossover, where a circle's radial error and a friction offset live. It is kept
    as a vector in the normal plane and re-projected on the current frame every sample, so at
    a corner the part of it that no longer lies along the new normal is dropped (an exact
    reversal flips its sign with the normal, keeping its direction in space); it is limited to
    the force limit (anti-windup).

    Parameters: bandwidth_rad_s, damping, P, D as :class:`PDController`; W_p (1/s²), W_i
    (1/s³), W_d (1/s) per unit nominal axis mass (defaults: the plant's tuned
    ``controller_gains`` (``contour-env tune``), else per named plant ``DEFAULT_GAINS``, else 0
    with an ``UntunedGainsWarning``).
    """

    name = "ccc"
    COMPILED_LAW = "ccc"
    CORNER_TURN_RAD = CORNER_TURN_RAD  # the compiled law reads it here
    # command-line parameters (``ccc:wp=3e4:wd=20``; :mod:`agents.parameters`)
    PARAMETERS = {
        **PDController.PARAMETERS,
        "wp": _coupling_gain("W_p", "proportional", "1/s²"),
        "wi": _coupling_gain("W_i", "integral", "1/s³"),
        "wd": _coupling_gain("W_d", "derivative", "1/s"),
    }

    def __init__(self, W_p=None, W_i=None, W_d=None, **pd_kwargs):
        super().__init__(**pd_kwargs)
        self._user = {"W_p": W_p, "W_i": W_i, "W_d": W_d}

    def configure(self) -> None:
        self.configure_pd()
        name = self.nominal.name
        defaults = DEFAULT_GAINS.get(name, FALLBACK_GAINS)
        tuned = {k: tuned_gain(self.nominal, "ccc", k) for k in self._user}
        if any(v is not None for v in tuned.values()):
            defaults = {k: 0.0 if v is None else v for k, v in tuned.items()}
        elif name not in DEFAULT_GAINS and all(v is None for v in self._user.values()):
            self.untuned.append(
                "W_p = W_i = W_d = 0 (no cross-coupling: the same commands as pd; give them as "
                "ccc:wp=W_P:wi=W_I, 1/s² and 1/s³ per unit mass)"
            )
        if self.untuned:
            warn_untuned(self.name, self.untuned, name)
        for key, value in self._user.items():
            v = defaults[key] if value is None else value
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"{key}: must be a number >= 0, got {value!r}") from None
            if not (np.isfinite(v) and v >= 0):
                raise ValueError(f"{key}: must be a finite number >= 0, got {value!r}")
            setattr(self, key, v)
        self.mass = per_axis("mass", self.nominal.mass_kg, self.n_axes)

    def reset(self, mask=None) -> None:
        B, A = self.n_envs, self.n_axes
        if mask is None or not hasattr(self, "_prev"):
            self._prev = np.zeros((B, 2))
            self._integral = np.zeros((B, A))  # T Σ ε̂ as a vector in the normal plane, m s
            self._started = np.zeros(B, dtype=bool)
            self._tangent = np.zeros((B, A))  # the previous sample's path tangent
            self._corner = np.zeros((B, A))  # the reference where the frame last jumped
            self._bisector = np.zeros((B, A))  # old + new tangent at that jump
            self._holding = np.zeros(B, dtype=bool)
        else:
            for arr in (self._prev, self._integral, self._tangent, self._corner, self._bisector):
                arr[mask] = 0.0
            self._started[mask] = False
            self._holding[mask] = False

    def act(self, signals: dict) -> np.ndarray:
        """PD plus the coupling of the class docstring, with the corner hold: the compiled law
        ``ccc`` (:func:`agents.compiled.laws.law`, the one definition the fused loops run
        too).

        The corner hold: Koren's estimate refers to the reference point's frame. Where that
        frame jumps (an exact-stop corner: the tangent turns by more than ``CORNER_TURN_RAD``
        in one sample), a tool still on the previous segment is not off the path, but the
        estimate reads its lag along the old tangent as normal error and the compensator — its
        integral above all — would push it off the path. From the jump until the tool passes
        the corner (the reference where the frame jumped) along the new tangent, the coupling
        holds: the integral restarts at zero and no correction is applied; the axial PD brings
        the tool round the corner. Past means on the new segment's side of the corner's
        bisector, (x − c)·(t_old + t_new) ≥ 0 (a near-reversal, cos turn ≤ −0.9, holds
        nothing: the tool stays on the line)."""
        from .compiled.forms import run_law

        return run_law(self, "ccc", signals)

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        """PD plus the linearised coupling: ε̂_n = −n·E (the κ|E|²/2 term is second order), so
        u = u_PD + M (W_p + W_i T Σ + W_d Δ/T) (n nᵀ + b bᵀ) E."""
        A0, A1, A2 = super().loop_gains(frame)
        F = np.asarray(frame, dtype=np.float64)
        normal = F[:, 1:] @ F[:, 1:].T  # n nᵀ (+ b bᵀ in 3-D)
        coupling = self.mass[:, None] * normal
        return A0 + self.W_p * coupling, A1 + self.W_d * coupling, A2 + self.W_i * coupling
