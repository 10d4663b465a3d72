"""Recurrent fuzzy neural network (RFNN) contouring control (Chen & Lee 2020, eqs. 5–7, 13–23).

The network's output is a task-frame force correction on top of the PD loops (the project's
``pd`` gains for the plant), trained online, during the run, by back-propagation of
E = ½‖e‖² through the plant sensitivity; ``fnn`` is the same network without the recurrent
feedback (the paper's FNN, §4.3). The design choices the paper leaves open, and why, are in
the class docstring and in docs/RFNN.md.
"""

from __future__ import annotations

import math

import numpy as np

from .parameters import BOOL, INT, Param
from .pd import PDController

# Defaults (the reasons are in RFNNController's docstring and docs/RFNN.md). Tuned on tuning
# paths only (TUNING_PATH; scripts/tune_controllers.py's per plant), never on a named case or
# a test program: "never tune on what you score".
DEFAULT_RULES = 4  # 2 Gaussian sets per input (negative / positive) on a grid
# lr_w = η_w y_u² (dimensionless; eq. 23 needs < 2) per plant, from scripts/rfnn_tune.py
# --plants on each plant's tuning paths (never a named case): the grid value up to ω T / 4 with
# RMS effort within +10 % of PD on every axis and the lowest RMS contour error. The rule
# weights act as an integral of corner frequency ≈ lr_w Σψ² / T, and PD + integral
# (m s³ + D s² + P s + K_i) is stable for K_i < 2 m ω³, i.e. lr_w Σψ² < 2 ω T (Routh): the cap
# ω T / 4 is an eighth of that with one rule firing alone (Σψ² = 1). A looser cap (ω T / 2)
# let the friction table's fnn wind its weights up to the force limit on G-code programs with
# pauses. hsm2 stops at the effort limit (its y axis chatters from lr_w = 0.016 on).
DEFAULT_LR_W = {
    "linear-motor": 0.01,
    "hsm2": 0.01,
    "friction-table": 0.016,
    "jee-triaxial": 0.032,
}
#: a plant without a tuned rate gets LR_W_PER_OMEGA_T · ω T (half the cap above)
LR_W_PER_OMEGA_T = 0.125
# lr_theta = η_θ y_u² w_max² defaults to this fraction of what eq. 23 leaves after lr_w
LR_THETA_FRACTION = 0.2
DEFAULT_THETA0 = -1.0  # initial recurrent link weight θ_ij (dimensionless)
DEFAULT_W0_N = 0.0  # initial rule weight w_j (N): the network starts as "no correction"
DEFAULT_ERROR_SCALE_M = 10e-6  # e0: the network reads e / e0 and s / (2 α e0)
DEFAULT_WIDTH = 1.0  # σ of every Gaussian, in units of the centre spacing
INPUT_LIMIT = 3.0  # inputs clipped to ±3 (the outer centres are at ±1)
THETA_LIMIT = 1.0  # |θ_ij| ≤ 1 (projection; keeps the eq. 23 bound finite)
N_INPUTS = 2  # (e_p, s_p) per task-frame direction p

# --- options (issue 38; off by default: the shipped law is the paper's) -------------------
# instant=1: eq. 23 checked at every sample (the paper's Theorem 1 holds "∀ t_k") instead of
# a priori over every reachable state. The θ step of a sample is scaled down so that the
# sample's value lr_w Σψ² + lr_theta ‖∂y/∂θ‖² / w_max² stays ≤ EQ23_INSTANT_CAP: 1, the
# one-step optimum of the quadratic in the proof's ΔV (half the bound 2).
EQ23_INSTANT_CAP = 1.0
#: margin=1: the largest incremental stiffness the network may add along a task-frame
#: direction, in units of the PD's smallest stiffness P (κ of :func:`spread_limit`), per plant:
#: the largest κ of (0.25, 0.5, 0.75) for which the PD loops with P ± κ P_min and
#: D ± κ P_min / (3 α) (the network's linearisation at its steepest, both signs) keep the
#: project's margins, ≥ 6 dB / ≥ 30° over the ±20 % mass corners (agents.margins;
#: ``python scripts/rfnn_margin_bound.py`` derives the table, a test checks it). Below 1 on
#: every plant: the network can never cancel the PD's stiffness.
MARGIN_KAPPA = {
    "hsm2": 0.75,
    "linear-motor": 0.75,
    "friction-table": 0.75,
    "jee-triaxial": 0.25,
}
MARGIN_KAPPA_FALLBACK = 0.25  # a plant not in the table

#: The path the defaults were tuned on (linear motor; not a named case, not a test program):
#: a 100° arc of radius 0.25 m in a plane tilted 20° about y, 0.03 m/s.
TUNING_PATH = dict(radius_m=0.25, tilt_deg=20.0, sweep_deg=100.0, feedrate_m_s=0.03)


def _exp(x: np.ndarray) -> np.ndarray:
    """exp element by element with libm's ``math.exp`` — the function the compiled law calls.
    numpy's SIMD exp differs from it by one ulp for ~5 % of arguments, which would keep the
    compiled and Python runs from being identical to the bit."""
    flat = np.fromiter(map(math.exp, x.ravel()), dtype=np.float64, count=x.size)
    return flat.reshape(x.shape)


def grid_centres(n_rules: int, width: float) -> tuple[np.ndarray, np.ndarray]:
    """Centres m_ij and squared widths σ_ij² (each (2, R)) of a grid of k × k = R rules over
    the two normalised inputs: k centres per input equally spaced on [−1, 1] (0 for k = 1),
    σ = ``width`` × spacing (spacing 1 for k = 1). ``ValueError`` unless R is a square."""
    k = int(round(math.sqrt(n_rules)))
    if n_rules < 1 or k * k != n_rules:
        raise ValueError(
            f"rules: must be a square k² (k Gaussian sets per input on a grid: 1, 4, 9, 16, 25, "
            f"...), got {n_rules!r}"
        )
    levels = np.linspace(-1.0, 1.0, k) if k > 1 else np.zeros(1)
    spacing = 2.0 / (k - 1) if k > 1 else 1.0
    m = np.stack([np.repeat(levels, k), np.tile(levels, k)])  # rule j = (a, b) → (m_a, m_b)
    sigma = width * spacing
    return m, np.full((N_INPUTS, n_rules), sigma * sigma)


def theta_gradient_bound(centres: np.ndarray, sigma2: np.ndarray) -> float:
    """g_θ: a bound on ‖∂O⁽⁴⁾/∂θ‖² / w_max² over every state the network can reach.

    ∂y/∂θ_ij = −ψ_j (w_j − y) · 2 (u_ij − m_ij) O_ij(k−1) / σ_ij²; with |w_j|, |y| ≤ w_max
    (projection), O ≤ 1, |u_ij − m_ij| ≤ D = INPUT_LIMIT + THETA_LIMIT + max|m| and
    Σ_j ψ_j² ≤ 1, the squared norm over the N_INPUTS × R links is at most
    N_INPUTS (2 w_max)² (2 D / σ_min²)² = w_max² · 16 N_INPUTS D² / σ_min⁴."""
    D = INPUT_LIMIT + THETA_LIMIT + float(np.max(np.abs(centres)))
    return 16.0 * N_INPUTS * D * D / float(np.min(sigma2)) ** 2


def slope_bound(centres: np.ndarray, sigma2: np.ndarray, theta_limit: float) -> float:
    """c: |∂y/∂x_i| ≤ c (max_j w_j − min_j w_j) for each normalised input x_i, at every state.

    ∂ψ_j/∂x_i = ψ_j (a_ij − Σ_l ψ_l a_il) with a_ij = −2 (u_ij − m_ij) / σ_ij², so
    ∂y/∂x_i = Σ_j w_j ∂ψ_j/∂x_i is the covariance of w and a_i under the weights ψ, at most
    (Δw / 2)(Δa_i / 2) in magnitude (Δ: the range over the rules). u_ij − m_ij = x_i +
    θ_ij O_ij(k−1) − m_ij with |θ O| ≤ ``theta_limit`` (0 for the FNN), so
    Δa_i ≤ 2 (range_j m_ij + 2 theta_limit) / σ_min², and c = (range m + 2 theta_limit) /
    (2 σ_min²): 1/4 for the default 4-rule FNN (ψ of one input is then the logistic
    1 / (1 + e^{−x}), slope 1/4 at 0), 1/2 for the 4-rule RFNN, 1 for the 9-rule FNN."""
    span = float(np.max(np.ptp(centres, axis=1)))
    return (span + 2.0 * theta_limit) / (2.0 * float(np.min(sigma2)))


def spread_limit(kappa: float, P_min: float, e0: float, c: float) -> float:
    """The largest rule-weight spread max_j w_j − min_j w_j (N) whose steepest linearisation
    adds at most κ P_min of stiffness: with x = (e / e0, (ė + α e) / (2 α e0)),
    |∂y/∂e| ≤ c Δw (1 + 1/2) / e0 and |∂y/∂ė| ≤ c Δw / (2 α e0) = |∂y/∂e|_max / (3 α), so
    Δw ≤ κ P_min e0 / (1.5 c) (∞ when κ = 0 or c = 0: no bound, or a network without slope)."""
    if kappa <= 0.0 or c <= 0.0:
        return math.inf
    return kappa * P_min * e0 / (1.5 * c)


def eq23_value(lr_w: float, lr_theta: float, g_theta: float) -> float:
    """Chen & Lee 2020 eq. 23, η_w y_u² ‖∂O⁽⁴⁾/∂w‖² + η_θ y_u² ‖∂O⁽⁴⁾/∂θ‖², at its largest:
    ‖∂O⁽⁴⁾/∂w‖² = Σ ψ_j² ≤ 1 and ‖∂O⁽⁴⁾/∂θ‖² ≤ w_max² g_θ, so the value is
    lr_w + lr_theta · g_θ (lr_w = η_w y_u², lr_theta = η_θ y_u² w_max²). Convergence needs it
    in (0, 2)."""
    return lr_w + lr_theta * g_theta


class RFNNController(PDController):
    """PD axial loops plus an RFNN task-frame force correction learnt online (Chen & Lee 2020).

    **Network** (§2.2, one per task-frame direction p = t, n (, b), two inputs each, as the
    one-dimensional case of Theorem 1). Inputs x = (e_p / e0, s_p / s0), clipped to ±3, with
    the task-frame error e = Fᵀ(x − x_d) (the paper's e = x_f − x_fd; the measured position)
    and s = ė + α e (§3), ė = Fᵀ(ẋ − ẋ_d) from the measured (backward-difference) velocity.
    Layer 2, Gaussian memberships with the recurrent input (eqs. 5, 6):

        u_ij(k) = x_i(k) + O_ij(k−1) θ_ij,   O_ij(k) = exp(−(u_ij − m_ij)² / σ_ij²);

    layer 3, product rules O_j = Π_i O_ij; layer 4, the normalised output (eq. 7)
    y_p = Σ_j w_j ψ_j, ψ_j = O_j / Σ_l O_l. The command is u = u_PD + F y (F = [t n (b)]:
    the task-frame force F̄ = y of eq. 13 mapped to the axes, F_c = F F̄_c).

    **Learning** (eqs. 14–19), every servo period, on E = ½‖e‖² with the plant sensitivity
    y_u = ∂e/∂F̄: the quasi-static one of the PD-closed loop, y_u = 1 / P (m/N; a constant
    force offset moves the axis by F/P), with P the smallest PD stiffness of the axes:

        w_j ← w_j − η_w e y_u ψ_j,
        θ_ij ← θ_ij − η_θ e y_u ∂y/∂θ_ij,
        ∂y/∂θ_ij = −ψ_j (w_j − y) 2 (u_ij − m_ij) O_ij(k−1) / σ_ij²

    (the exact gradient of the normalised output of eq. 7 — the paper's eq. 19 drops the
    normalisation — with O(k−1) held, as in eq. 19). Centres and widths stay fixed (the paper
    tunes W = [θ, w] only). Rule weights are projected on |w| ≤ w_max (the smallest force
    limit) and θ on |θ| ≤ THETA_LIMIT.

    **Learning rates and eq. 23.** The rates are given as the dimensionless products of
    eq. 23: ``lr_w`` = η_w y_u² and ``lr_theta`` = η_θ y_u² w_max². With the bounds
    ‖∂O⁽⁴⁾/∂w‖² = Σ ψ_j² ≤ 1 and ‖∂O⁽⁴⁾/∂θ‖² ≤ w_max² g_θ (:func:`theta_gradient_bound`) eq. 23
    holds at every instant when lr_w + lr_theta g_θ < 2; a configuration outside it is refused
    (``ValueError`` stating the bound). The rates that work are far inside it (the bound is the
    paper's one-step quasi-static argument; the loop's time scale sets the useful rate): the
    rule weights are an integral action of corner frequency ≈ lr_w Σψ² / T, so lr_w is capped
    at ω T / 4 (an eighth of the Routh limit of PD + integral with one rule firing alone)
    and chosen per plant on tuning paths (:data:`DEFAULT_LR_W`); lr_theta defaults to 20 % of
    what the bound leaves after lr_w.

    **Parameter choices** (scripts/rfnn_tune.py; on tuning paths, never on a named case): R = 4
    rules (2 sets per input, negative / positive; a cost of 2 R exp per direction and sample. On
    :data:`TUNING_PATH` at lr_w = 0.04, θ0 = −1 the RMS contour error was 0.268 µm with 1 rule —
    a plain adaptive integral, where rfnn and fnn coincide —, 0.518 µm with 4, 0.675 µm with 9:
    four is the fewest that leaves the recurrence something to do), centres ±1 of the normalised
    inputs, σ = the spacing (2), e0 = 10 µm (the PD's error on the linear motor is 10–25 µm), s0
    = 2 α e0, α = the PD's bandwidth ω (s = ė + ω e is the PD's slow closed-loop mode), initial
    w = 0 (the network starts as no correction, so ``learn=0`` is the PD loop it sits on) and θ0
    = −1 (the recurrent term's best on the tuning path: 9 % below the FNN's RMS; θ0 = +0.5 was
    worse than the FNN). Within the a-priori eq. 23 bound θ hardly moves (max |Δθ| = 4·10⁻³
    over lm-circle3d): the bound covers every reachable state (|w_j − y| up to 2 w_max), ~10²
    above the per-sample value a run meets, so the recurrent network's effect comes from θ0
    (docs/RFNN.md, "Ablations").

    **Options (issue 38; off by default, the shipped law is the one above).** ``instant=1``
    checks eq. 23 at every sample, as Theorem 1 states it ("∀ t_k"), instead of a priori: any
    lr_theta is accepted and a sample's θ step is scaled down so that its eq. 23 value stays
    ≤ :data:`EQ23_INSTANT_CAP`; θ then learns (``rfnn:theta0=0:instant=1:lr_theta=80``).
    ``margin=1`` (or ``kappa=κ``) bounds the rule weights' spread per direction by
    :func:`spread_limit`, so that the network's steepest slope adds at most κ P_min of
    stiffness (κ from the loop margins, :data:`MARGIN_KAPPA`): without it the network learns a
    slope of ~10 P near e = 0 on hsm2 and the normal loop chatters at 70–80 Hz. Both are part
    of the compiled law; ``eq23_peak`` records the largest per-sample eq. 23 value since the
    last ``reset`` (NaN before the network has learnt), on every path.

    **Across episodes.** ``reset`` starts the network afresh (w = w0, θ = θ0, no memory);
    with ``keep=True`` it keeps the learnt w and θ and clears only the recurrent memory
    O(k−1), so a repeated batch (:func:`agents.repeated_batch.run_batch`) goes on learning from
    trial to trial.

    Parameters: bandwidth_rad_s, damping, P, D as :class:`PDController`; n_rules (R, a square),
    lr_w, lr_theta (dimensionless, eq. 23), alpha (1/s, default ω), error_scale_m (e0, m),
    width (σ per centre spacing), theta0, w0_N (N), online_update (``learn=``), keep,
    eq23_instant (``instant=``), margin_bound (``margin=``) (switches), kappa (≥ 0, explicit κ).
    """

    name = "rfnn"
    COMPILED_LAW = "rfnn"
    # the compiled law reads them here
    INPUT_LIMIT, THETA_LIMIT, EQ23_INSTANT_CAP = INPUT_LIMIT, THETA_LIMIT, EQ23_INSTANT_CAP
    recurrent = True
    PARAMETERS = {
        **PDController.PARAMETERS,
        "rules": Param(
            "n_rules", "rule count R = k² (k Gaussian sets per input; default 4)", INT, ">0"
        ),
        "lr_w": Param(
            "lr_w",
            "rule-weight learning rate η_w y_u², dimensionless (eq. 23: < 2; default per plant, "
            "0.01 on the linear motor)",
            check=">=0",
        ),
        "lr_theta": Param(
            "lr_theta",
            "recurrent-weight learning rate η_θ y_u² w_max², dimensionless (eq. 23; default "
            "20 % of what the bound leaves after lr_w)",
            check=">=0",
        ),
        "alpha": Param("alpha", "α of s = ė + α e, 1/s (default the PD's ω)", check=">0"),
        "e0": Param(
            "error_scale_m",
            "error scale e0 of the inputs e/e0, s/(2 α e0), m (default 1e-5)",
            check=">0",
        ),
        "width": Param("width", "Gaussian width σ per centre spacing (default 1)", check=">0"),
        "theta0": Param("theta0", "initial recurrent link weight θ_ij, |θ0| <= 1 (default -1)"),
        "w0": Param("w0_N", "initial rule weight w_j, N (default 0)"),
        "learn": Param(
            "online_update", "online update of w and θ (default true; 0: fixed network)", BOOL
        ),
        "keep": Param(
            "keep",
            "keep the learnt network across episodes (repeated batches; default false)",
            BOOL,
        ),
        "instant": Param(
            "eq23_instant",
            "check eq. 23 at every sample instead of over every reachable state: lr_theta is "
            "not limited at configuration, a sample's θ step is scaled to keep eq. 23 <= 1 "
            "(default false)",
            BOOL,
        ),
        "margin": Param(
            "margin_bound",
            "bound the rule weights' spread so that the network's steepest slope adds at most "
            "the plant's margin-derived stiffness (MARGIN_KAPPA; default false)",
            BOOL,
        ),
        "kappa": Param(
            "kappa",
            "that bound with an explicit κ: added stiffness <= κ x the PD's smallest P "
            "(default 0: none)",
            check=">=0",
        ),
    }

    def __init__(
        self,
        n_rules=DEFAULT_RULES,
        lr_w=None,
        lr_theta=None,
        alpha=None,
        error_scale_m=DEFAULT_ERROR_SCALE_M,
        width=DEFAULT_WIDTH,
        theta0=DEFAULT_THETA0,
        w0_N=DEFAULT_W0_N,
        online_update=True,
        keep=False,
        eq23_instant=False,
        margin_bound=False,
        kappa=None,
        **pd_kwargs,
    ):
        super().__init__(**pd_kwargs)
        if isinstance(n_rules, bool) or not isinstance(n_rules, (int, np.integer)):
            raise ValueError(f"rules: must be an integer square k² (1, 4, 9, ...), got {n_rules!r}")
        self.n_rules = int(n_rules)
        for label, v, rule in (
            ("lr_w", 0.0 if lr_w is None else lr_w, ">= 0"),
            ("lr_theta", 0.0 if lr_theta is None else lr_theta, ">= 0"),
            ("error_scale_m", error_scale_m, "> 0 m"),
            ("width", width, "> 0"),
            ("w0_N", w0_N, "finite"),
            ("theta0", theta0, f"in [-{THETA_LIMIT:g}, {THETA_LIMIT:g}]"),
        ):
            try:
                v = float(v)
            except (TypeError, ValueError):
                raise ValueError(f"{label}: must be a number {rule}, got {v!r}") from None
            ok = math.isfinite(v) and {
                ">= 0": v >= 0,
                "> 0 m": v > 0,
                "> 0": v > 0,
                "finite": True,
            }.get(rule, abs(v) <= THETA_LIMIT)
            if not ok:
                raise ValueError(f"{label}: must be a number {rule}, got {v!r}")
        if alpha is not None and not (math.isfinite(float(alpha)) and float(alpha) > 0):
            raise ValueError(f"alpha: must be > 0 1/s, got {alpha!r}")
        if kappa is not None and not (math.isfinite(float(kappa)) and float(kappa) >= 0):
            raise ValueError(f"kappa: must be a number >= 0, got {kappa!r}")
        self.eq23_instant = bool(eq23_instant) and self.recurrent
        self.margin_bound = bool(margin_bound)
        self._kappa_user = None if kappa is None else float(kappa)
        self._lr_w_user = None if lr_w is None else float(lr_w)
        self._lr_theta_user = None if lr_theta is None else float(lr_theta)
        self._alpha_user = alpha
        self.error_scale_m = float(error_scale_m)
        self.width = float(width)
        self.theta0 = float(theta0) if self.recurrent else 0.0
        self.w0_N = float(w0_N)
        # not ``learn``: that name is the between-trials hook of agents.repeated_batch
        self.online_update = bool(online_update)
        self.keep = bool(keep)
        self.centres, self.sigma2 = grid_centres(self.n_rules, self.width)
        # reciprocals: the law multiplies (a division costs several multiplications)
        self.inv_sigma2 = 1.0 / self.sigma2
        self.g_theta = theta_gradient_bound(self.centres, self.sigma2)
        self.slope_c = slope_bound(
            self.centres, self.sigma2, THETA_LIMIT if self.recurrent else 0.0
        )
        self.eq23_peak = math.nan
        # a rate given explicitly is checked now, the plant-derived ones when bound
        self._set_rates(self._lr_w_user if self._lr_w_user is not None else 0.0)

    def _set_rates(self, lr_w: float) -> None:
        """lr_w, lr_theta from the user's values or the defaults, checked against eq. 23."""
        self.lr_w = float(lr_w)
        if not self.recurrent:
            self.lr_theta = 0.0
        elif self._lr_theta_user is not None:
            self.lr_theta = self._lr_theta_user
        else:
            self.lr_theta = LR_THETA_FRACTION * max(2.0 - self.lr_w, 0.0) / self.g_theta
        # per sample (instant=1): only lr_w is limited a priori (Σψ² ≤ 1), lr_theta per sample
        value = eq23_value(self.lr_w, 0.0 if self.eq23_instant else self.lr_theta, self.g_theta)
        if value >= 2.0:
            raise ValueError(
                f"lr_w, lr_theta: outside the convergence bound of Chen & Lee 2020 eq. 23: "
                f"lr_w·‖∂y/∂w‖² + lr_theta·‖∂y/∂θ‖²/w_max² ≤ lr_w + lr_theta·{self.g_theta:.4g} "
                f"= {value:.4g}, must be < 2 (lr_w < 2; lr_theta < (2 − lr_w)/{self.g_theta:.4g} "
                f"= {max(2.0 - self.lr_w, 0.0) / self.g_theta:.4g} with R = {self.n_rules} "
                f"rules, width {self.width:g})"
            )

    def configure(self) -> None:
        super().configure()
        if self._lr_w_user is None:
            fallback = LR_W_PER_OMEGA_T * self.omega * self.servo_period_s
            self._set_rates(DEFAULT_LR_W.get(self.nominal.name, fallback))
        else:
            self._set_rates(self._lr_w_user)
        self.alpha = float(self.omega if self._alpha_user is None else self._alpha_user)
        self.input_scale = np.array([self.error_scale_m, 2.0 * self.alpha * self.error_scale_m])
        self.inv_input_scale = 1.0 / self.input_scale
        # y_u = 1 / P: the quasi-static sensitivity of the PD-closed loop (the largest over
        # the axes), m/N; w_max: the smallest force limit (the correction acts along any
        # task-frame direction)
        self.sensitivity_m_N = 1.0 / float(np.min(self.P))
        self.w_max = float(np.min(self.force_limit))
        # the per-sample update factors: Δw = −k_w e ψ, Δθ = −k_θ e ∂y/∂θ
        self.k_w = self.lr_w / self.sensitivity_m_N
        self.k_theta = self.lr_theta / self.sensitivity_m_N / (self.w_max * self.w_max)
        # the spread bound (margin=1 / kappa=κ; off by default)
        if self._kappa_user is not None:
            self.kappa = self._kappa_user
        elif self.margin_bound:
            self.kappa = MARGIN_KAPPA.get(self.nominal.name, MARGIN_KAPPA_FALLBACK)
        else:
            self.kappa = 0.0
        self.spread_max_N = spread_limit(
            self.kappa, 1.0 / self.sensitivity_m_N, self.error_scale_m, self.slope_c
        )

    def reset(self, mask=None) -> None:
        B, A, R = self.n_envs, self.n_axes, self.n_rules
        # the largest per-sample eq. 23 value of the episode (NaN until the network learns)
        self.eq23_peak = math.nan
        fresh = mask is None or not hasattr(self, "w") or self.w.shape[0] != B
        if fresh and (not self.keep or not hasattr(self, "w") or self.w.shape[0] != B):
            self.w = np.full((B, A, R), self.w0_N)
            self.theta = np.full((B, A, N_INPUTS, R), self.theta0)
            self.memory = np.zeros((B, A, N_INPUTS, R))  # O_ij(k−1)
            return
        sel = slice(None) if mask is None else mask
        self.memory[sel] = 0.0
        if not self.keep:
            self.w[sel] = self.w0_N
            self.theta[sel] = self.theta0

    def network(self, x: np.ndarray, memory: np.ndarray, theta: np.ndarray, w: np.ndarray):
        """One forward pass (eqs. 5–7) for inputs ``x`` (..., 2) (normalised), the memory
        O(k−1) and θ (..., 2, R), the weights w (..., R). Returns (y (...), ψ (..., R),
        O (..., 2, R), u − m (..., 2, R))."""
        R = self.n_rules
        d = (x[..., None] + memory * theta) - self.centres  # u_ij − m_ij (eq. 6)
        O2 = _exp(-(d * d * self.inv_sigma2))  # eq. 5: exp(−(u − m)² / σ²)
        O3 = O2[..., 0, :] * O2[..., 1, :]  # product rules
        S = O3[..., 0]
        for j in range(1, R):
            S = S + O3[..., j]
        psi = O3 * (1.0 / S)[..., None]
        y = w[..., 0] * psi[..., 0]
        for j in range(1, R):
            y = y + w[..., j] * psi[..., j]  # eq. 7
        return y, psi, O2, d

    def theta_gradient(self, psi, w, y, d, memory) -> np.ndarray:
        """∂y/∂θ_ij = −ψ_j (w_j − y) · 2 (u_ij − m_ij) O_ij(k−1) / σ_ij², shape (..., 2, R)."""
        a = psi * (w - y[..., None])
        return -a[..., None, :] * (2.0 * d * memory * self.inv_sigma2)

    def task_errors(self, signals: dict) -> tuple[np.ndarray, np.ndarray]:
        """(e, ė), each (B, A): Fᵀ(x − x_d) and Fᵀ(ẋ − ẋ_d) from the measured signals."""
        F = signals["frame"]
        E = signals["reference_position"] - signals["measured_position"]
        Ed = signals["reference_velocity"] - signals["measured_velocity"]
        se = F[:, 0, :] * E[:, 0:1]
        sd = F[:, 0, :] * Ed[:, 0:1]
        for i in range(1, self.n_axes):
            se = se + F[:, i, :] * E[:, i : i + 1]
            sd = sd + F[:, i, :] * Ed[:, i : i + 1]
        return -se, -sd

    def network_inputs(self, signals: dict) -> np.ndarray:
        """The normalised inputs x (B, A, 2) the network reads this sample: per task-frame
        direction (e / e0, s / s0) clipped to ±INPUT_LIMIT, with (e, ė) of
        :meth:`task_errors` and s = ė + α e. For analysis (with :meth:`network` and the
        state ``memory``, ``theta``, ``w`` held before :meth:`act`); the law itself is
        compiled."""
        e, de = self.task_errors(signals)
        s = de + self.alpha * e
        lim = INPUT_LIMIT
        return np.stack(
            [
                np.clip(e * self.inv_input_scale[0], -lim, lim),
                np.clip(s * self.inv_input_scale[1], -lim, lim),
            ],
            axis=-1,
        )

    def act(self, signals: dict) -> np.ndarray:
        """PD plus the network's task-frame force F y, and one learning step (eqs. 5–7,
        14–19, with the options ``instant`` and ``margin`` / ``kappa``): the compiled law
        ``rfnn`` (:func:`agents.compiled.laws.law`, the one definition the fused loops run
        too); the network's state (``w``, ``theta``, ``memory``) and ``eq23_peak`` advance."""
        from .compiled.forms import run_law

        return run_law(self, "rfnn", signals)

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        raise ValueError(
            f"controller {self.name!r}: no linear feedback model for loop analysis (a learning "
            "network; its PD part is `pd`)"
        )


class FNNController(RFNNController):
    """The RFNN without the recurrent feedback (Chen & Lee 2020 §4.3: "FNN is a special case
    of RFNN without feedback layer"): u_ij = x_i, only the rule weights w learn."""

    name = "fnn"
    COMPILED_LAW = "rfnn"  # the RFNN law with θ = 0 and no recurrence
    recurrent = False
    PARAMETERS = {
        k: v
        for k, v in RFNNController.PARAMETERS.items()
        if k not in ("lr_theta", "theta0", "instant")
    }

    def __init__(self, **kwargs):
        for key in ("lr_theta", "theta0", "eq23_instant"):
            if kwargs.get(key):
                raise ValueError(f"{key}: the fnn has no recurrent links (use rfnn)")
        super().__init__(**kwargs)
