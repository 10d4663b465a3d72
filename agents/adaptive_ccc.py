"""Adaptive nonlinear contour coupling control (Lee, Dixon & Ziegert 2012, eqs. 19–26, 38, 39)."""

from __future__ import annotations

import math

import numpy as np

from contour_env.plants.gains import tuned_gain

from .base import Controller, per_axis
from .parameters import AXES, BOOL, Param
from .pd import default_bandwidth, warn_untuned

# Feedback bandwidth ω (rad/s): k_i = 2 m_i ω − b_i and α_i = (m_i ω² − 1) / k_i give the same
# proportional and derivative action as the PD controller (α k + 1 = m ω², k = 2 m ω − b; Lee
# used his PD gains for these terms), so the comparison isolates the cross-coupling and
# adaptive terms, and the loop margins are PD's. The same ω as agents.pd.
DEFAULT_BANDWIDTH_RAD_S = {
    "hsm2": 80.0,
    "jee-triaxial": 150.0,
    "linear-motor": 400.0,
    "friction-table": 75.0,
}
#: Adaptation time constant τ_a (s) the default Γ is derived for (see the class docstring):
#: 40× the loop time constant 1/ω of the slowest loop (hsm2, 12.5 ms), so adaptation and
#: feedback stay separated in time scale, and short enough for the estimates to settle within
#: a part program of a few seconds.
DEFAULT_TAU_A_S = 0.5
#: The tuning excitation per plant: a circle (radius m, feed m/s); one axis's reference motion
#: on it, x = R sin(v t / R), has the mean squares ā² = v⁴/(2 R²) and v̄² = v²/2 that Γ is
#: scaled to. None of them is a named case (chosen before, and never tuned on, the cases).
TUNING_CIRCLE = {
    "hsm2": (0.08, 0.3),  # 1.13 m/s² centripetal, 3.75 rad/s
    "jee-triaxial": (0.03, 0.1),
    "linear-motor": (0.05, 0.1),
    "friction-table": (0.01, 0.02),
}
DEFAULT_TUNING_CIRCLE = (0.05, 0.1)


def tuning_excitation(radius_m: float, feed_m_s: float) -> tuple[float, float]:
    """(ā², v̄²): the mean squares of one axis's reference acceleration and velocity on a circle
    of ``radius_m`` at ``feed_m_s`` (x = R sin(v t / R): ā² = v⁴/(2 R²), v̄² = v²/2)."""
    if not (radius_m > 0 and feed_m_s > 0):
        raise ValueError(f"tuning_circle: radius and feed must be > 0, got {radius_m}, {feed_m_s}")
    return feed_m_s**4 / (2 * radius_m**2), feed_m_s**2 / 2


def adaptation_gains(k, tau_a_s: float, mean_squares) -> np.ndarray:
    """Γ per regressor column j and axis i, shape (columns, axes): Γ_j,i = k_i / (τ_a ⟨φ_j²⟩),
    the rule of :class:`AdaptiveCCCController` (``mean_squares``: ⟨φ_j²⟩ of each column on the
    tuning excitation, e.g. (ā², v̄²))."""
    k = np.asarray(k, dtype=np.float64)
    return np.stack([k / (tau_a_s * float(ms)) for ms in mean_squares])


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

        T = diag(c) v (F R Fᵀ)(x_d − x) + (α k + 1)(x_d − x) + k (ẋ_d − ẋ) + F Y_d θ̂

    With c = k (the default) this is T = k F r + F e + F Y_d θ̂ with the task-frame errors
    e = Fᵀ(x_d − x) (eq. 19), r = ė + α e (eq. 20), T̄ = (k₁ + k_n ζ₁²) r + Y_d θ̂ + e
    (eq. 25) and T = F T̄ (eq. 9), using Ḟᵀ = v R Fᵀ (eq. 14). θ = [m₁..m_n, b₁..b_n] are
    the unknown diagonal inertia and viscous friction, Y_d = Fᵀ [diag(ẍ_d), diag(ẋ_d)] the
    desired regression (eqs. 13, 22), and the adaptation law is θ̂̇ = Γ Y_dᵀ r (eq. 26),
    θ̂(0) = the nominal model, integrated once per servo period (estimates kept ≥ 0). r is
    always eq. 20's (the coupling gains below do not change it). k = k₁ + k_n ζ₁² and α are
    used per axis, with Lee's choice of the PD's gains for eq. 38's proportional and derivative
    terms: k_i = 2 m_i ω − b_i (PD's D) and α_i = (m_i ω² − 1) / k_i (α k + 1 = PD's P; α = ω/2
    where b = 0), so axes of very different mass are balanced and the loop margins
    (``loop_gains``) are the PD's up to the coupling term.

    **Coupling gains.** Lee tunes the cross-coupling term separately from k: on his 2-D
    circle eq. 38's first term is diag((kv/ρ)₁, (kv/ρ)₂) [x_d2 − x_2, −(x_d1 − x_1)] (eq. 39)
    with (kv/ρ)₁ = 422, (kv/ρ)₂ = 1359 chosen as independent constants. Here ``coupling``
    (c, N s/m per axis, default k) replaces k in that term, so (kv/ρ)_i = c_i v/ρ on a
    circle; ``kv_rho`` (N/m per axis, 2-axis plants only) is Lee's literal form, a coupling
    stiffness independent of feed and radius: the term diag(kv_rho) sgn(κ) J (x_d − x),
    J = [[0, 1], [−1, 0]] (F R Fᵀ = κ J in 2-D), zero on straight segments; giving it sets the
    default c to 0. kv_rho is in SI on this model's linear-equivalent axes (x: force per metre
    of y error, a torque divided by the lead for hsm2's rotary x). Lee's 422 / 1359 are in his
    PMAC servo's internal units (his PD gains P_x = 360 000, D_x = 9 000 000 are not SI
    either: D/P = 25 servo periods) and are not converted; relative to his own P gains they are
    0.12 % (x) and 2.3 % (y) of P, i.e. kv_rho ≈ 2.3e4 / 1.7e5 N/m at this model's ω = 80 rad/s
    (an estimate that ignores his axes' different encoder counts).

    **Coulomb friction (ours).** θ also holds the Coulomb friction f_c of every axis, with the
    regressor column sgn(ẋ_d) and θ̂(0) = the nominal f_c (0 where the paper gives none: hsm2,
    jee-triaxial); ``friction=False`` is Lee's θ = [m, b]. Without it the law ignores the
    friction the nominal model has (linear-motor, friction-table) and friction the true plant
    has anyway; the m, b estimates then drift to absorb it (m̂ → 0 on the linear motor's and the
    friction table's polygons, where adaptive CCC was 1.03× / 1.9× PD's RMS error).

    **Adaptation gains by a rule.** For adaptation slower than the loop, the closed loop of
    axis i settles to k_i (F r)_i ≈ (Y_d θ̃)_i (the PD force balancing the feedforward's error,
    θ̃ = θ − θ̂), so F r ≈ Y_d θ̃ / k and eq. 26 becomes

        θ̃̇ ≈ −Γ Y_dᵀ Y_d θ̃ / k,   i.e. per axis  θ̃̇_j = −(Γ_j / k) Σ_l ⟨φ_j φ_l⟩ θ̃_l

    with the regressor columns φ = (ẍ_d, ẋ_d[, sgn ẋ_d]) of the axis. On an excitation whose
    acceleration and velocity are uncorrelated (a circle: they are in quadrature on every
    axis) each parameter error decays with the time constant k / (Γ_j ⟨φ_j²⟩). Γ is chosen so
    that this is τ_a (``tau_a_s``, default 0.5 s) for every parameter at the plant's tuning
    excitation (one axis of the circle ``TUNING_CIRCLE[plant]``, not a named case):

        Γ_m,i = γ_m k_i / (τ_a ā²),   Γ_b,i = γ_b k_i / (τ_a v̄²),   Γ_c,i = γ_b k_i / τ_a,

    ā² = v⁴/(2R²), v̄² = v²/2 and ⟨sgn²⟩ = 1 on the circle; the multipliers γ_m = γ_b = 1 by
    default (``gamma`` sets both, 0 switches the adaptation off). (On the circle sgn ẋ_d and
    ẋ_d are correlated, 2√2/π ≈ 0.9: b and f_c separate about ten times more slowly.)

    **Normalisation (ours).** Unnormalised, the rate scales with the square of the excitation:
    on a spline with 25× the tuning acceleration it reaches the loop's own time scale. With
    ``normalize`` (default) the step is divided by n² = max(1, ψ²/N), ψ² = Σ_j φ_j²/⟨φ_j²⟩
    over the N columns: ψ² = N at every instant on the tuning circle (so the rule holds there
    exactly), and on stronger excitations the time constant stays about τ_a instead of
    shrinking (a normalised gradient law, Ioannou & Sun 1996 §4.3).

    **Velocity error (ours).** The measured velocity is the encoder's backward difference,
    the velocity half a servo period ago, so Ė uses ẋ_d − ẍ_d T/2 (``velocity_match``).
    Against ẋ_d itself the D term adds k ẍ_d T/2 — ω T = 8 % of the inertial force on hsm2 —
    which r does not see (α e cancels it) and adaptation cannot remove: a steady 8–18 µm
    RMS radial error on circles even on the ideal plant with the exact model (< 1 µm with it).

    Parameters: bandwidth_rad_s (ω), k (per axis, N s/m) and alpha (1/s) overriding it,
    coupling (c, per axis, N s/m) and kv_rho (per axis, N/m), tau_a_s (s), gamma = (γ_m, γ_b)
    (dimensionless multipliers of the rule's Γ; a None entry keeps 1), friction, normalize,
    velocity_match (switches), tuning_circle = (radius m, feed m/s) overriding the plant's.
    """

    name = "adaptive-ccc"
    COMPILED_LAW = "adaptive-ccc"
    # command-line parameters (``adaptive-ccc:gamma=0``; :mod:`agents.parameters`)
    PARAMETERS = {
        "w": Param(
            "bandwidth_rad_s", "feedback bandwidth ω, rad/s (default per plant)", check=">0"
        ),
        "k": Param("k", "feedback gain k, N s/m (default PD's D = 2 m ω − b)", AXES, ">0"),
        "alpha": Param(
            "alpha",
            "error weight α of r = ė + α e, 1/s (default (m ω² − 1)/k: α k + 1 = PD's P)",
            check=">=0",
        ),
        "c": Param(
            "coupling",
            "cross-coupling gain c of diag(c) v F R Fᵀ (x_d − x), N s/m (default k; on a circle "
            "(kv/ρ)_i = c_i v/ρ)",
            AXES,
            ">=0",
        ),
        "kv_rho": Param(
            "kv_rho",
            "Lee's eq. 39 coupling stiffness (kv/ρ)_i, N/m, constant in feed and radius "
            "(2 axes; SI, not Lee's servo units; sets the default c to 0)",
            AXES,
            ">=0",
        ),
        "tau_a": Param(
            "tau_a_s",
            "adaptation time constant τ_a on the plant's tuning circle, s (default 0.5)",
            check=">0",
        ),
        "gamma": Param(
            "gamma",
            "multiplier of every adaptation gain, γ_m = γ_b (default 1; 0: no adaptation)",
            check=">=0",
        ),
        "gamma_m": Param(
            "gamma_m",
            "mass adaptation multiplier γ_m: Γ_m = γ_m k / (τ_a ā²) (default 1)",
            check=">=0",
        ),
        "gamma_b": Param(
            "gamma_b",
            "friction adaptation multiplier γ_b: Γ_b = γ_b k / (τ_a v̄²), Γ_c = γ_b k / τ_a "
            "(default 1)",
            check=">=0",
        ),
        "friction": Param(
            "friction",
            "Coulomb friction f_c sgn(ẋ_d) in θ, from the nominal f_c (default true; false: "
            "Lee's θ = [m, b])",
            BOOL,
        ),
        "norm": Param(
            "normalize", "normalised adaptation, rate capped near 1/τ_a (default true)", BOOL
        ),
        "vmatch": Param(
            "velocity_match",
            "compare the backward-difference velocity with ẋ_d − ẍ_d T/2 (default true)",
            BOOL,
        ),
    }

    @classmethod
    def adapt_parameters(cls, kwargs: dict) -> dict:
        """Command-line ``gamma`` / ``gamma_m`` / ``gamma_b`` → ``gamma=(γ_m, γ_b)`` (None: the
        default multiplier 1)."""
        g, gm, gb = (kwargs.pop(k, None) for k in ("gamma", "gamma_m", "gamma_b"))
        if g is not None and (gm is not None or gb is not None):
            raise ValueError("give gamma (both gains) or gamma_m / gamma_b, not both")
        if g is not None:
            kwargs["gamma"] = (g, g)
        elif gm is not None or gb is not None:
            kwargs["gamma"] = (gm, gb)
        return kwargs

    def __init__(
        self,
        bandwidth_rad_s=None,
        k=None,
        alpha=None,
        gamma=None,
        coupling=None,
        kv_rho=None,
        tau_a_s=DEFAULT_TAU_A_S,
        friction=None,
        normalize=True,
        tuning_circle=None,
        velocity_match=True,
    ):
        super().__init__()
        self.bandwidth_rad_s = bandwidth_rad_s
        self._k_user, self._alpha_user = k, alpha
        self._gamma_user = gamma
        self._coupling_user, self._kv_rho_user = coupling, kv_rho
        self.tau_a_s = float(tau_a_s)
        if not (math.isfinite(self.tau_a_s) and self.tau_a_s > 0):
            raise ValueError(f"tau_a_s: must be > 0 seconds, got {tau_a_s!r}")
        self._friction_user = friction
        self.normalize = bool(normalize)
        self._tuning_circle_user = tuning_circle
        self.velocity_match = bool(velocity_match)

    def configure(self) -> None:
        m = self.nominal.mass_kg
        w = self.bandwidth_rad_s
        if w is None:
            # the plant's tuned PD ω (contour-env tune), else the table, else a warned fallback
            w = DEFAULT_BANDWIDTH_RAD_S.get(self.nominal.name)
            if w is None or tuned_gain(self.nominal, "pd", "bandwidth_rad_s") is not None:
                w, tuned = default_bandwidth(self.nominal)
                if not tuned:
                    warn_untuned(self.name, [f"ω = {w:g} rad/s"], self.nominal.name)
        if not (np.isfinite(w) and w > 0):
            raise ValueError(f"bandwidth_rad_s: must be > 0, got {w!r}")
        n = self.n_axes
        gamma = (1.0, 1.0) if self._gamma_user is None else tuple(self._gamma_user)
        if len(gamma) != 2:
            raise ValueError(f"gamma: two adaptation multipliers >= 0, got {gamma!r}")
        self.gamma = tuple(1.0 if g is None else float(g) for g in gamma)  # gamma_m=… only
        if any(not np.isfinite(g) or g < 0 for g in self.gamma):
            raise ValueError(f"gamma: two adaptation multipliers >= 0, got {gamma!r}")
        # Lee: "the existing PD controller is used for" eq. 38's proportional and derivative
        # terms, so k = PD's D = 2 m ω − b and α k + 1 = PD's P = m ω² (α = ω/2 where b = 0)
        b = self.nominal.viscous_Ns_m
        if self._k_user is None:
            self.k = np.maximum(2 * m * w - b, 0.2 * m * w)
        else:
            self.k = per_axis("k", self._k_user, n)
        if self._alpha_user is None:
            self.alpha = np.maximum(m * w**2 - 1.0, 0.0) / self.k
        else:
            self.alpha = np.full(n, float(self._alpha_user))
        self.kv_rho = np.zeros(n)
        if self._kv_rho_user is not None:
            if n != 2:
                raise ValueError(
                    "kv_rho: Lee's eq. 39 is the 2-axis form; on a 3-axis plant give the "
                    "coupling gains c"
                )
            self.kv_rho = per_axis("kv_rho", self._kv_rho_user, n)
        if self._coupling_user is not None:
            self.coupling = per_axis("coupling", self._coupling_user, n)
        else:
            self.coupling = np.zeros(n) if self._kv_rho_user is not None else self.k.copy()
        for label, v in (("coupling", self.coupling), ("kv_rho", self.kv_rho)):
            if np.any(v < 0):
                raise ValueError(f"{label}: must be >= 0 on every axis, got {v.tolist()}")
        coulomb = self.nominal.coulomb_N
        self.friction = True if self._friction_user is None else bool(self._friction_user)
        circle = self._tuning_circle_user or TUNING_CIRCLE.get(
            self.nominal.name, DEFAULT_TUNING_CIRCLE
        )
        self.tuning_circle = tuple(float(x) for x in circle)
        a2, v2 = tuning_excitation(*self.tuning_circle)
        # regressor columns per axis: ẍ_d, ẋ_d (Lee's θ = [m, b]) and sgn(ẋ_d) (f_c)
        columns = [m, self.nominal.viscous_Ns_m]
        self.mean_squares = [a2, v2]
        multipliers = list(self.gamma)
        if self.friction:
            columns.append(coulomb)
            self.mean_squares.append(1.0)
            multipliers.append(self.gamma[1])
        self.n_columns = len(columns)
        self.theta0 = np.concatenate(columns)
        G = adaptation_gains(self.k, self.tau_a_s, self.mean_squares)
        self.Gamma = (np.asarray(multipliers)[:, None] * G).reshape(-1)

    def reset(self, mask=None) -> None:
        if mask is None or not hasattr(self, "theta_hat"):
            self.theta_hat = np.tile(self.theta0, (self.n_envs, 1))
        else:
            self.theta_hat[mask] = self.theta0

    def _coupling_matrix(self, frame, curvature, torsion, feedrate):
        """(C, F R Fᵀ), each (B, A, A), with the coupling term = C (x_d − x):
        C = diag(c) v F R Fᵀ + diag(kv_rho) sgn(κ) J."""
        R = _R(curvature, torsion, self.n_axes)
        FRFt = np.einsum("bij,bjk,blk->bil", frame, R, frame)
        C = (self.coupling * feedrate[:, None])[:, :, None] * FRFt
        if np.any(self.kv_rho):
            J = np.array([[0.0, 1.0], [-1.0, 0.0]])
            C = C + np.sign(curvature)[:, None, None] * (self.kv_rho[:, None] * J)
        return C, FRFt

    def act(self, signals: dict) -> np.ndarray:
        """Eqs. 20, 26 and 38 (see the class docstring): the compiled law ``adaptive-ccc``
        (:func:`agents.compiled.laws.law`, the one definition the fused loops run too);
        θ̂ advances in ``theta_hat``.

        The measured velocity is a backward difference, (x_k − x_{k−1}) / T, i.e. the velocity
        half a period ago; with ``velocity_match`` it is compared with the reference's at the
        same instant (ẋ_d − ẍ_d T/2), or the D term adds k ẍ_d T/2 (ω T of the inertial force)
        that r cannot see (a steady radial error on a circle even with a perfect model)."""
        from .compiled.forms import run_law

        return run_law(self, "adaptive-ccc", signals)

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        """Eq. 38 without the feedforward (θ̂ frozen):
        u = diag(k) (Ė + α E) + (diag(c) v F R Fᵀ + diag(kv_rho) sgn(κ) J) E + E."""
        n = self.n_axes
        C, _ = self._coupling_matrix(
            np.asarray(frame, dtype=np.float64)[None],
            np.array([float(curvature)]),
            np.array([float(torsion)]),
            np.array([float(feedrate_m_s)]),
        )
        return np.diag(self.alpha * self.k + 1.0) + C[0], np.diag(self.k), np.zeros((n, n))
