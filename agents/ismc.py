"""Five-axis contouring laws of Chen, Khong & Hsieh (2022): the equivalent-error integral
sliding mode controller (eqs. 6–12) and the joint-space PD it is compared with (Table 2); and
the joint PID baseline tuned to the project's margins (``JointPID``, ours).

All are plain classes: ``command(q, qd, k)`` takes the measured joints ξ (5,), rates ξ̇
(5,) (m, rad; m/s, rad/s) and the reference sample index k, and returns the joint command
u (5,) in (N, N, N, N·m, N·m). They use the nominal dynamics ξ̈ = f + G u (eq. 5) of
:func:`contour_env.plants.five_axis.dynamics.drift_and_gain`. The policy-protocol wrapper
(observation → action) is separate.
"""

from __future__ import annotations

import math

import numpy as np

from contour_env.paths.five_axis import FiveAxisPath
from contour_env.plants.five_axis.dynamics import (
    coriolis_matrix,
    drift_and_gain,
    gravity,
    mass_matrix,
)

__all__ = ["PAPER_ISMC_GAINS", "PAPER_PD_GAINS", "EquivalentErrorISMC", "JointPD", "JointPID"]

# Chen 2022, Table 2 (simulation cases 1–4): PD (Kp, Kd) and ISMC (b1, b2, ρ, μ) per path
PAPER_PD_GAINS = {
    "five-axis-line": (800.0, 60.0),
    "five-axis-circle": (800.0, 310.0),
}
PAPER_ISMC_GAINS = {
    "five-axis-line": (57.0, 800.0, 50.0, 0.05),
    "five-axis-circle": (283.0, 800.0, 150.0, 0.8),
}
# Tangential-error regulariser v₀ (m/s) as a share of the path's peak feed F. The paper's
# e = ξ̇_dᵀ (ξ − ξ_d) = ṡ · (dξ_d/ds)ᵀ (ξ − ξ_d) is the tangential error along the joint-space
# tangent dξ_d/ds scaled by the feed ṡ: a time-varying scale that is zero at rest (Γ of
# eq. 7 loses its last row at the start and end of the S-curve). The sliding surface
# σ = η̇ + b₁η + b₂∫η does not need that scale, and it hurts: ∫e gathered at cruise feed is
# worked off at the end of the path where the scale is ṡ + v₀ ≈ v₀, so with v₀ = 1 % of F a
# tangential offset is amplified ~100× as the feed stops (the circle diverged there on the
# realistic plant). w = dξ_d/ds (ṡ + v₀) with v₀ = F keeps the scale within F … 2F over the
# whole path (e at cruise is twice the paper's, at rest equal to it at cruise): the same
# law, now well-conditioned from rest to rest. v₀ = 0 is the paper's weight. Ablated in
# docs/FIVE_AXIS.md ("ISMC's two additions", scripts/five_axis_table.py --ablations): v₀ = 0
# stops at the path's end (Γ singular), 0.01 F diverges on the circle; from F up the line is
# unchanged and a larger v₀ helps the circle only at its end point (its overshoot there).
DEFAULT_TANGENT_FLOOR_SHARE = 1.0


def _positive(name: str, value) -> float:
    v = float(value)
    if not (math.isfinite(v) and v > 0):
        raise ValueError(f"{name}: must be a finite number > 0, got {value!r}")
    return v


def _require_algebraic(path) -> FiveAxisPath:
    if not isinstance(path, FiveAxisPath):
        raise ValueError(
            "ismc: the equivalent-error controller needs an algebraic path (a FiveAxisPath "
            "with path functions p(ξ) = 0, e.g. contour_env.paths.five_axis.five_axis_path); "
            f"got {type(path).__name__} (a path given only as G-code or samples has none)"
        )
    return path


class EquivalentErrorISMC:
    """Feedback linearisation plus integral sliding mode on the equivalent errors (Chen 2022).

    With η = (ε₁…ε₄, e) (eq. 6) and η̈ = Ω + Γ u (eq. 7, :meth:`FiveAxisPath.error_dynamics`
    on the nominal f, G of eq. 5), the command is (eqs. 8–12)

        u = Γ⁻¹ (−Ω − b₁ η̇ − b₂ η − ρ tanh(σ / μ)),   σ = η̇ + b₁ η + b₂ ∫η dt

    so that σ̇ = −ρ tanh(σ/μ) on the model and, on σ = 0, η̈ + b₁ η̇ + b₂ η = 0.

    ε₁…ε₄ are :class:`FiveAxisPath`'s path functions (its docstring gives each). Two differ
    from the printed text: ε₄ = (z_w − z_c)² − L cos² A, zero on the path, where the paper
    prints (x_w − x_c)² − L cos² θ_A, which is not; and ε₃ carries our kinematics' angles, the
    paper's mirrored (θ_A = −A, θ_C = −C).

    Parameters
    ----------
    path : FiveAxisPath
        The algebraic path (a G-code-only path raises ValueError: no local fit is made).
    inertia : FiveAxisInertia
        The nominal rigid-body model (``FiveAxisPlant(...).nominal.inertia``).
    b1 (1/s), b2 (1/s²), rho (ρ, units of η̈), mu (μ, units of σ) : float > 0
        Default: the paper's Table 2 gains for ``path.name`` (line: 57, 800, 50, 0.05;
        circle: 283, 800, 150, 0.8).
    tangent_floor_m_s : float >= 0, optional
        v₀ of the tangential error's weight w = dξ_d/ds (ṡ + v₀); 0 is the paper's
        w = ξ̇_d (singular at rest). Default the path's peak feed F (see
        ``DEFAULT_TANGENT_FLOOR_SHARE``: the weight then stays within F … 2F).
    computation_delay_steps : int >= 0
        The servo's computation delay n (periods; the realistic plant's: 1): the command
        computed now acts from n periods later. The law is then applied to the state predicted
        n periods ahead with the nominal model under the commands already issued (and the
        reference sample k + n); 0 (default): the measured state, as in the paper. The delay
        is a property of the controller's own hardware, so the controller knows it.
    drive_limit : (5,) or scalar, optional
        The drive limits (N, N·m) the issued commands are clipped to in the prediction.

    State: ``integral`` (5,) = ∫η dt, by the rectangle rule at the servo period (updated with
    η_k before σ_k is formed) and, with a delay, the last n + 1 commands issued; reset()
    clears both.
    """

    def __init__(
        self,
        path,
        inertia,
        b1=None,
        b2=None,
        rho=None,
        mu=None,
        tangent_floor_m_s=None,
        computation_delay_steps: int = 0,
        drive_limit=None,
    ):
        self.path = _require_algebraic(path)
        self.inertia = inertia
        paper = PAPER_ISMC_GAINS.get(path.name)
        given = (b1, b2, rho, mu)
        if paper is None and any(g is None for g in given):
            raise ValueError(f"ismc: no paper gains for path {path.name!r}; pass b1, b2, rho, mu")
        b1, b2, rho, mu = (
            p if g is None else g for g, p in zip(given, paper or given, strict=True)
        )
        self.b1, self.b2 = _positive("b1", b1), _positive("b2", b2)
        self.rho, self.mu = _positive("rho", rho), _positive("mu", mu)
        if tangent_floor_m_s is None:
            peak = max(sec.peak_feed for sec in path.profile.sections)
            tangent_floor_m_s = DEFAULT_TANGENT_FLOOR_SHARE * peak
        v0 = float(tangent_floor_m_s)
        if not (math.isfinite(v0) and v0 >= 0):
            raise ValueError(f"tangent_floor_m_s: must be a finite number >= 0, got {v0!r}")
        self.tangent_floor_m_s = v0
        self.dt = path.reference.servo_period_s
        delay = computation_delay_steps
        if isinstance(delay, bool) or not isinstance(delay, (int, np.integer)) or delay < 0:
            raise ValueError(f"computation_delay_steps: must be an integer >= 0, got {delay!r}")
        self.computation_delay_steps = int(delay)
        if drive_limit is None:
            self.drive_limit = None
        else:
            lim = np.broadcast_to(np.asarray(drive_limit, dtype=np.float64), (5,)).copy()
            if not np.all(np.isfinite(lim) & (lim > 0)):
                raise ValueError(f"drive_limit: must be finite and > 0, got {lim.tolist()}")
            self.drive_limit = lim
        self.reset()

    def reset(self) -> None:
        """Zero the integral state ∫η dt and forget the commands still in the delay line."""
        self.integral = np.zeros(5)
        self._in_flight = []

    def _applied(self, u) -> np.ndarray:
        return u if self.drive_limit is None else np.clip(u, -self.drive_limit, self.drive_limit)

    def predict(self, q, qd):
        """The state (ξ, ξ̇) the command now computed will act on: ``computation_delay_steps``
        periods ahead of the measurement, by the nominal model ξ̈ = f + G u under the commands
        already issued and not yet applied (the first ones of an episode: the gravity hold).
        With a delay, ξ̇ (a backward difference over the last period: the rate half a period
        ago) is first advanced by half a period."""
        n = self.computation_delay_steps
        if n == 0:
            return q, qd
        T = self.dt
        hold = gravity(q, self.inertia)
        issued = [hold] * (n + 1 - len(self._in_flight)) + list(self._in_flight)
        # ξ̇ is the rate of the last period's mid-point: advance it by the command applied then
        f, g = drift_and_gain(q, qd, self.inertia)
        qd = qd + 0.5 * T * (f + g @ issued[-n - 1])
        for u in issued[-n:]:
            f, g = drift_and_gain(q, qd, self.inertia)
            acc = f + g @ u
            q = q + T * qd + 0.5 * T * T * acc
            qd = qd + T * acc
        return q, qd

    def command(self, q, qd, k: int) -> np.ndarray:
        """Joint command u (5,) at joints q, rates qd (5,) and reference sample k (with a
        computation delay: the state predicted for sample k + delay, and its reference)."""
        q = np.asarray(q, dtype=np.float64)
        qd = np.asarray(qd, dtype=np.float64)
        n = self.computation_delay_steps
        if n:
            q, qd = self.predict(q, qd)
            k = k + n
        u = self._law(q, qd, k)
        if n:
            self._in_flight = [*self._in_flight, self._applied(u)][-n - 1 :]
        return u

    def _law(self, q, qd, k: int) -> np.ndarray:
        v0 = self.tangent_floor_m_s
        eta, eta_dot = self.path.equivalent_errors(q, qd, k, v0)
        self.integral = self.integral + self.dt * eta
        sigma = eta_dot + self.b1 * eta + self.b2 * self.integral
        drift, gain = drift_and_gain(q, qd, self.inertia)
        omega, gamma = self.path.error_dynamics(q, qd, k, drift, gain, v0)
        v = -self.b1 * eta_dot - self.b2 * eta - self.rho * np.tanh(sigma / self.mu)
        try:
            return np.linalg.solve(gamma, v - omega)
        except np.linalg.LinAlgError:
            raise ValueError(
                f"ismc: Γ of eq. 7 is singular at sample {k} (ξ̇_d = 0 at rest with "
                "tangent_floor_m_s = 0, or the path functions lose rank); use "
                "tangent_floor_m_s > 0"
            ) from None


class JointPD:
    """Joint-space PD on e = ξ_d − ξ (the paper's comparison law, Table 2: Kp = 800,
    Kd = 60 on the line, 310 on the circle).

    The paper gives the gains without units; as printed they are the acceleration-level
    gains of the same linearised loop the ISMC uses (its b₂ is 800 too): on our NXV560A-class
    model (slides of 450–1100 kg) Kp = 800 N/m would leave the spindle head sagging metres.
    So by default (``inverse_dynamics=True``) the law is computed through the nominal model,

        u = G⁻¹ (Kp e + Kd ė − f)       (ë + Kd ė + Kp e = ξ̈_d on the model)

    without acceleration feed-forward (with it the nominal loop would track exactly).
    ``inverse_dynamics=False`` gives the plain law u = Kp e + Kd ė + g(ξ) with Kp in N/m
    (N·m/rad), Kd in N·s/m (N·m·s/rad). Kp, Kd scalar or per joint (5,), ≥ 0; default from
    ``PAPER_PD_GAINS`` for ``path.name``. Stateless (reset() does nothing).
    """

    def __init__(self, path, inertia, kp=None, kd=None, inverse_dynamics: bool = True):
        self.path = path
        self.inertia = inertia
        paper = PAPER_PD_GAINS.get(getattr(path, "name", None))
        if paper is None and (kp is None or kd is None):
            raise ValueError(f"pd: no paper gains for path {path!r}; pass kp and kd")
        kp = paper[0] if kp is None else kp
        kd = paper[1] if kd is None else kd
        self.kp = np.broadcast_to(np.asarray(kp, dtype=np.float64), (5,)).copy()
        self.kd = np.broadcast_to(np.asarray(kd, dtype=np.float64), (5,)).copy()
        for name, g in (("kp", self.kp), ("kd", self.kd)):
            if not np.all(np.isfinite(g) & (g >= 0)):
                raise ValueError(f"{name}: must be finite and >= 0, got {g.tolist()}")
        self.inverse_dynamics = bool(inverse_dynamics)

    def reset(self) -> None:
        """Nothing to reset (no state)."""

    def command(self, q, qd, k: int) -> np.ndarray:
        """Joint command u (5,) at joints q, rates qd (5,) and reference sample k."""
        ref = self.path.reference
        k = min(max(int(k), 0), ref.n_steps - 1)
        q = np.asarray(q, dtype=np.float64)
        qd = np.asarray(qd, dtype=np.float64)
        acc = self.kp * (ref.joints[k] - q) + self.kd * (ref.joint_rate[k] - qd)
        if not self.inverse_dynamics:
            return acc + gravity(q, self.inertia)
        drift, gain = drift_and_gain(q, qd, self.inertia)
        return np.linalg.solve(gain, acc - drift)


class JointPID:
    """Joint-space PID through the nominal model (computed torque), the tuned baseline of the
    five-axis plant (``pid``; gains and margins: docs/FIVE_AXIS.md):

        u = M̂(ξ) a + ĥ(ξ, ξ̇) + f̂(ξ̇_d[k + lead]),
        a = ξ̈_d[k + lead] + Kp e + Ki ∫e dt + Kd ė,    e = ξ_d[k] − ξ

    with M̂, ĥ = Ĉ ξ̇ + ĝ the nominal model (u = G⁻¹ (a − f) of eq. 5), ė the backward
    difference of e (the measured rate is a backward difference, so the reference's is too:
    ė = (e_k − e_{k−1}) / T exactly, the form the loop analysis models), ∫e by the rectangle
    rule including e_k. The acceleration feedforward (``feedforward``) and the friction
    feedforward f̂ (``friction``: per-joint viscous and Coulomb levels, or None) read the
    reference ``lead`` samples ahead: the command computed at k acts from k + 1 on a plant
    with the one-period computation delay, held over the period and lagged by the current
    loop. Neither closes a loop, so neither changes the margins.

    Parameters
    ----------
    path : object with ``reference`` (a FiveAxisReference) and ``name``
    inertia : FiveAxisInertia, the nominal model
    kp (1/s²), ki (1/s³), kd (1/s) : scalar or per joint (5,), >= 0
    feedforward : bool, acceleration feedforward ξ̈_d (default True)
    lead : int >= 0, samples of reference preview of the feedforward terms
    friction : (viscous (5,), coulomb (5,), smoothing velocity (5,)) or None
        f̂(v) = b v + f_c tanh(v / v_s).

    State: ``integral`` (5,) = ∫e dt; reset() zeroes it.
    """

    def __init__(
        self, path, inertia, kp, ki, kd, feedforward: bool = True, lead: int = 0, friction=None
    ):
        self.path = path
        self.inertia = inertia
        gains = {}
        for name, g in (("kp", kp), ("ki", ki), ("kd", kd)):
            arr = np.broadcast_to(np.asarray(g, dtype=np.float64), (5,)).copy()
            if not np.all(np.isfinite(arr) & (arr >= 0)):
                raise ValueError(f"{name}: must be finite and >= 0, got {arr.tolist()}")
            gains[name] = arr
        self.kp, self.ki, self.kd = gains["kp"], gains["ki"], gains["kd"]
        self.feedforward = bool(feedforward)
        if isinstance(lead, bool) or not isinstance(lead, (int, np.integer)) or lead < 0:
            raise ValueError(f"lead: must be an integer >= 0, got {lead!r}")
        self.lead = int(lead)
        if friction is None:
            self.friction = None
        else:
            visc, coulomb, vs = (
                np.broadcast_to(np.asarray(a, dtype=np.float64), (5,)).copy() for a in friction
            )
            if not (np.all(visc >= 0) and np.all(coulomb >= 0) and np.all(vs > 0)):
                raise ValueError("friction: viscous and Coulomb levels >= 0, velocities > 0")
            self.friction = (visc, coulomb, vs)
        self.dt = path.reference.servo_period_s
        self.reset()

    def reset(self) -> None:
        """Zero the integral ∫e dt."""
        self.integral = np.zeros(5)

    def command(self, q, qd, k: int) -> np.ndarray:
        """Joint command u (5,) at measured joints q, rates qd (5,) and reference sample k."""
        ref = self.path.reference
        last = ref.n_steps - 1
        k = int(k)
        kk, kprev, kff = (
            min(max(k, 0), last),
            min(max(k - 1, 0), last),
            min(max(k + self.lead, 0), last),
        )
        q = np.asarray(q, dtype=np.float64)
        qd = np.asarray(qd, dtype=np.float64)
        e = ref.joints[kk] - q
        e_dot = (ref.joints[kk] - ref.joints[kprev]) / self.dt - qd
        self.integral = self.integral + self.dt * e
        acc = self.kp * e + self.ki * self.integral + self.kd * e_dot
        if self.feedforward:
            acc = acc + ref.joint_accel[kff]
        M = mass_matrix(q, self.inertia)
        u = M @ acc + coriolis_matrix(q, qd, self.inertia) @ qd + gravity(q, self.inertia)
        if self.friction is not None:
            visc, coulomb, vs = self.friction
            v = ref.joint_rate[kff]
            u = u + visc * v + coulomb * np.tanh(v / vs)
        return u
