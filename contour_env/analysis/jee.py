"""Jee & Lee (2007) analysis of a P axial position loop on velocity-loop-closed feed drives.

What is computed (equation numbers are the paper's, ``/work/shared/papers/001_*``):

1. **Axis model, eq. (9).** Every axis of a plant ``m ẍ + b ẋ = u`` is ``G(s) = K/(s(τs+1))``
   with ``K = 1/b`` and ``τ = m/b`` (Jee's velocity-command drives are stored as m = τ/K,
   b = 1/K). Its zero-order-hold discretisation with period T is

       G_i(z) = (H1_i z + H0_i) / ((z − 1)(z − r_i)),
       H1 = K (T − τ + τ r),  H0 = K (τ − τ r − T r),  r = exp(−T/τ).

   The same algebra holds for a force-input axis (``input_kind == "force"``): K = 1/b in
   m/(N s), τ = m/b in s, and K_P is then in N/m. H1 and H0 are evaluated in a form that stays
   accurate for T ≪ τ (b → 0), where they tend to T²/(2m), the double-integrator limit.

2. **Stability, eqs. (16)–(17).** With a P axial controller u = K_P (x_ref − x) the closed
   loop of one axis has the characteristic polynomial

       Ω1(z) = (z − 1)(z − r) + K_P (H1 z + H0) = z² + a1 z + a0,
       a1 = K_P H1 − (1 + r),   a0 = r + K_P H0.

   Jury's criterion for a monic second-order polynomial is the three conditions
   Ω1(1) > 0, Ω1(−1) > 0 and |a0| < 1, i.e.

       K_P (H1 + H0) > 0                      → K_P > 0            (H1 + H0 = K T (1 − r) > 0)
       2 (1 + r) − K_P (H1 − H0) > 0          → K_P < 2 (1 + r)/(H1 − H0)   (H1 ≥ H0 always)
       1 − r − K_P H0 > 0                     → K_P < (1 − r)/H0             (eq. 17)
       1 + r + K_P H0 > 0                     → K_P > −(1 + r)/H0

   For Jee's Table 1 the binding upper limit is eq. (17) on the x axis: K_P < 16.6399
   (the paper: 0 ≤ K_P ≤ 16.64). The Ω1(−1) condition only binds when T is comparable with τ.

3. **Confirmation by simulation.** The same P loop is closed around the plant's own step
   (:class:`contour_env.plants.Plant`, exact ZOH integration) for a small position step at
   0.98 and 1.02 times the limit; the envelope of the error decays below and grows above.

4. **Steady state on a circle, eqs. (20)–(31).** With the closed loop of each axis
   ``H_i(z) = K_P G_i(z) / (1 + K_P G_i(z))`` (eq. 21 with G_C = 0) and the reference
   ``R(t) = R0 (u cos ωt + v sin ωt)`` (eq. 22) the steady-state position is
   ``P(k) = Re{L e^{jωkT}}``, ``L = R0 H(e^{jωT}) (u − j v)`` (eqs. 24–27).

   *Matched axes* (H_i = H): ``L = R0 H (u − jv)``, so ``P(k)`` is the reference circle
   scaled by |H| and rotated back by ∠H: a circle of radius R0 |H|. Eq. (28)–(29) give
   ``ε = ‖a‖ − R0 = R0 (|H(e^{jωT})| − 1)`` — the radial deviation, here written
   ``R0 | |H| − 1 |``. The lag d of eqs. (18) and (32) is the (non-integer) number of
   periods by which P(k) trails the reference, ``d = −∠H/(ωT)``: the point R(k − d) is the
   foot of the normal from P(k) to the circle, so ε of eq. (18) is purely radial and its
   magnitude does not depend on d. The tracking error of eqs. (30)–(31) is
   ``E = R0 |1 − H(e^{jωT})|`` (constant around the circle).

   *Unmatched axes*: ``P(θ) = Re{R0 diag(H_i)(u − jv) e^{jθ}}`` is an ellipse-like orbit
   (eq. 28 with a^T b ≠ 0). The predicted maximum contour error is computed numerically as
   the maximum over θ of the true distance from P(θ) to the reference circle (in-plane radial
   deviation and out-of-plane offset), and the maximum tracking error as the maximum of
   ‖R(θ) − P(θ)‖. Both are compared with a simulation of the plant on the circle over one
   revolution after the transient has died out.

All quantities are SI (m, s); contour and tracking errors in the report are in µm.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import signal

from contour_env.plants import Plant, PlantParams

__all__ = [
    "DEFAULT_FEEDRATES_M_S",
    "AxisModel",
    "axial_gain_limit",
    "axis_models",
    "discretize_axis",
    "format_stability_report",
    "jury_conditions",
    "jury_stable",
    "simulate_circle",
    "simulate_step_response",
    "stability_report",
    "steady_state_prediction",
]

#: 5, 10 and 20 m/min (Jee 2007's 3-D circle runs at 10 m/min).
DEFAULT_FEEDRATES_M_S = (5.0 / 60.0, 10.0 / 60.0, 20.0 / 60.0)
#: Default K_P as a fraction of the Jury limit: a gain margin of 2 (6 dB).
DEFAULT_KP_FRACTION = 0.5
#: Factors of the limit at which the simulation confirms the bound.
SIM_FACTORS = (0.98, 1.02)
#: Saturation of the simulated plant is lifted to this (the analysis is linear).
_NO_SATURATION = 1e30


# --------------------------------------------------------------------------- axis model (eq. 9)


def _g1_over_x2(x: float) -> float:
    """(x − 1 + e^{−x}) / x², accurate for small x (series) and large x."""
    if x < 1e-3:
        return 0.5 - x / 6.0 + x**2 / 24.0 - x**3 / 120.0 + x**4 / 720.0
    return (x + math.expm1(-x)) / x**2


def _g0_over_x2(x: float) -> float:
    """(1 − e^{−x} − x e^{−x}) / x², accurate for small x (series) and large x."""
    if x < 1e-3:
        return 0.5 - x / 3.0 + x**2 / 8.0 - x**3 / 30.0 + x**4 / 144.0
    return (-math.expm1(-x) - x * math.exp(-x)) / x**2


def discretize_axis(mass: float, viscous: float, servo_period_s: float) -> dict:
    """Jee eq. (9) for one axis ``m ẍ + b ẋ = u``: K = 1/b, τ = m/b, r, H1, H0.

    ``H1 = K (T − τ + τ r)``, ``H0 = K (τ − τ r − T r)``, ``r = exp(−T/τ)``, evaluated as
    ``H = (T²/m) g(T/τ)/(T/τ)²`` with series for small T/τ (no cancellation when b → 0).
    Returns a dict with K, tau, r, one_minus_r, H1, H0 (floats).
    """
    m, b, T = float(mass), float(viscous), float(servo_period_s)
    if not (math.isfinite(m) and m > 0):
        raise ValueError(f"mass: must be a finite value > 0, got {mass}")
    if not (math.isfinite(b) and b > 0):
        raise ValueError(
            f"viscous: Jee eq. (9) needs viscous friction b > 0 (K = 1/b, τ = m/b), got {viscous}; "
            "a pure mass under P control has no stable gain (the limit 2b/T tends to 0)"
        )
    if not (math.isfinite(T) and T > 0):
        raise ValueError(f"servo_period: must be a finite value > 0 (s), got {servo_period_s}")
    x = T * b / m  # T/τ
    scale = T * T / m
    return {
        "K": 1.0 / b,
        "tau": m / b,
        "r": math.exp(-x),
        "one_minus_r": -math.expm1(-x),
        "H1": scale * _g1_over_x2(x),
        "H0": scale * _g0_over_x2(x),
    }


# --------------------------------------------------------------------------- Jury criterion


def jury_conditions(kp: float, H1: float, H0: float, r: float, one_minus_r: float | None = None):
    """The three Jury conditions of Ω1(z) = z² + a1 z + a0 (eq. 16) at gain ``kp``.

    Returns a dict of margins (stable iff all are > 0): ``omega1_at_1`` = Ω1(1),
    ``omega1_at_minus1`` = Ω1(−1), ``one_minus_a0`` = 1 − a0, ``one_plus_a0`` = 1 + a0.
    """
    omr = (1.0 - r) if one_minus_r is None else one_minus_r
    return {
        "omega1_at_1": kp * (H1 + H0),
        "omega1_at_minus1": 2.0 * (1.0 + r) - kp * (H1 - H0),
        "one_minus_a0": omr - kp * H0,
        "one_plus_a0": 1.0 + r + kp * H0,
    }


def jury_stable(coeffs: Sequence[float]) -> bool:
    """Jury's stability test of a real polynomial (coefficients highest power first).

    True iff every root lies strictly inside the unit circle. Necessary conditions
    P(1) > 0, (−1)^n P(−1) > 0, |a_0| < a_n, then the rows of Jury's table
    ``b_k = a_0 a_k − a_n a_{n−k}`` with |b_0| > |b_{n−1}| down to three entries.
    """
    a = np.trim_zeros(np.asarray(coeffs, dtype=np.float64), "f")
    if a.size == 0 or not np.all(np.isfinite(a)):
        raise ValueError(f"coeffs: need finite coefficients, got {list(coeffs)}")
    n = a.size - 1
    if n == 0:
        return True
    if a[0] < 0:
        a = -a
    asc = a[::-1]  # a_0 .. a_n
    if not (np.polyval(a, 1.0) > 0 and (-1) ** n * np.polyval(a, -1.0) > 0):
        return False
    if not abs(asc[0]) < asc[-1]:
        return False
    row = asc
    while row.size > 3:
        m = row.size - 1
        b = row[0] * row[:m] - row[-1] * row[m:0:-1]
        if not abs(b[0]) > abs(b[-1]):
            return False
        row = b
    return True


@dataclass(frozen=True)
class AxisModel:
    """One axis in Jee's form (eq. 9) and its Jury range of K_P (eqs. 16–17).

    Attributes: name, mass, viscous (the plant's nominal m, b), servo_period_s, K = 1/b,
    tau = m/b, r = exp(−T/τ), one_minus_r, H1, H0.
    """

    name: str
    mass: float
    viscous: float
    servo_period_s: float
    K: float
    tau: float
    r: float
    one_minus_r: float
    H1: float
    H0: float

    @classmethod
    def from_mass_viscous(cls, name: str, mass: float, viscous: float, servo_period_s: float):
        try:
            d = discretize_axis(mass, viscous, servo_period_s)
        except ValueError as exc:
            raise ValueError(f"{exc} (axis {name})") from None
        return cls(name, float(mass), float(viscous), float(servo_period_s), **d)

    # transfer functions -------------------------------------------------------------------
    def open_loop(self) -> signal.dlti:
        """G_i(z) of eq. (9) as a scipy dlti (input u, output position)."""
        den = np.polymul([1.0, -1.0], [1.0, -self.r])
        return signal.dlti([self.H1, self.H0], den, dt=self.servo_period_s)

    def characteristic(self, kp: float) -> np.ndarray:
        """Ω1(z) = (z − 1)(z − r) + K_P (H1 z + H0) (eq. 16), coefficients [1, a1, a0]."""
        return np.array([1.0, kp * self.H1 - (1.0 + self.r), self.r + kp * self.H0])

    def closed_loop(self, kp: float) -> signal.dlti:
        """H_i(z) = K_P G_i / (1 + K_P G_i) (eq. 21 with G_C = 0), x_ref → x."""
        return signal.dlti(
            [kp * self.H1, kp * self.H0], self.characteristic(kp), dt=self.servo_period_s
        )

    def closed_loop_response(self, kp: float, omega_rad_s: float) -> complex:
        """H_i(e^{jωT}) via scipy.signal.dfreqresp."""
        _, h = signal.dfreqresp(self.closed_loop(kp), w=[omega_rad_s * self.servo_period_s])
        return complex(h[0])

    # Jury ---------------------------------------------------------------------------------
    def jury(self, kp: float) -> dict:
        """The Jury margins of Ω1 at ``kp`` (all > 0 ⇔ stable)."""
        return jury_conditions(kp, self.H1, self.H0, self.r, self.one_minus_r)

    def kp_limits(self) -> dict:
        """Bound on K_P from each Jury condition (None where a condition gives no bound)."""
        return {
            "omega1_at_1_lower": 0.0,  # K_P (H1 + H0) > 0 with H1 + H0 = K T (1 − r) > 0
            "omega1_at_minus1_upper": (
                2.0 * (1.0 + self.r) / (self.H1 - self.H0) if self.H1 > self.H0 else None
            ),
            "eq17_upper": self.one_minus_r / self.H0,
            "one_plus_a0_lower": -(1.0 + self.r) / self.H0,
        }

    def kp_interval(self) -> tuple[float, float]:
        """Open interval (lo, hi) of K_P for which Ω1 has both roots inside the unit circle."""
        lim = self.kp_limits()
        lo = max(lim["omega1_at_1_lower"], lim["one_plus_a0_lower"])
        uppers = [v for k, v in lim.items() if k.endswith("_upper") and v is not None]
        return lo, min(uppers)

    def binding_condition(self) -> str:
        lim = self.kp_limits()
        hi = self.kp_interval()[1]
        return "eq17_upper" if lim["eq17_upper"] == hi else "omega1_at_minus1_upper"

    def describe(self) -> dict:
        lo, hi = self.kp_interval()
        return {
            "name": self.name,
            "mass": self.mass,
            "viscous": self.viscous,
            "K": self.K,
            "tau": self.tau,
            "r": self.r,
            "H1": self.H1,
            "H0": self.H0,
            "kp_interval": [lo, hi],
            "kp_limits": self.kp_limits(),
            "binding_condition": self.binding_condition(),
        }


# --------------------------------------------------------------------------- plant resolution


def _make_plant(plant, plant_kw: dict) -> Plant:
    if isinstance(plant, Plant):
        if plant_kw:
            raise ValueError(
                f"plant_kw: a Plant instance takes no further arguments, got {sorted(plant_kw)}"
            )
        return plant
    kw = {"ideal": True, **plant_kw}
    return Plant(plant, **kw)


def _check_linear_model(p: PlantParams) -> None:
    if p.computation_delay:
        raise ValueError(
            "computation_delay: Jee eq. (9) has no computation delay; analyse a plant with "
            "computation_delay=False"
        )
    if np.any(p.current_loop_time_constant_s > 0):
        raise ValueError(
            "current_loop_time_constant: Jee eq. (9) is second order; analyse a plant without "
            "a current-loop lag"
        )
    if p.has_structural_mode:
        raise ValueError(
            "structural_stiffness: Jee eq. (9) is a rigid axis; analyse a plant without the "
            "two-mass mode"
        )
    bad = [a for a, b in zip(p.axis_names, p.viscous_Ns_m, strict=True) if not b > 0]
    if bad:
        raise ValueError(
            f"viscous: Jee eq. (9) needs viscous friction b > 0 on every axis (K = 1/b, "
            f"τ = m/b); zero on axis {', '.join(bad)}. A pure mass under P control has no "
            "stable gain (the limit 2b/T tends to 0)"
        )


def axis_models(plant="jee-triaxial", **plant_kw) -> list[AxisModel]:
    """Eq. (9) for every axis of ``plant`` (name, mapping, PlantParams or Plant).

    Uses the *nominal* parameters (the model a controller designer is given): m, b and T.
    Nonlinear terms (friction, ripple, disturbance) are not part of eq. (9) and are ignored;
    a nominal model with computation delay, current-loop lag or a two-mass mode is rejected.
    """
    p = _make_plant(plant, plant_kw).nominal
    _check_linear_model(p)
    return [
        AxisModel.from_mass_viscous(a, m, b, p.servo_period_s)
        for a, m, b in zip(p.axis_names, p.mass_kg, p.viscous_Ns_m, strict=True)
    ]


def _common_interval(models: Sequence[AxisModel]) -> tuple[float, float, str]:
    ivs = [mdl.kp_interval() for mdl in models]
    hi_idx = int(np.argmin([iv[1] for iv in ivs]))
    return max(iv[0] for iv in ivs), ivs[hi_idx][1], models[hi_idx].name


def axial_gain_limit(plant="jee-triaxial", **plant_kw) -> float:
    """Upper end of the common stable range of K_P: min over axes of the Jury limit (eq. 17)."""
    return _common_interval(axis_models(plant, **plant_kw))[1]


def _kp_units(p: PlantParams) -> str:
    if p.input_kind == "velocity-command":
        return (
            "command units per metre of error (dimensionless in Jee's normalisation u = ẋ_ss/K; "
            "K·K_P is the position-loop gain in 1/s)"
        )
    return "N/m (force-input axis: K = 1/b in m/(N s), τ = m/b)"


# --------------------------------------------------------------------------- simulation


def _linear_sim_plant(plant: Plant) -> Plant:
    """The simulated plant with its actuator saturation lifted (the analysis is linear)."""
    return Plant(plant.params.replace(force_limit_N=np.full(plant.n_axes, _NO_SATURATION)))


def simulate_step_response(
    plant="jee-triaxial",
    kp: float | Sequence[float] = 8.0,
    *,
    duration_s: float = 2.0,
    step_m: float = 1e-5,
    bound_m: float | None = None,
    **plant_kw,
) -> dict:
    """P axial loop u = K_P (x_ref − x) on every axis, x_ref a step of ``step_m`` per axis.

    ``kp`` may be a sequence: one env per gain, run as one batch. The plant (``ideal=True``
    unless told otherwise) is stepped with its saturation lifted; the controller reads the
    exact position (no encoder quantisation). A run stops when any |error| exceeds
    ``bound_m`` (default 10⁶ × step) so a diverging loop never overflows.

    Returns ``time_s`` (n,), ``error_m`` (n, B, A) (NaN-free; rows after a stop are the
    last value), ``stopped_at_s`` (B,) (None where the run completed), ``growth`` (B,)
    = max |error| over the last 25 % of the run / max |error| over the first 25 %, and
    ``rate_per_s`` (B,) = ln(growth) / (elapsed time between the two windows' centres).
    """
    base = _make_plant(plant, plant_kw)
    sim = _linear_sim_plant(base)
    gains = np.atleast_1d(np.asarray(kp, dtype=np.float64))
    if gains.ndim != 1 or not np.all(np.isfinite(gains)):
        raise ValueError(f"kp: need finite gains, got {kp}")
    if not (math.isfinite(duration_s) and duration_s > 0):
        raise ValueError(f"duration_s: must be > 0, got {duration_s}")
    if not (math.isfinite(step_m) and step_m != 0):
        raise ValueError(f"step_m: must be a finite non-zero step (m), got {step_m}")
    bound = abs(step_m) * 1e6 if bound_m is None else float(bound_m)
    if not (math.isfinite(bound) and bound > abs(step_m)):
        raise ValueError(f"bound_m: must exceed |step_m|, got {bound_m}")
    T = sim.servo_period_s
    n = max(8, int(round(duration_s / T)))
    B, A = gains.size, sim.n_axes
    ref = np.full((B, A), float(step_m))
    state = sim.initial_state(np.zeros((B, A)))
    packed = sim.packed_batch(B)
    err = np.empty((n, B, A))
    active = np.ones(B, dtype=bool)
    stopped = np.full(B, -1, dtype=np.int64)
    for k in range(n):
        e = ref - state.position
        err[k] = e
        over = active & np.any(np.abs(e) > bound, axis=1)
        if np.any(over):
            stopped[over] = k
            active &= ~over
        if not np.any(active):
            err[k + 1 :] = err[k]
            break
        u = np.where(active[:, None], gains[:, None] * e, 0.0)
        new, _ = sim.step(state, u, k * T, packed)
        # frozen envs keep their state (no further growth, no overflow)
        new.z[~active] = state.z[~active]
        state = new
    env = np.max(np.abs(err), axis=2)  # (n, B)
    q = max(1, n // 4)
    growth, rate = [], []
    for b in range(B):
        end = n if stopped[b] < 0 else stopped[b] + 1
        qb = max(1, min(q, end // 4)) if stopped[b] >= 0 else q
        early = float(np.max(env[:qb, b]))
        late = float(np.max(env[end - qb : end, b]))
        g = max(late, 1e-300) / max(early, 1e-300)
        growth.append(g)
        span = max((end - qb) * T, T)
        rate.append(math.log(g) / span)
    return {
        "time_s": np.arange(n) * T,
        "error_m": err,
        "kp": gains,
        "stopped_at_s": [None if s < 0 else float(s * T) for s in stopped],
        "growth": np.array(growth),
        "rate_per_s": np.array(rate),
    }


def _circle_basis(plane, n_axes: int) -> tuple[np.ndarray, np.ndarray]:
    """Orthonormal (u, v) of the circle's plane in axis space (eq. 22)."""
    names = {"xy": (0, 1), "yz": (1, 2), "zx": (2, 0)}
    if isinstance(plane, str):
        if plane not in names:
            raise ValueError(f"plane: one of {sorted(names)} or a normal vector, got {plane!r}")
        i, j = names[plane]
        if max(i, j) >= n_axes:
            raise ValueError(f"plane: {plane!r} needs 3 axes, the plant has {n_axes}")
        u, v = np.zeros(n_axes), np.zeros(n_axes)
        u[i], v[j] = 1.0, 1.0
        return u, v
    nrm = np.asarray(plane, dtype=np.float64)
    if n_axes != 3 or nrm.shape != (3,) or not np.all(np.isfinite(nrm)):
        raise ValueError(
            f"plane: a normal vector needs a 3-axis plant and 3 finite values, got {plane}"
        )
    norm = float(np.linalg.norm(nrm))
    if norm == 0:
        raise ValueError("plane: the normal vector must be non-zero")
    w = nrm / norm
    e = np.eye(3)[int(np.argmin(np.abs(w)))]
    u = e - (e @ w) * w
    u /= np.linalg.norm(u)
    return u, np.cross(w, u)


def _distance_to_circle(pos: np.ndarray, radius: float, u: np.ndarray, v: np.ndarray):
    """True distance of points (..., A) to the circle R(u cos φ + v sin φ) centred at 0."""
    pu, pv = pos @ u, pos @ v
    out = pos - pu[..., None] * u - pv[..., None] * v
    radial = np.hypot(pu, pv) - radius
    return np.sqrt(radial**2 + np.sum(out**2, axis=-1))


def steady_state_prediction(
    models: Sequence[AxisModel],
    kp: float,
    radius_m: float,
    feedrate_m_s: float,
    plane="xy",
    n_phase: int = 8192,
) -> dict:
    """Predicted steady-state contour and tracking error on a circle (eqs. 20–31).

    ``ω = F/R``; per axis ``H_i = H_i(e^{jωT})`` (scipy dfreqresp of the closed loop). The
    steady-state orbit is ``P(θ) = Re{R diag(H_i)(u − jv) e^{jθ}}`` (eq. 27); the contour
    error is its true distance to the circle and the tracking error ``‖R(θ) − P(θ)‖``, both
    maximised over θ on ``n_phase`` points. For matched axes these reduce to
    ``R | |H| − 1 |`` (eq. 29) and ``R |1 − H|`` (eq. 31); the per-axis values of those two
    formulas are returned too (``matched_formula``).
    """
    u, v = _circle_basis(plane, len(models))
    omega = float(_check_circle(radius_m, [feedrate_m_s])[0]) / radius_m
    H = np.array([m.closed_loop_response(kp, omega) for m in models])
    c = radius_m * (u - 1j * v)
    theta = np.linspace(0.0, 2.0 * np.pi, n_phase, endpoint=False)
    rot = np.exp(1j * theta)[:, None]
    ref = np.real(c[None, :] * rot)
    pos = np.real((H * c)[None, :] * rot)
    contour = _distance_to_circle(pos, radius_m, u, v)
    tracking = np.linalg.norm(ref - pos, axis=1)
    in_plane = [i for i in range(len(models)) if abs(u[i]) + abs(v[i]) > 0]
    return {
        "omega_rad_s": omega,
        "H": H,
        "contour_error_m": float(np.max(contour)),
        "tracking_error_m": float(np.max(tracking)),
        "matched_formula": {
            models[i].name: {
                "contour_error_m": float(radius_m * abs(abs(H[i]) - 1.0)),
                "tracking_error_m": float(radius_m * abs(1.0 - H[i])),
                "lag_steps_d": float(-np.angle(H[i]) / (omega * models[i].servo_period_s)),
            }
            for i in in_plane
        },
    }


def _check_circle(radius_m, feedrates_m_s) -> np.ndarray:
    F = np.atleast_1d(np.asarray(feedrates_m_s, dtype=np.float64))
    if F.ndim != 1 or F.size == 0 or not np.all(np.isfinite(F)) or np.any(F <= 0):
        raise ValueError(
            f"feedrates_m_s: need one or more finite feedrates > 0 (m/s), got {feedrates_m_s}"
        )
    try:
        r = float(radius_m)
    except (TypeError, ValueError):
        r = math.nan
    if not (math.isfinite(r) and r > 0):
        raise ValueError(f"radius_m: must be a finite value > 0 (m), got {radius_m}")
    return F


def _steady_state_init(models, kp, c, omega):
    """Exact ZOH steady-state [x, v] per axis at k = 0 for r_k = Re{c e^{jωkT}}."""
    pos, vel = np.empty(len(models)), np.empty(len(models))
    for i, mdl in enumerate(models):
        A = np.array([[0.0, 1.0], [0.0, -mdl.viscous / mdl.mass]])
        Bm = np.array([[0.0], [1.0 / mdl.mass]])
        Phi, Gam, *_ = signal.cont2discrete(
            (A, Bm, np.eye(2), np.zeros((2, 1))), mdl.servo_period_s, method="zoh"
        )
        Phi_cl = Phi - kp * Gam @ np.array([[1.0, 0.0]])
        z = np.exp(1j * omega * mdl.servo_period_s)
        Z = np.linalg.solve(z * np.eye(2) - Phi_cl, Gam[:, 0] * kp * c[i])
        pos[i], vel[i] = Z.real
    return pos, vel


def simulate_circle(
    plant,
    kp: float,
    radius_m: float,
    feedrates_m_s: Sequence[float],
    plane="xy",
    *,
    models: Sequence[AxisModel] | None = None,
    settle_tol: float = 1e-6,
    max_settle_s: float = 20.0,
    **plant_kw,
) -> list[dict]:
    """Simulated steady-state contour and tracking error on a circle, one env per feedrate.

    Reference ``r_k = R (u cos ωkT + v sin ωkT)`` (other axes 0), P loop
    ``u_k = K_P (r_k − x_k)`` on the plant (saturation lifted, exact position). Each env
    starts on its steady-state orbit (exact ZOH solution), runs until the slowest closed-loop
    mode has decayed to ``settle_tol`` (at most ``max_settle_s``), and is scored over its
    last full revolution: max true distance to the circle and max ‖r_k − x_k‖. An env whose
    error exceeds 100 R is stopped and marked ``diverged`` (errors None), e.g. a realistic
    plant whose computation delay eq. (9) does not model.
    """
    base = _make_plant(plant, plant_kw)
    sim = _linear_sim_plant(base)
    if models is None:
        models = axis_models(base)
    u, v = _circle_basis(plane, sim.n_axes)
    T = sim.servo_period_s
    F = _check_circle(radius_m, feedrates_m_s)
    omegas = F / radius_m
    rho = max(float(np.max(np.abs(np.roots(m.characteristic(kp))))) for m in models)
    if not rho < 1.0:
        raise ValueError(f"kp: the closed loop is not stable at K_P = {kp} (max |root| {rho:.6g})")
    rho = max(rho, 1e-12)
    n_settle = max(1, int(min(math.ceil(math.log(settle_tol) / math.log(rho)), max_settle_s / T)))
    n_rev = np.maximum(1, np.round(2.0 * np.pi / (omegas * T)).astype(np.int64))
    n = n_settle + int(np.max(n_rev))
    B, A = F.size, sim.n_axes
    c = radius_m * (u - 1j * v)
    state = sim.initial_state(np.zeros((B, A)))
    for b in range(B):
        pos, vel = _steady_state_init(models, kp, c, omegas[b])
        state.z[b, :, 0] = pos
        state.z[b, :, 1] = vel
        if state.z.shape[2] >= 4:  # two-mass layout: motor side moves with the load
            state.z[b, :, 2] = pos
            state.z[b, :, 3] = vel
    packed = sim.packed_batch(B)
    ks = np.arange(n)
    phase = np.exp(1j * np.outer(ks * T, omegas))  # (n, B)
    ref_all = np.real(phase[:, :, None] * c[None, None, :])  # (n, B, A)
    positions = np.empty((n, B, A))
    peak_u = np.zeros((B, A))
    bound = 100.0 * radius_m  # a diverging loop is stopped here (no overflow)
    active = np.ones(B, dtype=bool)
    for k in range(n):
        positions[k] = state.position
        err = ref_all[k] - state.position
        active &= np.all(np.abs(err) <= bound, axis=1)
        if not np.any(active):
            positions[k + 1 :] = positions[k]
            break
        cmd = np.where(active[:, None], kp * err, 0.0)
        peak_u = np.maximum(peak_u, np.abs(cmd))
        new, _ = sim.step(state, cmd, k * T, packed)
        new.z[~active] = state.z[~active]
        state = new
    out = []
    for b in range(B):
        w = slice(n - int(n_rev[b]), n)
        pos = positions[w, b]
        contour = _distance_to_circle(pos, radius_m, u, v)
        tracking = np.linalg.norm(ref_all[w, b] - pos, axis=1)
        ok = bool(active[b])
        out.append(
            {
                "feedrate_m_s": float(F[b]),
                "diverged": not ok,
                "contour_error_m": float(np.max(contour)) if ok else None,
                "tracking_error_m": float(np.max(tracking)) if ok else None,
                "settle_steps": n_settle,
                "revolution_steps": int(n_rev[b]),
                "peak_command_fraction_of_limit": float(
                    np.max(peak_u[b] / base.params.force_limit_N)
                ),
            }
        )
    return out


# --------------------------------------------------------------------------- report


def _um(x):
    return None if x is None else x * 1e6


def _ratio(num: float, den):
    if den is None:
        return None
    if den > 0:
        return num / den
    return 1.0 if num == 0 else None


def stability_report(
    plant="jee-triaxial",
    *,
    kp: float | None = None,
    feedrates_m_s: Sequence[float] = DEFAULT_FEEDRATES_M_S,
    radius_m: float = 0.05,
    plane="xy",
    sim_duration_s: float = 2.0,
    step_m: float = 1e-5,
    **plant_kw,
) -> dict:
    """Jee 2007's analysis of ``plant`` with a P axial controller, confirmed by simulation.

    Parameters
    ----------
    plant : name, mapping, PlantParams or Plant
        ``plant_kw`` go to :class:`~contour_env.plants.Plant` (``ideal`` defaults to True).
        The analysis uses the nominal m, b, T (eq. 9); the simulations use the true plant
        with its saturation lifted.
    kp : float, optional
        Axial gain for the steady-state part; default ``0.5 × axial_gain_limit`` (gain margin
        2, 6 dB; 8.32 for Jee's Table 1). Must lie inside the stable range.
    feedrates_m_s : sequence of float
        Circle feedrates F (m/s); ω = F/R. Default 5, 10, 20 m/min.
    radius_m : float
        Circle radius R (m), default 50 mm (Jee's 3-D circle).
    plane : "xy", "yz", "zx" or a 3-vector normal
        Plane of the circle (default the xy-plane; other axes' reference is 0).
    sim_duration_s, step_m : float
        Length and step size of the stability-confirming simulations (2 s, 10 µm).

    Returns a JSON-serialisable dict (no NaN): ``plant``, ``input_kind``, ``servo_period_s``,
    ``axes`` (per axis: name, K, tau, H1, H0, r, kp_interval, kp_limits, binding_condition),
    ``axial_gain_limit_per_s`` (min over axes of the Jury upper limit; eq. 17),
    ``limiting_axis``, ``kp_units``, ``simulation`` ({kp_below, kp_above, stable_below,
    diverged_above, growth_below, growth_above, rate_below_per_s, rate_above_per_s,
    predicted_rate_below_per_s, predicted_rate_above_per_s, ...}), ``kp_used``,
    ``steady_state`` (per feedrate: predicted/simulated contour and tracking error in µm and
    their ratios predicted/simulated), ``notes``.
    """
    base = _make_plant(plant, plant_kw)
    models = axis_models(base)
    lo, limit, limiting_axis = _common_interval(models)
    if kp is None:
        kp_used = DEFAULT_KP_FRACTION * limit
    else:
        kp_used = float(kp)
        if not (math.isfinite(kp_used) and lo < kp_used < limit):
            raise ValueError(
                f"kp: must lie inside the stable range ({lo:.6g}, {limit:.6g}), got {kp}"
            )
    F = _check_circle(radius_m, feedrates_m_s)

    simulation = _stability_simulation(base, models, limit, sim_duration_s, step_m)
    steady = _steady_state_rows(base, models, kp_used, radius_m, F, plane)
    p = base.params
    return {
        "plant": base.name,
        "input_kind": base.nominal.input_kind,
        "effects": _jsonable(base.effects),
        "servo_period_s": base.servo_period_s,
        "axes": [m.describe() for m in models],
        "axial_gain_limit_per_s": limit,
        "kp_interval": [lo, limit],
        "limiting_axis": limiting_axis,
        "kp_units": _kp_units(base.nominal),
        "simulation": simulation,
        "kp_used": kp_used,
        "kp_default_rule": f"{DEFAULT_KP_FRACTION} × axial_gain_limit (gain margin 2) unless given",
        "plane": plane if isinstance(plane, str) else [float(x) for x in plane],
        "steady_state": steady,
        "notes": (
            "Analysis: nominal m, b, T in Jee eq. (9), Jury on Ω1 (eq. 16), limit eq. (17). "
            "Simulations: the plant's own exact ZOH step with saturation lifted and the exact "
            "position fed back (no encoder quantisation)"
            + ("; nonlinear friction/ripple in the simulated plant" if p.has_friction else "")
            + (
                "; the simulated plant has a one-period computation delay, which eq. (9) does "
                "not model and which lowers the stable range"
                if p.computation_delay
                else ""
            )
            + ". Steady state: circle in the given plane, errors are maxima over one revolution."
        ),
    }


def _stability_simulation(base, models, limit, sim_duration_s, step_m) -> dict:
    """stability_report's ``simulation``: step responses just below and just above the gain
    limit (SIM_FACTORS), their growth and rate against the rate the roots predict."""
    kb, ka = SIM_FACTORS[0] * limit, SIM_FACTORS[1] * limit
    sim = simulate_step_response(base, [kb, ka], duration_s=sim_duration_s, step_m=step_m)
    pred_rate = [
        max(
            math.log(max(float(np.max(np.abs(np.roots(m.characteristic(g))))), 1e-300))
            for m in models
        )
        / base.servo_period_s
        for g in (kb, ka)
    ]
    g_below, g_above = (float(x) for x in sim["growth"])
    return {
        "kp_below": kb,
        "kp_above": ka,
        "stable_below": bool(sim["stopped_at_s"][0] is None and g_below < 1.0),
        "diverged_above": bool(sim["stopped_at_s"][1] is not None or g_above > 1.0),
        "growth_below": g_below,
        "growth_above": g_above,
        "rate_below_per_s": float(sim["rate_per_s"][0]),
        "rate_above_per_s": float(sim["rate_per_s"][1]),
        "predicted_rate_below_per_s": pred_rate[0],
        "predicted_rate_above_per_s": pred_rate[1],
        "stopped_at_s": sim["stopped_at_s"],
        "duration_s": float(sim["time_s"][-1] + base.servo_period_s),
        "step_m": float(step_m),
        "growth_definition": (
            "max |x_ref − x| over all axes in the last 25 % of the run / the same over the "
            "first 25 %; rate = ln(growth)/elapsed time; predicted rate = ln(max |root of "
            "Ω1|)/T"
        ),
    }


def _steady_state_rows(base, models, kp_used, radius_m, F, plane) -> list[dict]:
    """stability_report's ``steady_state``: per feedrate, the predicted and the simulated
    contour and tracking errors on the circle."""
    sims = simulate_circle(base, kp_used, radius_m, F, plane, models=models)
    steady = []
    for f, s in zip(F, sims, strict=True):
        p = steady_state_prediction(models, kp_used, radius_m, float(f), plane)
        pc, pt = p["contour_error_m"], p["tracking_error_m"]
        sc, st = s["contour_error_m"], s["tracking_error_m"]
        steady.append(
            {
                "feedrate_m_s": float(f),
                "feedrate_m_min": float(f) * 60.0,
                "radius_m": float(radius_m),
                "omega_rad_s": p["omega_rad_s"],
                "predicted_contour_error_um": pc * 1e6,
                "simulated_contour_error_um": _um(sc),
                "predicted_tracking_error_um": pt * 1e6,
                "simulated_tracking_error_um": _um(st),
                "contour_ratio": _ratio(pc, sc),
                "tracking_ratio": _ratio(pt, st),
                "matched_formula_um": {
                    a: {
                        "contour": d["contour_error_m"] * 1e6,
                        "tracking": d["tracking_error_m"] * 1e6,
                        "lag_steps_d": d["lag_steps_d"],
                    }
                    for a, d in p["matched_formula"].items()
                },
                "simulation_diverged": s["diverged"],
                "peak_command_fraction_of_limit": s["peak_command_fraction_of_limit"],
            }
        )
    return steady


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, np.integer, np.bool_)):
        return x.item()
    return x


def format_stability_report(report: dict) -> str:
    """A readable text table of :func:`stability_report`'s dict."""
    lines = [
        f"Jee & Lee 2007 stability analysis — plant {report['plant']} "
        f"({report['input_kind']}), T = {report['servo_period_s'] * 1e3:g} ms",
        "",
        f"{'axis':6s} {'K':>12s} {'tau (s)':>10s} {'r':>10s} {'H1':>12s} {'H0':>12s} "
        f"{'K_P range (Jury)':>24s}  binding",
    ]
    for a in report["axes"]:
        lo, hi = a["kp_interval"]
        lines.append(
            f"{a['name']:6s} {a['K']:12.6g} {a['tau']:10.4g} {a['r']:10.6f} {a['H1']:12.5e} "
            f"{a['H0']:12.5e} {f'({lo:.4g}, {hi:.6f})':>24s}  {a['binding_condition']}"
        )
    s = report["simulation"]
    lines += [
        "",
        f"axial gain limit K_P < {report['axial_gain_limit_per_s']:.6f} "
        f"(axis {report['limiting_axis']}; eq. 17: min (1 − r)/H0)",
        f"  K_P units: {report['kp_units']}",
        "",
        f"simulation, {s['step_m'] * 1e6:g} µm step, {s['duration_s']:g} s "
        "(growth = late/early error envelope):",
        f"  K_P = {s['kp_below']:.4f} (0.98 × limit): growth {s['growth_below']:.4g}, "
        f"rate {s['rate_below_per_s']:+.4f}/s (predicted {s['predicted_rate_below_per_s']:+.4f}/s)"
        f" -> {'stable' if s['stable_below'] else 'NOT stable'}",
        f"  K_P = {s['kp_above']:.4f} (1.02 × limit): growth {s['growth_above']:.4g}, "
        f"rate {s['rate_above_per_s']:+.4f}/s (predicted {s['predicted_rate_above_per_s']:+.4f}/s)"
        f" -> {'diverging' if s['diverged_above'] else 'NOT diverging'}",
        "",
        f"steady state on a circle R = {report['steady_state'][0]['radius_m'] * 1e3:g} mm "
        f"(plane {report['plane']}), K_P = {report['kp_used']:.4g}:",
        f"{'F (m/min)':>10s} {'contour pred':>13s} {'contour sim':>12s} {'ratio':>7s} "
        f"{'tracking pred':>14s} {'tracking sim':>13s} {'ratio':>7s}   (µm)",
    ]

    for row in report["steady_state"]:
        # a simulation that diverged has no steady-state error, nor a ratio
        sim_contour = format_cell(row["simulated_contour_error_um"], 12, 4, "diverged")
        sim_tracking = format_cell(row["simulated_tracking_error_um"], 13, 3, "diverged")
        lines.append(
            f"{row['feedrate_m_min']:10.4g} {row['predicted_contour_error_um']:13.4f} "
            f"{sim_contour} {format_cell(row['contour_ratio'], 7, 4)} "
            f"{row['predicted_tracking_error_um']:14.3f} "
            f"{sim_tracking} {format_cell(row['tracking_ratio'], 7, 4)}"
        )
    return "\n".join(lines)


def format_cell(x: float | None, width: int, prec: int, missing: str = "n/a") -> str:
    """A table cell: ``x`` in fixed point (``width`` characters, ``prec`` decimals), or
    ``missing`` right-aligned in the same width where ``x`` is None."""
    return f"{missing:>{width}s}" if x is None else f"{x:{width}.{prec}f}"
