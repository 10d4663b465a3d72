"""Iterative learning control on top of PD feedback: the learning state, its update between
trials, and the two classical laws ``ilc-pd`` (axial) and ``ilc-contour`` (task frame).

Every learning controller here adds a learned feedforward table to a feedback controller,

    u_j(t) = C(e_j)(t) + u_ff,j(t),        u_ff,j+1(t) = Q[u_ff,j(t) + L e_j(t + λ)],

(j: trial, t: sample, Q: zero-phase low-pass, L: learning operator, λ: lead in samples; the
classical P/PD-type law, REFERENCE §3). L is
written in acceleration units and scaled by the nominal axis masses M,

    L e = M Γ (ω_L² e + 2 ζ_L ω_L ė),

so with Γ = γ I it is γ times the PD feedback law of the same ω, ζ (PD-type ILC with gains
L_p = γ m ω_L², L_d = 2 γ m ζ_L ω_L per axis). ė is the central difference over the whole
trial (zero phase). The learning state (feedforward table, trial count and what it was
learned on) can be saved and loaded to continue a batch another day.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np

from contour_env.env.core import core_of
from contour_env.io import atomic_write_bytes

from .base import Controller
from .parameters import INT, Param
from .pd import PDController, default_bandwidth
from .qfilter import (
    ZeroPhaseLowPass,
    axis_plant_model,
    closed_loop,
    frequency_response,
    servo_loop_model,
)
from .records import attributes
from .repeated_batch import fingerprint_of
from .trial import TrialRecord

STATE_FORMAT = "contour_env.learning_state/1"

# Q-filter cutoff per plant (Hz) of the laws on PD feedback (ilc-pd, ilc-contour): the
# largest whole-Hz cutoff for which the linear learning contracts by at least 20 % per trial
# at every frequency, sup ρ ≤ ``LEARNING_RATE_LIMIT`` (:func:`learning_rate_bound`), with the
# default PD (re-tuned under stability-margin constraints: ω = 75, 80, 150, 400 rad/s), the
# default law at γ = 1 (above every law's default gain: 0.5, 0.8, 0.8), over the ±20 % mass
# corners of the realistic plant (delay, current lag, mismatch) and, where the plant has it,
# with the two-mass mode and the drive-side encoder. Above the cutoff the phase of the
# delayed, lagging loop turns |1 − z^λ L G_ff| above 1 (friction-table from about 40 Hz);
# the margin to 1 leaves room for what the linear model leaves out (friction, quantisation,
# noise, which a rate near 1 would accumulate trial after trial). ``vilcfd`` learns on the
# PD + disturbance-observer loop and has its own table (agents/vilcfd.py).
# tests/agents/test_ilc.py checks the rule.
LEARNING_RATE_LIMIT = 0.8
DEFAULT_Q_CUTOFF_HZ = {
    "hsm2": 34.0,
    "jee-triaxial": 105.0,
    "linear-motor": 181.0,
    "friction-table": 30.0,
}
FALLBACK_Q_CUTOFF_HZ = 20.0


def shift_ahead(x: np.ndarray, lead: int) -> np.ndarray:
    """x(t + λ) along axis 1, the last sample held past the end."""
    if lead <= 0:
        return x
    out = np.empty_like(x)
    out[:, :-lead] = x[:, lead:]
    out[:, -lead:] = x[:, -1:]
    return out


class LearningController(Controller):
    """PD feedback + a learned feedforward table (see the module docstring).

    Parameters
    ----------
    learning_gain : float
        γ, the fraction of the PD law applied per trial (0 < γ ≤ 2; default 0.5).
    learning_bandwidth_rad_s : float, optional
        ω_L of the learning law (rad/s); default the feedback's ω.
    learning_damping : float
        ζ_L (default 1).
    lead_steps : int, optional
        λ (samples); default 1 + the controller's computation delay (the relative degree of
        the sampled force-to-position path is one sample).
    q_cutoff_hz : float, optional
        Cutoff of the zero-phase Butterworth Q-filter (Hz); default per plant
        (``DEFAULT_Q_CUTOFF_HZ``).
    q_order : int
        Q-filter order (default 2, applied forward and backward).
    feedback : Controller, optional
        The feedback controller (default :class:`~agents.pd.PDController` with its per-plant
        gains); ``feedback_bandwidth_rad_s`` sets its ω instead.
    """

    name = "learning"
    # the per-plant Q-filter cutoffs of this law (Hz)
    default_q_cutoff_hz = DEFAULT_Q_CUTOFF_HZ
    # command-line parameters (``ilc-pd:gain=0.8:q=40``; :mod:`agents.parameters`)
    PARAMETERS = {
        "gain": Param(
            "learning_gain",
            "learning gain γ, share of the PD law learned per trial, in (0, 2]",
            check=">0",
        ),
        "wl": Param(
            "learning_bandwidth_rad_s",
            "bandwidth ω_L of the learning law, rad/s (default the feedback's ω)",
            check=">0",
        ),
        "zeta_l": Param(
            "learning_damping", "damping ζ_L of the learning law (default 1)", check=">0"
        ),
        "lead": Param(
            "lead_steps", "lead λ, samples (default 1 + the computation delay)", INT, ">=0"
        ),
        "q": Param("q_cutoff_hz", "Q-filter cutoff, Hz (default per plant)", check=">0"),
        "q_order": Param("q_order", "Q-filter (Butterworth) order (default 2)", INT, ">0"),
        "w": Param(
            "feedback_bandwidth_rad_s",
            "PD feedback bandwidth ω, rad/s (default per plant)",
            check=">0",
        ),
    }

    def __init__(
        self,
        learning_gain: float = 0.5,
        learning_bandwidth_rad_s: float | None = None,
        learning_damping: float = 1.0,
        lead_steps: int | None = None,
        q_cutoff_hz: float | None = None,
        q_order: int = 2,
        feedback: Controller | None = None,
        feedback_bandwidth_rad_s: float | None = None,
    ):
        super().__init__()
        self.learning_gain = _positive("learning_gain", learning_gain, upper=2.0)
        self.learning_bandwidth_rad_s = (
            None
            if learning_bandwidth_rad_s is None
            else _positive("learning_bandwidth_rad_s", learning_bandwidth_rad_s)
        )
        self.learning_damping = _positive("learning_damping", learning_damping)
        if lead_steps is not None and (
            isinstance(lead_steps, bool)
            or not isinstance(lead_steps, (int, np.integer))
            or lead_steps < 0
        ):
            raise ValueError(f"lead_steps: must be an integer >= 0 (samples), got {lead_steps!r}")
        self.lead_steps_arg = lead_steps
        self.q_cutoff_arg = None if q_cutoff_hz is None else _positive("q_cutoff_hz", q_cutoff_hz)
        self.q_order = q_order
        self.feedback = feedback or PDController(bandwidth_rad_s=feedback_bandwidth_rad_s)
        self.u_ff: np.ndarray | None = None
        self.fingerprint: dict | None = None
        self.iteration = 0

    # --- binding --------------------------------------------------------------------------
    def bind(self, env) -> LearningController:
        """Attach to an env. A learning state (learned or loaded) must have been learned on
        the same case, path, length and batch size: otherwise ``ValueError`` and the state is
        left untouched."""
        _, core = core_of(env)
        if self.u_ff is not None:
            self._check_fingerprint(fingerprint_of(core), "env")
            if self.u_ff.shape[0] not in (1, core.n_envs):
                raise ValueError(
                    f"env: the learning state holds {self.u_ff.shape[0]} envs, the env has "
                    f"{core.n_envs}"
                )
        self.feedback.bind(env)
        super().bind(env)
        if self.u_ff is None:
            self.fingerprint = fingerprint_of(core)
            self.u_ff = np.zeros((self.n_envs, core.n_steps - 1, self.n_axes))
        elif self.u_ff.shape[0] != self.n_envs:  # a single-env state continued in a batch
            self.u_ff = np.repeat(self.u_ff, self.n_envs, axis=0)
        return self

    def configure_for(self, plant) -> LearningController:
        self.feedback.configure_for(plant)
        return super().configure_for(plant)

    def loop_gains(self, frame, curvature=0.0, torsion=0.0, feedrate_m_s=0.0):
        """Within a trial the learned table is feedforward: the loop is the feedback's."""
        return self.feedback.loop_gains(frame, curvature, torsion, feedrate_m_s)

    def configure(self) -> None:
        fb = self.feedback
        omega = getattr(fb, "omega", None)
        if omega is None:
            omega = default_bandwidth(self.nominal)[0]
        self.omega_L = self.learning_bandwidth_rad_s or float(omega)
        lead = self.lead_steps_arg
        self.lead_steps = 1 + self.computation_delay_steps if lead is None else int(lead)
        table = self.default_q_cutoff_hz
        fc = self.q_cutoff_arg or table.get(self.nominal.name, FALLBACK_Q_CUTOFF_HZ)
        self.q_filter = ZeroPhaseLowPass(fc, self.servo_period_s, self.q_order)
        self.mass = self.nominal.mass_kg.copy()

    def reset(self, mask=None) -> None:
        self.feedback.reset(mask)

    # --- acting ---------------------------------------------------------------------------
    def feedforward(self, step: np.ndarray) -> np.ndarray:
        """The learned command (B, A) at samples ``step`` (B,)."""
        n = self.u_ff.shape[1]
        idx = np.minimum(np.asarray(step, dtype=np.int64), n - 1)
        return self.u_ff[np.arange(self.u_ff.shape[0]), idx]

    def act(self, signals: dict) -> np.ndarray:
        return self.feedback.act(signals) + self.feedforward(signals["step"])

    # --- learning -------------------------------------------------------------------------
    def _pd_acceleration(self, e: np.ndarray, T: float) -> np.ndarray:
        """ω_L² e + 2 ζ_L ω_L ė (m/s²), ė by central differences along the samples."""
        de = np.gradient(e, T, axis=1) if e.shape[1] > 1 else np.zeros_like(e)
        w, z = self.omega_L, self.learning_damping
        return w * w * e + 2.0 * z * w * de

    def learning_signal(self, trial: TrialRecord) -> np.ndarray:
        """L e_j(t) before the lead shift, (B, N, A) in plant units."""
        raise NotImplementedError

    def learn(self, trial: TrialRecord) -> None:
        """u_ff ← Q[u_ff + L e(t + λ)] from one trial. A trial of another case, path, length
        or batch size raises ``ValueError`` and leaves the state untouched; an env whose trial
        was stopped by the crash guard keeps its previous table."""
        if self.u_ff is None:
            raise ValueError("learn: bind the controller to an env and run a trial first")
        self._check_fingerprint(trial.fingerprint, "trial")
        if trial.n_envs != self.u_ff.shape[0]:
            raise ValueError(
                f"trial: {trial.n_envs} envs, the learning state holds {self.u_ff.shape[0]}"
            )
        correction = shift_ahead(self.learning_signal(trial), self.lead_steps)
        new = self.q_filter(self.u_ff + correction, axis=1)
        ok = np.array([r is None for r in trial.termination_reason]) & np.all(
            np.isfinite(new), axis=(1, 2)
        )
        self.u_ff = np.where(ok[:, None, None], new, self.u_ff)
        self.iteration += 1

    def _check_fingerprint(self, fp: dict, what: str) -> None:
        if self.fingerprint is None or fp == self.fingerprint:
            return
        diff = [k for k in self.fingerprint if fp.get(k) != self.fingerprint.get(k)]
        details = ", ".join(
            f"{k}: state {self.fingerprint[k]!r}, {what} {fp.get(k)!r}" for k in diff
        )
        raise ValueError(
            f"{what}: does not match the learning state (learned on case "
            f"{self.fingerprint['case']!r}, {self.fingerprint['n_samples']} samples); differs in "
            f"{details}. The learning state is unchanged; use a new controller (or "
            "reset_learning()) for another contour."
        )

    def reset_learning(self) -> None:
        """Forget the learned table (the next bind starts from zero)."""
        self.u_ff = None
        self.fingerprint = None
        self.iteration = 0

    # --- saving ---------------------------------------------------------------------------
    def hyperparameters(self) -> dict:
        return {
            **attributes(self, "learning_gain", "learning_bandwidth_rad_s", "learning_damping"),
            "lead_steps": self.lead_steps_arg,
            "q_cutoff_hz": self.q_cutoff_arg,
            "q_order": self.q_order,
        }

    def save(self, path) -> Path:
        """Write the learning state (``.npz``; atomically)."""
        if self.u_ff is None:
            raise ValueError("save: nothing learned yet (bind and run a trial first)")
        meta = {
            "format": STATE_FORMAT,
            "controller": self.name,
            "hyperparameters": self.hyperparameters(),
            "fingerprint": self.fingerprint,
            "iteration": self.iteration,
        }
        buf = io.BytesIO()
        np.savez_compressed(buf, u_ff=self.u_ff, meta=np.array(json.dumps(meta)))
        return atomic_write_bytes(path, buf.getvalue())

    def load_state(self, path) -> LearningController:
        """Read a learning state written by :meth:`save` into this controller. A file of
        another controller, a corrupt file or (if bound) another contour → ``ValueError``,
        nothing changed."""
        meta, u_ff = read_state(path)
        if meta["controller"] != self.name:
            raise ValueError(
                f"{path}: a learning state of {meta['controller']!r}, not of {self.name!r}"
            )
        if self._core is not None:
            current = fingerprint_of(self._core)
            if meta["fingerprint"] != current:
                saved, self.fingerprint = self.fingerprint, meta["fingerprint"]
                try:
                    self._check_fingerprint(current, "env")
                finally:
                    self.fingerprint = saved
            if u_ff.shape[0] not in (1, self.n_envs):
                raise ValueError(f"{path}: holds {u_ff.shape[0]} envs, the env has {self.n_envs}")
            if u_ff.shape[0] != self.n_envs:
                u_ff = np.repeat(u_ff, self.n_envs, axis=0)
        self.u_ff = u_ff
        self.fingerprint = meta["fingerprint"]
        self.iteration = int(meta["iteration"])
        return self


def read_state(path) -> tuple[dict, np.ndarray]:
    """(metadata, feedforward table) of a saved learning state; ``ValueError`` if the file is
    not one (missing, truncated, another format)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"learning state: no such file {str(path)!r}")
    try:
        with np.load(path, allow_pickle=False) as data:
            meta = json.loads(str(data["meta"]))
            u_ff = np.array(data["u_ff"], dtype=np.float64)
    except Exception as exc:  # zipfile, KeyError, JSON errors: all mean "not a state file"
        raise ValueError(
            f"learning state {str(path)!r}: unreadable or not a contour_env learning state "
            f"({type(exc).__name__}: {exc})"
        ) from None
    if meta.get("format") != STATE_FORMAT or u_ff.ndim != 3 or not np.all(np.isfinite(u_ff)):
        raise ValueError(f"learning state {str(path)!r}: not a {STATE_FORMAT} file")
    return meta, u_ff


def _positive(name: str, value, upper: float | None = None) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name}: expected a number, got {value!r}")
    v = float(value)
    if not (np.isfinite(v) and v > 0 and (upper is None or v <= upper)):
        rng = f"in (0, {upper}]" if upper is not None else "> 0"
        raise ValueError(f"{name}: must be {rng}, got {value!r}")
    return v


class ILCPDController(LearningController):
    """``ilc-pd``: axial PD-type ILC on top of PD feedback,

        u_ff,j+1(t) = Q[u_ff,j(t) + M γ (ω_L² e_j + 2 ζ_L ω_L ė_j)(t + λ)],

    e = x_d − x per axis from the encoder — the classical ILC on the axis tracking errors only
    (u_{k+1}(t) = Q[u_k(t) + L e_k(t + 1)], REFERENCE §3). Parameters as
    :class:`LearningController`.
    """

    name = "ilc-pd"

    def learning_signal(self, trial: TrialRecord) -> np.ndarray:
        a = self._pd_acceleration(trial.axis_error, trial.servo_period_s)
        return self.learning_gain * self.mass * a


def _direction_gain(direction: str, default: float) -> Param:
    """The command-line parameter of the learning gain along one direction of the path
    frame (``ilc-contour:gn=0.5``)."""
    return Param(
        f"{direction}_gain",
        f"learning gain γ_{direction[0]}, {direction}, in (0, 2] (default {default})",
        check=">0",
    )


class ILCContourController(LearningController):
    """``ilc-contour``: contouring ILC that learns on the task-frame errors.

    e_l = Fᵀ e (tangential, normal(, binormal); Lee 2012 eq. 3, Simba 2018 eq. 2), learned
    with a gain per direction and mapped back to the axes through the frame of the same
    sample:

        u_ff,j+1(t) = Q[u_ff,j(t) + M F Γ (ω_L² e_l + 2 ζ_L ω_L ė_l)(t + λ)],
        Γ = diag(γ_t, γ_n(, γ_b)).

    The contour error is the normal (and binormal) part, so those learn hardest; the
    tangential (lag) error matters only through the corners it cuts. Learning on both the
    tracking (tangential) and the contour (normal) error, this is the closest of our laws to
    the conventional ILC Simba et al. 2018 compare VILCFD against (their Ref. [25], an ILC
    that considers tracking and contour errors).

    Parameters
    ----------
    tangential_gain, normal_gain, binormal_gain : float
        γ_t, γ_n, γ_b (defaults 0.3, 0.8, 0.8). Other parameters as
        :class:`LearningController` (``learning_gain`` is not used).
    """

    name = "ilc-contour"
    PARAMETERS = {
        **{k: v for k, v in LearningController.PARAMETERS.items() if k != "gain"},
        "gt": _direction_gain("tangential", 0.3),
        "gn": _direction_gain("normal", 0.8),
        "gb": _direction_gain("binormal", 0.8),
    }

    def __init__(self, tangential_gain=0.3, normal_gain=0.8, binormal_gain=0.8, **kwargs):
        super().__init__(**kwargs)
        self.tangential_gain = _positive("tangential_gain", tangential_gain, upper=2.0)
        self.normal_gain = _positive("normal_gain", normal_gain, upper=2.0)
        self.binormal_gain = _positive("binormal_gain", binormal_gain, upper=2.0)

    def hyperparameters(self) -> dict:
        return {
            **super().hyperparameters(),
            "tangential_gain": self.tangential_gain,
            "normal_gain": self.normal_gain,
            "binormal_gain": self.binormal_gain,
        }

    def direction_gains(self, trial: TrialRecord) -> np.ndarray:
        """Γ as (B, N, A) (constant here; :class:`~agents.vilcfd.VILCFDController` varies it)."""
        g = np.array([self.tangential_gain, self.normal_gain, self.binormal_gain][: self.n_axes])
        return np.broadcast_to(g, trial.task_error.shape)

    def learning_signal(self, trial: TrialRecord) -> np.ndarray:
        a_l = self._pd_acceleration(trial.task_error, trial.servo_period_s)
        a_l = self.direction_gains(trial) * a_l
        a_w = np.einsum("nij,bnj->bni", trial.frame, a_l)
        return self.mass * a_w


def learning_rate_bound(
    plant,
    q_cutoff_hz: float | None,
    *,
    learning_gain: float = 1.0,
    q_order: int = 2,
    structural_mode: bool = False,
    mass_variation: float = 0.2,
    dob_bandwidth_rad_s: float = 0.0,
    dob_order: int = 4,
    lead_steps: int | None = None,
) -> dict:
    """Worst per-trial contraction of the learning, linear part, on the realistic plant.

    For the default PD feedback (with ``dob_bandwidth_rad_s`` > 0 also ``vilcfd``'s
    disturbance observer), the default learning law of one axis, L = γ m (ω_L² + 2 ω_L δ),
    δ the central difference, ω_L the PD's ω, the lead λ = 1 + delay, and the zero-phase
    Butterworth Q of ``q_cutoff_hz`` (None: no Q), the learned table evolves from trial to
    trial as u_{j+1} = Q (1 − z^λ L G_ff) u_j + …, G_ff the closed loop from the feedforward
    to the measured position. Its rate per frequency,

        ρ(ω) = |Q(e^{iωT})| · |1 − e^{iωλT} L G_ff(e^{iωT})|,

    below 1 everywhere means the error converges monotonically (sufficient condition, in the
    2-norm over the trial). Returned: ``{"rate": sup ρ, "frequency_hz": where}``, the worst
    over the axes and the true masses scaled by 1 ± ``mass_variation`` and 1 (with
    ``structural_mode`` the two-mass mode and the drive-side encoder).
    """
    from contour_env.plants import Plant

    pl = plant if isinstance(plant, Plant) else Plant(plant, structural_mode=structural_mode)
    pd = PDController()
    pd.configure_for(pl)
    nom, T = pl.nominal, pl.servo_period_s
    delay = int(pl.params.computation_delay)
    lead = 1 + delay if lead_steps is None else int(lead_steps)
    w = np.linspace(0.5, np.pi / T * (1 - 1e-3), 3000)
    z = np.exp(1j * w * T)
    f = w / (2 * np.pi)
    if q_cutoff_hz is None:
        q = np.ones_like(f)
    else:  # forward and backward: the squared magnitude of the Butterworth filter
        q = 1.0 / (1.0 + (f / q_cutoff_hz) ** (2 * q_order))
    worst, where = 0.0, 0.0
    for i in range(pl.n_axes):
        m = nom.mass_kg[i]
        K = servo_loop_model(
            pd.P[i], pd.D[i], m, nom.viscous_Ns_m[i], dob_bandwidth_rad_s, dob_order, T, delay
        )
        wl = pd.omega
        L = learning_gain * m * (wl**2 + 2 * wl * (z - 1 / z) / (2 * T))
        for scale in (1.0 - mass_variation, 1.0, 1.0 + mass_variation):
            p = pl.params.replace(mass_kg=pl.params.mass_kg * scale)
            G = frequency_response(*closed_loop(*axis_plant_model(p, i), K), 0.0, z)
            rho = q * np.abs(1.0 - z**lead * L * G)
            k = int(np.argmax(rho))
            if rho[k] > worst:
                worst, where = float(rho[k]), float(f[k])
    return {"rate": worst, "frequency_hz": where}


__all__ = [
    "DEFAULT_Q_CUTOFF_HZ",
    "ILCContourController",
    "ILCPDController",
    "LearningController",
    "learning_rate_bound",
    "read_state",
    "shift_ahead",
]
