"""The five-axis laws under the one policy protocol: Chen, Khong & Hsieh (2022)'s joint PD
with the paper's gains (``pd`` on the five-axis plant) and equivalent-error ISMC (``ismc``),
and the tuned joint PID baseline (``pid``, five-axis only).

The laws themselves are :class:`agents.ismc.JointPD` and :class:`agents.ismc.EquivalentErrorISMC`
(per env, on the nominal model ξ̈ = f + G u); these classes bind them to a five-axis env,
run one per env of a batch on the servo signals (measured joints, backward-difference rates,
reference index) and return the joint command (N, N, N, N·m, N·m).
"""

from __future__ import annotations

import numpy as np

from contour_env.env.core import core_of

from .base import Controller, per_axis
from .ismc import PAPER_ISMC_GAINS, PAPER_PD_GAINS, EquivalentErrorISMC, JointPD, JointPID
from .parameters import AXES, BOOL, FLOAT, INT, Param

# a five-axis program (G-code) has no paper gains: PD takes the line's
DEFAULT_PD_CASE = "five-axis-line"

# pid's defaults (docs/FIVE_AXIS.md, "The tuned baseline"; scripts/five_axis_tune.py): the
# largest ω meeting ≥ 6 dB / ≥ 30° on every joint loop over the ±20 % inertia corners and the
# poses (agents.five_axis_margins), the integral pole a share of it
PID_BANDWIDTH_RAD_S = 95.0
PID_INTEGRAL_SHARE = 0.5
# the friction pid's feedforward assumes (pid:friction=1): viscous (N s/m, N m s/rad), Coulomb
# (N, N m) and the velocity of its tanh (m/s, rad/s): the realistic plant's documented levels
# (docs/FIVE_AXIS.md), as identified on the machine; the nominal model has no friction
PID_FRICTION = {
    "viscous": (1500.0, 1800.0, 1500.0, 40.0, 15.0),
    "coulomb": (150.0, 200.0, 180.0, 30.0, 10.0),
    "velocity": (2e-3, 2e-3, 2e-3, 5e-3, 5e-3),
}
PID_FRICTION_DEFAULT = 1.0


class _FiveAxisController(Controller):
    """Base of the five-axis controllers: binds only to the five-axis plant."""

    plant_family = "five-axis"

    def bind(self, env) -> Controller:
        _, core = core_of(env)
        self._setup = core.setup
        return super().bind(env)

    def configure_for(self, plant) -> Controller:
        """The gains for ``plant`` (a five-axis machine, :class:`FiveAxisMachine`) without an
        env, for the loop analysis (:mod:`agents.five_axis_margins`); a feed-drive plant is a
        ValueError, as binding to its env is."""
        self._attach(plant, 1)
        self._setup = None
        self._configure_gains()
        return self

    def _configure_gains(self) -> None:
        raise ValueError(
            f"controller {self.name!r}: no joint-loop model for the loop analysis (its law acts "
            "on the path's equivalent errors; margins are for the joint-space laws pd, pid)"
        )

    def joint_loop_gains(self, q) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The law linearised at pose q (5,) for the loop analysis: (A0, A1, A2), each (5, 5)
        in N (N·m) per m (rad), such that u = A0 E_k + A1 (E_k − E_{k−1}) / T + A2 T Σ E_j
        with E = ξ_d − ξ_measured (the form of :meth:`Controller.loop_gains`). A joint law
        through the nominal model gives A0 = M̂(q) Kp − ∂ĝ/∂ξ, A1 = M̂(q) Kd, A2 = M̂(q) Ki
        (feedforward, Coriolis and friction feedforward close no loop)."""
        from contour_env.analysis.five_axis_linear import gravity_stiffness
        from contour_env.plants.five_axis import mass_matrix

        q = np.asarray(q, dtype=np.float64)
        M = mass_matrix(q, self.nominal.inertia)
        Kg = gravity_stiffness(q, self.nominal.inertia)
        ki = getattr(self, "Ki", np.zeros(5))
        return M * self.Kp[None, :] - Kg, M * self.Kd[None, :], M * ki[None, :]

    def _attach(self, plant, n_envs: int) -> None:
        if getattr(plant, "family", None) != "five-axis":
            raise ValueError(
                f"env: controller {self.name!r} (five-axis) needs the five-axis plant; the env "
                f"has the {plant.n_axes}-axis plant {plant.name!r} (run it with plant "
                "'five-axis': the cases five-axis-line, five-axis-circle or a five-axis G-code "
                "program)"
            )
        self.nominal = plant.nominal
        self.servo_period_s = plant.servo_period_s
        self.force_limit = np.array(plant.params.force_limit_N, dtype=np.float64)
        self.n_axes = 5
        self.n_envs = n_envs
        self.computation_delay_steps = int(plant.params.computation_delay)

    def _laws(self):
        raise NotImplementedError

    def act(self, signals: dict) -> np.ndarray:
        q = np.asarray(signals["measured_position"], dtype=np.float64)
        qd = np.asarray(signals["measured_velocity"], dtype=np.float64)
        step = np.atleast_1d(signals["step"])
        laws = self._laws()
        u = np.empty_like(q)
        for b in range(q.shape[0]):
            u[b] = laws[b if len(laws) > 1 else 0].command(q[b], qd[b], int(step[b]))
        return u


class FiveAxisPDController(_FiveAxisController):
    """Joint-space PD of Chen 2022 (Table 2) through the nominal model,
    u = G⁻¹ (Kp e + Kd ė − f), e = ξ_d − ξ_m (:class:`agents.ismc.JointPD`; the paper's
    gains are acceleration-level: Kp = 800 1/s², Kd = 60 1/s on the line, 310 1/s on the
    circle; a G-code program gets the line's).

    Parameters (the ``pd`` names, so ``pd:p=800:d=60`` works on either plant family)
    ----------
    bandwidth_rad_s, damping : float, optional
        Kp = ω², Kd = 2 ζ ω (ζ default 1) instead of the paper's gains.
    P, D : scalar or per joint (5,), optional
        Kp (1/s²) and Kd (1/s), overriding the above.
    """

    name = "pd"
    summary = (
        "Chen 2022's joint PD with the paper's gains (Table 2: Kp 800 1/s², Kd 60/310 1/s) "
        "through the nominal model"
    )
    PARAMETERS = {
        "w": Param(
            "bandwidth_rad_s", "ω of every joint loop, rad/s: Kp = ω², Kd = 2ζω", FLOAT, ">0"
        ),
        "zeta": Param("damping", "damping ratio ζ (with w; default 1)", FLOAT, ">0"),
        "p": Param("P", "Kp, 1/s² (default the paper's 800)", AXES, ">=0"),
        "d": Param("D", "Kd, 1/s (default the paper's 60 line / 310 circle)", AXES, ">=0"),
    }

    def __init__(self, bandwidth_rad_s=None, damping=None, P=None, D=None):
        super().__init__()
        self.bandwidth_rad_s = bandwidth_rad_s
        self.damping = damping
        self._P_user, self._D_user = P, D

    def _configure_gains(self) -> None:
        # the gains of the path's case (margins, without a path: the line's)
        case = DEFAULT_PD_CASE if self._setup is None else self._setup.name
        kp, kd = PAPER_PD_GAINS.get(case, PAPER_PD_GAINS[DEFAULT_PD_CASE])
        if self.bandwidth_rad_s is not None:
            w = float(self.bandwidth_rad_s)
            zeta = 1.0 if self.damping is None else float(self.damping)
            kp, kd = w * w, 2.0 * zeta * w
        self.Kp = per_axis("P", kp if self._P_user is None else self._P_user, 5)
        self.Kd = per_axis("D", kd if self._D_user is None else self._D_user, 5)

    def configure(self) -> None:
        self._configure_gains()
        self.law = JointPD(
            _ReferenceOnly(self._setup), self.nominal.inertia, kp=self.Kp, kd=self.Kd
        )

    def _laws(self):
        return (self.law,)


class FiveAxisPIDController(_FiveAxisController):
    """Joint-space PID through the nominal model (computed torque) with acceleration
    feedforward: the five-axis baseline tuned like the feed drives' defaults
    (:class:`agents.ismc.JointPID`; gains, margins and tuning path: docs/FIVE_AXIS.md).

        u = M̂(ξ) (ξ̈_d[k + lead] + Kp e + Ki ∫e + Kd ė) + ĥ(ξ, ξ̇) (+ f̂(ξ̇_d[k + lead]))

    Gains by pole placement on the nominal double integrator: closed-loop poles at a double
    ω (damping ζ) and at the integral pole ω_i, (s² + 2ζω s + ω²)(s + ω_i), i.e.
    Kd = 2ζω + ω_i, Kp = ω² + 2ζω ω_i, Ki = ω² ω_i. Runs on named cases and G-code programs.

    Parameters
    ----------
    bandwidth_rad_s : scalar or per joint (5,) > 0   ω (default :data:`PID_BANDWIDTH_RAD_S`)
    damping : float > 0                              ζ (default 1)
    integral_pole_rad_s : scalar or per joint >= 0   ω_i (default ω × :data:`PID_INTEGRAL_SHARE`)
    P, I, D : scalar or per joint, optional          Kp 1/s², Ki 1/s³, Kd 1/s, overriding the above
    feedforward : bool                               acceleration feedforward (default True)
    lead_samples : int >= 0                          preview of the feedforward terms (default
                                                     the computation delay, 1 sample on the
                                                     realistic plant, 0 on the ideal one)
    friction_feedforward : float >= 0                the share of :data:`PID_FRICTION` fed
                                                     forward (default :data:`PID_FRICTION_DEFAULT`)
    """

    name = "pid"
    summary = (
        "joint PID through the nominal model with acceleration feedforward, gains at "
        ">= 6 dB / 30° over the ±20 % inertia corners"
    )
    PARAMETERS = {
        "w": Param(
            "bandwidth_rad_s",
            "ω of the joint loops' double pole, rad/s (per joint x/y/z/A/C)",
            AXES,
            ">0",
        ),
        "zeta": Param("damping", "damping ratio ζ of the double pole (default 1)", FLOAT, ">0"),
        "wi": Param(
            "integral_pole_rad_s", "integral pole ω_i, rad/s (0: a PD)", AXES, ">=0"
        ),  # fmt: skip
        "p": Param("P", "Kp, 1/s² (overrides w)", AXES, ">=0"),
        "i": Param("I", "Ki, 1/s³ (overrides w, wi)", AXES, ">=0"),
        "d": Param("D", "Kd, 1/s (overrides w)", AXES, ">=0"),
        "ff": Param("feedforward", "acceleration feedforward ξ̈_d (default 1)", BOOL),
        "lead": Param(
            "lead_samples",
            "feedforward preview, samples (default the computation delay)",
            INT,
            ">=0",
        ),
        "friction": Param(
            "friction_feedforward",
            "share of the identified viscous + Coulomb friction fed forward (0: none; default 1)",
            FLOAT,
            ">=0",
        ),
    }

    def __init__(
        self,
        bandwidth_rad_s=None,
        damping=None,
        integral_pole_rad_s=None,
        P=None,
        I=None,  # noqa: E741 (the gain's name)
        D=None,
        feedforward=True,
        lead_samples=None,
        friction_feedforward=None,
    ):
        super().__init__()
        self.bandwidth_rad_s = bandwidth_rad_s
        self.damping = damping
        self.integral_pole_rad_s = integral_pole_rad_s
        self._user = {"P": P, "I": I, "D": D}
        self.feedforward = bool(feedforward)
        self.lead_samples = lead_samples
        share = PID_FRICTION_DEFAULT if friction_feedforward is None else friction_feedforward
        share = float(share)
        if not (np.isfinite(share) and share >= 0):
            raise ValueError(f"friction_feedforward: a share >= 0, got {friction_feedforward!r}")
        self.friction_feedforward = share
        self._per_env = []

    def _configure_gains(self) -> None:
        w = per_axis(
            "w", PID_BANDWIDTH_RAD_S if self.bandwidth_rad_s is None else self.bandwidth_rad_s, 5
        )
        if np.any(w <= 0):
            raise ValueError(f"w: must be > 0, got {w.tolist()}")
        zeta = 1.0 if self.damping is None else float(self.damping)
        wi = per_axis(
            "wi",
            PID_INTEGRAL_SHARE * w
            if self.integral_pole_rad_s is None
            else self.integral_pole_rad_s,
            5,
        )
        placed = {"P": w * w + 2 * zeta * w * wi, "I": w * w * wi, "D": 2 * zeta * w + wi}
        for key, value in placed.items():
            user = self._user[key]
            setattr(self, f"K{key.lower()}", per_axis(key, value if user is None else user, 5))
        self.wi = wi
        self.w = w
        self.zeta = zeta

    def configure(self) -> None:
        self._configure_gains()
        lead = self.lead_samples
        self.lead = self.computation_delay_steps if lead is None else int(lead)
        friction = None
        if self.friction_feedforward > 0:
            share = self.friction_feedforward
            friction = (
                share * np.asarray(PID_FRICTION["viscous"], dtype=np.float64),
                share * np.asarray(PID_FRICTION["coulomb"], dtype=np.float64),
                np.asarray(PID_FRICTION["velocity"], dtype=np.float64),
            )
        self._per_env = [
            JointPID(
                _ReferenceOnly(self._setup),
                self.nominal.inertia,
                kp=self.Kp,
                ki=self.Ki,
                kd=self.Kd,
                feedforward=self.feedforward,
                lead=self.lead,
                friction=friction,
            )
            for _ in range(self.n_envs)
        ]

    def reset(self, mask=None) -> None:
        for b, law in enumerate(self._per_env):
            if mask is None or bool(np.asarray(mask).reshape(-1)[b]):
                law.reset()

    def _laws(self):
        return self._per_env


class ISMCController(_FiveAxisController):
    """Equivalent-error integral sliding mode control (Chen 2022, eqs. 6–12;
    :class:`agents.ismc.EquivalentErrorISMC`), one law (with its integral ∫η dt) per env.

    Needs the algebraic path functions p(ξ) of a named five-axis case; a program given only
    as G-code has none: binding raises ValueError (no local fit is made).

    Parameters: b1 (1/s), b2 (1/s²), rho, mu (> 0; default the paper's Table 2 gains of the
    case), tangent_floor_m_s (≥ 0, the regulariser v₀ of the tangential error; default the
    path's peak feed) and predict_delay (default True: the law acts on the state predicted
    over the plant's computation delay with the nominal model; nothing to predict on the
    ideal plant, which has none).
    """

    name = "ismc"
    summary = "Chen 2022's equivalent-error integral sliding mode control; named cases only"
    PARAMETERS = {
        "b1": Param("b1", "b₁ of σ = η̇ + b₁η + b₂∫η, 1/s (default Table 2)", FLOAT, ">0"),
        "b2": Param("b2", "b₂, 1/s² (default Table 2: 800)", FLOAT, ">0"),
        "rho": Param("rho", "switching gain ρ (default Table 2)", FLOAT, ">0"),
        "mu": Param("mu", "boundary layer μ of tanh(σ/μ) (default Table 2)", FLOAT, ">0"),
        "v0": Param(
            "tangent_floor_m_s",
            "tangential-error regulariser v₀, m/s (default the peak feed)",
            FLOAT,
            ">=0",
        ),  # fmt: skip
        "predict": Param(
            "predict_delay",
            "predict the state over the computation delay with the nominal model (default 1)",
            BOOL,
        ),
    }

    def __init__(
        self, b1=None, b2=None, rho=None, mu=None, tangent_floor_m_s=None, predict_delay=True
    ):
        super().__init__()
        self.gains = dict(b1=b1, b2=b2, rho=rho, mu=mu, tangent_floor_m_s=tangent_floor_m_s)
        self.predict_delay = bool(predict_delay)
        self._per_env = []

    def configure(self) -> None:
        path = getattr(self._setup, "five_axis_path", None)
        if path is None:
            raise ValueError(
                f"controller 'ismc': the program {self._setup.name!r} is given only as G-code, "
                "without the algebraic path functions p(ξ) = 0 the equivalent errors need "
                "(Chen 2022 eq. 6); run it with pd, or use a named five-axis case "
                f"({', '.join(PAPER_ISMC_GAINS)})"
            )
        self._per_env = [
            EquivalentErrorISMC(
                path,
                self.nominal.inertia,
                **self.gains,
                computation_delay_steps=self.computation_delay_steps if self.predict_delay else 0,
                drive_limit=self.force_limit,
            )
            for _ in range(self.n_envs)
        ]

    def reset(self, mask=None) -> None:
        for b, law in enumerate(self._per_env):
            if mask is None or bool(np.asarray(mask).reshape(-1)[b]):
                law.reset()

    def _laws(self):
        return self._per_env


class _ReferenceOnly:
    """What JointPD reads of a path: its name and joint reference (a setup has both)."""

    def __init__(self, setup):
        self.name = setup.name
        self.reference = setup.reference
