"""The five-axis laws of Chen, Khong & Hsieh (2022) under the one policy protocol: joint PD
(``pd`` on the five-axis plant) and the equivalent-error ISMC (``ismc``).

The laws themselves are :class:`agents.ismc.JointPD` and :class:`agents.ismc.EquivalentErrorISMC`
(per env, on the nominal model ξ̈ = f + G u); these classes bind them to a five-axis env,
run one per env of a batch on the servo signals (measured joints, backward-difference rates,
reference index) and return the joint command (N, N, N, N·m, N·m).
"""

from __future__ import annotations

import numpy as np

from contour_env.env.core import core_of

from .base import Controller, per_axis
from .ismc import PAPER_ISMC_GAINS, PAPER_PD_GAINS, EquivalentErrorISMC, JointPD
from .parameters import AXES, BOOL, FLOAT, Param

# a five-axis program (G-code) has no paper gains: PD takes the line's
DEFAULT_PD_CASE = "five-axis-line"


class _FiveAxisController(Controller):
    """Base of the five-axis controllers: binds only to the five-axis plant."""

    plant_family = "five-axis"

    def bind(self, env) -> Controller:
        _, core = core_of(env)
        self._setup = core.setup
        return super().bind(env)

    def configure_for(self, plant) -> Controller:
        raise ValueError(f"controller {self.name!r}: no loop analysis for the five-axis plant")

    def _attach(self, plant, n_envs: int) -> None:
        if getattr(plant, "family", None) != "five-axis":
            raise ValueError(
                f"env: controller {self.name!r} (five-axis) needs the five-axis plant; the env "
                f"has the {plant.n_axes}-axis plant {plant.name!r}"
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
    summary = "Chen 2022's joint PD through the nominal model, Kp 800 1/s², Kd 60/310 1/s"
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

    def configure(self) -> None:
        kp, kd = PAPER_PD_GAINS.get(self._setup.name, PAPER_PD_GAINS[DEFAULT_PD_CASE])
        if self.bandwidth_rad_s is not None:
            w = float(self.bandwidth_rad_s)
            zeta = 1.0 if self.damping is None else float(self.damping)
            kp, kd = w * w, 2.0 * zeta * w
        self.Kp = per_axis("P", kp if self._P_user is None else self._P_user, 5)
        self.Kd = per_axis("D", kd if self._D_user is None else self._D_user, 5)
        self.law = JointPD(
            _ReferenceOnly(self._setup), self.nominal.inertia, kp=self.Kp, kd=self.Kd
        )

    def _laws(self):
        return (self.law,)


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
